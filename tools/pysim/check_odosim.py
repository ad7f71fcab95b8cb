#!/usr/bin/python3
"""Self-check of odosim.py: generate drives, re-read them with a minimal odolog v1 parser of its
own (check_base.py), and verify them.

    python3 tools/pysim/check_odosim.py

Checks
  * every generated file follows odolog v1: `odolog 1` first, header records before data,
    the drive's params present and unique, scans with N ranges, integer encoder counts,
    times non-decreasing and enc < scan < truth at equal times;
  * clean drives (diff and sync, 1 minute): > 99 % of the beams agree with a ray cast from
    the truth pose within 5 sigma; the robot stays > 1 m from every wall; at least two
    direction reversals and turns of both signs;
  * an effect drive (range_bias=0.1, turn_slip=0.03): its meta truth_effect records, and the
    range residuals are centred on the injected bias;
  * the CLI refuses an unknown effect and a wrong value count with exit status 2, and a
    per-wheel effect on the sync drive;
  * per-wheel and out-of-catalogue forms: each form's formula recovered from the truth
    (check_forms.py says how);
  * map errors (--map-error): objects, a phantom and a shifted wall, each where its
    definition puts it (check_map_errors.py says how); the CLI refuses bad map errors with
    exit status 2, and --list-map-errors lists the three kinds.
Exits 1 with a message naming each failed check. The rooms: check_base.py (the tally, the
reader, the ray cast), check_forms.py, check_map_errors.py.
"""

import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
# The simulator's modules (odosim.py is the command, these its rooms) and the self-check's.
import effect_table as sim_effects  # noqa: E402
from check_base import LogError, check, failures, read_log, residuals  # noqa: E402
from check_forms import check_beam_forms, check_robot_forms, check_wheel_forms  # noqa: E402
from check_map_errors import check_map_errors, map_error_args  # noqa: E402
ODOSIM = os.path.join(HERE, "odosim.py")


def min_wall_distance(log):
    p = log["truth"][:, 1:3]
    best = math.inf
    for x1, y1, x2, y2 in log["walls"]:
        a, e = np.array([x1, y1]), np.array([x2 - x1, y2 - y1])
        u = np.clip(((p - a) @ e) / (e @ e), 0.0, 1.0)
        best = min(best, float(np.hypot(*(p - a - u[:, None] * e).T).min()))
    return best


def motion_stats(log):
    """(reversals, max and min 1 s turn rate) from the truth."""
    tr = log["truth"]
    d = np.diff(tr[:, 1:3], axis=0)
    th = tr[:-1, 3]
    dt = np.diff(tr[:, 0])
    v = (d[:, 0] * np.cos(th) + d[:, 1] * np.sin(th)) / dt
    v = np.convolve(v, np.ones(10) / 10, mode="valid")       # 0.1 s average
    reversals, sign = 0, 0
    for vi in v:
        if abs(vi) > 0.05:                                    # hysteresis
            s = 1 if vi > 0 else -1
            reversals += sign != 0 and s != sign
            sign = s
    heading = np.unwrap(tr[:, 3])
    n = int(round(1.0 / np.median(dt)))
    w = (heading[n:] - heading[:-n]) / (tr[n:, 0] - tr[:-n, 0])
    return reversals, float(w.max()), float(w.min())


def generate(path, *args):
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, ODOSIM, "--out", path, *args],
                       capture_output=True, text=True)
    dt = time.perf_counter() - t0
    check(p.returncode == 0, f"odosim {' '.join(args)} ran ({dt:.2f} s)"
          + ("" if p.returncode == 0 else ": " + p.stderr.strip()))
    return p.returncode == 0


def check_clean(path, label):
    try:
        log = read_log(path)
    except LogError as e:
        check(False, f"{label}: valid odolog v1 ({e})")
        return
    check(True, f"{label}: valid odolog v1 header, times non-decreasing, record order")
    check(len(log["enc"]) == 6001 and len(log["truth"]) == 6001 and len(log["scan"]) == 600,
          f"{label}: 100 Hz enc/truth and 10 Hz scans "
          f"({len(log['enc'])}, {len(log['truth'])}, {len(log['scan'])})")
    check(np.allclose(log["init"][:3], log["truth"][0, 1:]),
          f"{label}: init is the true start pose")
    res, total = residuals(log)
    sigma = log["laser"][4]
    frac = np.mean(np.abs(res) < 5 * sigma) * len(res) / total
    check(frac > 0.99, f"{label}: {100 * frac:.2f} % of beams within 5 sigma of the ray cast "
          f"(residual mean {1000 * res.mean():+.2f} mm, std {1000 * res.std():.1f} mm)")
    clear = min_wall_distance(log)
    check(clear > 1.0, f"{label}: minimum wall clearance {clear:.2f} m > 1 m")
    rev, wmax, wmin = motion_stats(log)
    check(rev >= 2, f"{label}: {rev} direction reversals (>= 2)")
    check(wmax > 0.2 and wmin < -0.2,
          f"{label}: turns both ways (1 s turn rate {wmin:+.2f} .. {wmax:+.2f} rad/s)")


def main():
    t0 = time.perf_counter()
    check_wheel_forms()
    check_robot_forms()
    check_beam_forms()
    print(f"(in-process form checks: {time.perf_counter() - t0:.2f} s)")

    with tempfile.TemporaryDirectory() as tmp:
        clean = os.path.join(tmp, "clean.odolog")
        if generate(clean, "--minutes", "1", "--seed", "3"):
            check_clean(clean, "clean diff")
        sync = os.path.join(tmp, "sync.odolog")
        if generate(sync, "--minutes", "1", "--seed", "4", "--drive", "sync"):
            check_clean(sync, "clean sync")

        eff = os.path.join(tmp, "effect.odolog")
        if generate(eff, "--minutes", "1", "--seed", "3", "--effect", "range_bias=0.1",
                    "--effect", "turn_slip=0.03"):
            try:
                log = read_log(eff)
                check(True, "effect diff: valid odolog v1")
                metas = [m for m in log["meta"] if m[0] == "truth_effect"]
                check(["truth_effect", "range_bias", "0.1"] in metas
                      and ["truth_effect", "turn_slip", "0.03"] in metas,
                      f"effect diff: meta truth_effect records {metas}")
                res, _ = residuals(log)
                med = float(np.median(res))
                check(abs(med - 0.1) < 0.01,
                      f"effect diff: range residual median {med:.4f} m ~ injected 0.1 m")
            except LogError as e:
                check(False, f"effect diff: valid odolog v1 ({e})")

        ooc = os.path.join(tmp, "ooc.odolog")
        clean4 = os.path.join(tmp, "clean4.odolog")
        if (generate(ooc, "--minutes", "1", "--seed", "4", "--effect",
                     "ooc_incidence_bias=0.015", "--effect", "ooc_range_time_drift=1e-4")
                and generate(clean4, "--minutes", "1", "--seed", "4")):
            try:
                log, log0 = read_log(ooc), read_log(clean4)
                metas = [m for m in log["meta"] if m[0] == "truth_effect"]
                check(["truth_effect", "ooc_incidence_bias", "0.015"] in metas
                      and ["truth_effect", "ooc_range_time_drift", "0.0001"] in metas,
                      f"ooc diff: valid odolog v1, meta truth_effect records {metas}")
                same = (np.array_equal(log["enc"], log0["enc"])
                        and np.array_equal(log["truth"], log0["truth"]))
                d = log["scan"][:, 1:] - log0["scan"][:, 1:]
                drift = d - 1e-4 * log["scan"][:, :1]
                check(same and np.nanmin(drift) > -1e-5,
                      "ooc diff: same seed, same encoders and truth as the clean drive; "
                      f"ranges differ by c t plus a non-negative incidence bias "
                      f"(median {1e3 * np.nanmedian(drift):.2f} mm)")
            except LogError as e:
                check(False, f"ooc diff: valid odolog v1 ({e})")
        mapped = os.path.join(tmp, "map.odolog")
        if generate(mapped, "--minutes", "1", "--seed", "3", *map_error_args()):
            try:
                check_map_errors(read_log(mapped), read_log(clean))
            except (LogError, OSError) as e:
                check(False, f"map errors: valid odolog v1 ({e})")
        p = subprocess.run([sys.executable, ODOSIM, "--list-map-errors"], capture_output=True,
                           text=True)
        listed = {line.split()[0] for line in p.stdout.splitlines() if line.strip()}
        check(p.returncode == 0 and {"object", "phantom", "shift"} <= listed,
              "--list-map-errors lists object, phantom, shift")
        p = subprocess.run([sys.executable, ODOSIM, "--list-effects"], capture_output=True,
                           text=True)
        listed = {line.split()[0] for line in p.stdout.splitlines() if line.strip()}
        want = set(sim_effects.TEST_SIZES)
        check(p.returncode == 0 and len(want) >= 10 and want <= listed,
              f"--list-effects lists the {len(want)} per-wheel and out-of-catalogue forms")

        bad = os.path.join(tmp, "bad.odolog")
        for args in (["--effect", "no_such_effect=1"], ["--effect", "laser_mount_xy=0.1"],
                     ["--drive", "sync", "--effect", "wheel_backlash=0.01,0.01"],
                     ["--drive", "sync", "--effect", "ooc_one_wheel_drag=0.05"],
                     ["--effect", "ooc_world_drift=0.01"],
                     ["--map-error", "object=4.3,5.2,0.3,0.3"],      # on the path
                     ["--map-error", "object=7,2,0,0.5"],
                     ["--map-error", "object=7,2,0.5"],
                     ["--map-error", "phantom=2,2,2,2"],
                     ["--map-error", "shift=12,0.1"],
                     ["--map-error", "shift=0.5,0.1"],
                     ["--map-error", "shift=0,nan"],
                     ["--map-error", "shift=0,0.1", "--map-error", "shift=0,0.2"],
                     ["--map-error", "door=1,2"]):
            p = subprocess.run([sys.executable, ODOSIM, "--out", bad, *args],
                               capture_output=True, text=True)
            check(p.returncode == 2 and "error" in p.stderr,
                  f"CLI refuses {' '.join(args)} with exit 2 (got {p.returncode})")

    if failures:
        print(f"\ncheck_odosim: {len(failures)} check(s) FAILED:", file=sys.stderr)
        for f in failures:
            print("  - " + f, file=sys.stderr)
        return 1
    print("\ncheck_odosim: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())

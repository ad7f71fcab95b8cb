#!/usr/bin/env python3
"""Relocalisation from a wrong start on a simulated building (odoerr replay --relocalise).

  check_relocalise.py ODOERR WORKDIR

A diff-drive robot drives a loop through an L-shaped building of rooms and pillars
(`odoerr sim --map`); its log's `init` is then moved 0.8 m and 0.35 rad off the truth with a
sigma that claims 1 cm. Checks: without --relocalise the track stays wrong (the failure the
rule exists for); with it the loss is declared, recovered, and the pose after the recovery
is within 5 cm of the truth from 1 s after it. Kidnapped: the start put in another room, 13 m
off and turned 2 rad: no window around the filter's pose holds the robot, the whole-map search
finds it (found_by "map"), and the pose is again within 5 cm. On the log with its true start no
loss is declared. Exits 1 when a check fails.
"""
import json
import math
import os
import subprocess
import sys

WALLS = [  # an L-shaped building: outer walls, two rooms, pillars (no symmetry)
    (0, 0, 20, 0), (20, 0, 20, 8), (20, 8, 9, 8), (9, 8, 9, 14), (9, 14, 0, 14), (0, 14, 0, 0),
    (6, 0, 6, 3.5), (6, 5, 6, 8), (0, 8, 4, 8), (5.2, 8, 6, 8), (13, 0, 13, 2.5), (13, 4, 13, 5),
    (15.5, 5, 15.5, 5.6), (15.5, 5.6, 16.1, 5.6), (16.1, 5.6, 16.1, 5), (16.1, 5, 15.5, 5),
    (3, 11, 3.5, 11), (3.5, 11, 3.5, 11.7), (3.5, 11.7, 3, 11.7), (3, 11.7, 3, 11),
    (17.5, 1.5, 18.5, 1.5)]
PATH = [(2.5, 2.0), (4.5, 4.3), (8.5, 4.3), (11.5, 6.0), (17.0, 6.8), (18.3, 3.5), (15.0, 3.2),
        (9.5, 3.2), (7.5, 6.5), (5.2, 9.5), (4.5, 12.5), (1.5, 10.5), (4.6, 9.0), (4.6, 7.0), (2.0, 5.5),
        (2.5, 2.0)]


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr}")
    return r


def replay(odoerr, log, out, reloc):
    run([odoerr, "replay", log, "--out", out] + (["--relocalise"] if reloc else []))
    rep = json.load(open(os.path.join(out, "replay.json")))
    rows = []
    with open(os.path.join(out, "estimates.csv")) as f:
        head = next(f).strip().split(",")
        ix, iy, tx, ty = head.index("x"), head.index("y"), head.index("truth_x"), head.index("truth_y")
        for line in f:
            p = line.strip().split(",")
            if p[tx]:
                rows.append((float(p[0]), math.hypot(float(p[ix]) - float(p[tx]), float(p[iy]) - float(p[ty]))))
    return rep, rows


def moved_start(src, dst, move):
    """dst: the log src with its init moved by move(x, y, theta) and a sigma claiming 1 cm."""
    with open(src) as f, open(dst, "w") as g:
        for line in f:
            if line.startswith("init "):
                w = line.split()
                x, y, th = move(float(w[1]), float(w[2]), float(w[3]))
                line = f"init {x:.6f} {y:.6f} {th:.6f} 0.01 0.01 0.01\n"
            g.write(line)
    return dst


def worst_after_recovery(eps, rows):
    """(the last recovery's time, the largest position error from 1 s after it)."""
    t_rec = eps[-1]["t_recovered"]
    after = [e for t, e in rows if t > t_rec + 1.0]
    return t_rec, max(after) if after else float("inf")


def main():
    odoerr, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    mp = os.path.join(work, "building.odomap")
    with open(mp, "w") as f:
        f.write("odomap 1\nmeta source tests/calibrate/check_relocalise.py (an L-shaped building)\n")
        f.writelines(f"segment {a} {b} {c} {d}\n" for a, b, c, d in WALLS)
    path = os.path.join(work, "path.txt")
    with open(path, "w") as f:
        f.writelines(f"{x} {y}\n" for x, y in PATH)
    good = os.path.join(work, "drive.odolog")
    run([odoerr, "sim", "--map", mp, "--path", path, "--out", good, "--seed", "7"])
    bad = moved_start(good, os.path.join(work, "wrong_start.odolog"), lambda x, y, th: (x + 0.6, y - 0.53, th + 0.35))
    fails = 0

    def check(ok, what):
        nonlocal fails
        print(("ok   " if ok else "FAIL ") + what)
        fails += not ok

    rep, rows = replay(odoerr, bad, os.path.join(work, "plain"), False)
    late = [e for t, e in rows[len(rows) // 2:]]
    check(sum(late) / len(late) > 0.3, f"without --relocalise the wrong start is never undone: mean error over the "
                                       f"second half {sum(late) / len(late):.2f} m")
    rep, rows = replay(odoerr, bad, os.path.join(work, "reloc"), True)
    tr = rep["tracking"]
    eps = tr["episodes"]
    check(tr["lost_episodes"] >= 1 and tr["recovered"] == tr["lost_episodes"] and not tr["lost"],
          f"with --relocalise: {tr['lost_episodes']} lost, {tr['recovered']} recovered, lost at the end {tr['lost']}")
    if eps and eps[-1]["t_recovered"] is not None:
        t_rec, worst = worst_after_recovery(eps, rows)
        check(worst < 0.05, f"from 1 s after the recovery at t={t_rec:.1f} s (jump {eps[-1]['jump_m']:.2f} m, "
                            f"{eps[-1]['jump_rad']:.2f} rad) the pose stays within {worst * 100:.1f} cm of the truth")
        check(eps[0]["t_lost"] < 0.2 * rows[-1][0], f"the loss is declared early: t={eps[0]['t_lost']:.1f} s of "
                                                     f"{rows[-1][0]:.0f} s")
    # Kidnapped: the start placed in another room, 13 m off and turned 2 rad, again claiming
    # 1 cm. No window around the filter's pose holds the robot; the whole-map search must.
    far = moved_start(good, os.path.join(work, "kidnapped.odolog"), lambda x, y, th: (15.0, 6.5, th + 2.0))
    rep, rows = replay(odoerr, far, os.path.join(work, "kidnapped"), True)
    tr = rep["tracking"]
    eps = tr["episodes"]
    check(tr["lost_episodes"] >= 1 and not tr["lost"] and eps and eps[-1]["found_by"] == "map",
          f"kidnapped: {tr['lost_episodes']} lost, {tr['recovered']} recovered, the last found by "
          f"{eps[-1]['found_by'] if eps else None} after {eps[-1]['map_searches'] if eps else 0} whole-map search(es)")
    if eps and eps[-1]["t_recovered"] is not None:
        t_rec, worst = worst_after_recovery(eps, rows)
        check(worst < 0.05, f"kidnapped: from 1 s after the recovery at t={t_rec:.1f} s (jump {eps[-1]['jump_m']:.2f} m) "
                            f"the pose stays within {worst * 100:.1f} cm of the truth")
    rep, rows = replay(odoerr, good, os.path.join(work, "clean"), True)
    tr = rep["tracking"]
    check(tr["lost_episodes"] == 0 and tr["fit_median"] > 0.8,
          f"the true start: no loss declared ({tr['lost_episodes']}), median fit {tr['fit_median']:.2f}")
    print(f"\n{'all checks passed' if fails == 0 else f'{fails} check(s) failed'}")
    sys.exit(1 if fails else 0)


if __name__ == "__main__":
    main()

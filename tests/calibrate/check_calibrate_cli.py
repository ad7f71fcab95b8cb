#!/usr/bin/env python3
"""`odoerr calibrate` end to end.

  check_calibrate_cli.py ODOERR WORKDIR

Always: a file that is neither an odolog nor a CARMEN log is refused (exit 2, FILE:LINE).
With the CARMEN data (import_common.data_dir(): $ODOERR_DATA, else ../shared/data; skipped
with a message, exit 77, without it): the Intel lab's first 300 scans, no option but the
crop: the contract's keys are there, the robot is tracked (not lost, pose RMS at the
corrected poses <= 0.15 m), every setting says why, and the calibration is NOT trusted with
the growth as its reason (on 150 scans K_w predicts the checked half's growth 3x off), which
the printed summary says too.
"""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "import"))
import import_common  # noqa: E402


def main():
    odoerr, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    fails = 0

    def check(ok, what):
        nonlocal fails
        print(("ok   " if ok else "FAIL ") + what)
        fails += not ok

    junk = os.path.join(work, "junk.txt")
    with open(junk, "w") as f:
        f.write("\n# a comment\nhello world\n")
    r = subprocess.run([odoerr, "calibrate", junk, "--out", os.path.join(work, "junk")], capture_output=True,
                       text=True)
    check(r.returncode == 2 and f"{junk}:3:" in r.stderr, f"not a log: exit {r.returncode}, {r.stderr.strip()}")
    d = import_common.find_data("carmen/intel-corrected.log.gz", sample=False)
    if not d:
        print(import_common.skip_message("odoerr calibrate on the Intel lab", "carmen/intel-corrected.log.gz"))
        sys.exit(1 if fails else 77)
    log = os.path.join(d, "carmen/intel-corrected.log.gz")
    out = os.path.join(work, "intel300")
    r = subprocess.run([odoerr, "calibrate", log, "--out", out, "--max-scans", "300", "--no-report"],
                       capture_output=True, text=True)
    check(r.returncode == 0, f"odoerr calibrate --max-scans 300: exit {r.returncode} {r.stderr.strip()[-300:]}")
    if r.returncode != 0:
        sys.exit(1)
    c = json.load(open(os.path.join(out, "calibration.json")))
    t = c["tracking"]
    keys = all(k in t for k in ("pose_rmse_at_truth_m", "heading_rmse_at_truth_rad", "lost", "lost_episodes",
                                "recovered")) and \
        all(k in c["calibration"] for k in ("trusted", "reason", "constants", "sigma")) and \
        all(k in c["rpe_5m_second_half"] for k in ("nominal", "calibrated")) and "settings" in c
    check(keys, "the contract's keys: tracking, calibration, rpe_5m_second_half, settings")
    check(not t["lost"] and t["pose_rmse_at_truth_m"] <= 0.15,
          f"tracked: lost {t['lost']}, {t['lost_episodes']} episodes, pose RMS {t['pose_rmse_at_truth_m']:.3f} m")
    whys = [k for k, v in c["settings"].items() if isinstance(v, dict) and "why" in v and not v["why"]]
    check(not whys and all(k in c["settings"] for k in ("range_sigma_m", "k0_m", "param_sigma", "order_beams")),
          "every setting chosen says why: " + ", ".join(f"{k} {v['value']:.3g}" for k, v in c["settings"].items()
                                                        if k in ("range_sigma_m", "k0_m")))
    cal = c["calibration"]
    check(not cal["trusted"] and "growth" in cal["reason"] and "NOT TRUSTED" in r.stdout and
          cal["use"] == cal["nominal"],
          f"not trusted, the nominal constants stand: {cal['reason']}")
    print(f"\n{'all checks passed' if fails == 0 else f'{fails} check(s) failed'}")
    sys.exit(1 if fails else 0)


if __name__ == "__main__":
    main()

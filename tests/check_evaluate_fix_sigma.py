#!/usr/bin/env python3
"""cli.evaluate_fix_sigma_auto: on a simulated pose-fix log whose fixes carry noise of known
sigma but declare ten times it, `odoerr evaluate --fix-sigma auto` lands within 25 % of the
true sigma, reports how it chose, and the calibration's pose-fix NIS per dof is near 1.

Usage: check_evaluate_fix_sigma.py EVALUATE.json TRUE_SIGMA_XY TRUE_SIGMA_THETA
"""
import json
import sys


def main():
    j = json.load(open(sys.argv[1]))
    true_xy, true_th = float(sys.argv[2]), float(sys.argv[3])
    fs = j["calibrated"]["fix_sigma"]
    nis = j["calibrated"]["pose_fix_nis"]
    bad = []
    if fs["mode"] != "auto":
        bad.append("fix_sigma.mode is %r, not auto" % fs["mode"])
    for key, true in (("sigma_xy_m", true_xy), ("sigma_theta_rad", true_th)):
        v = fs[key]
        if not (true / 1.25 <= v <= true * 1.25):
            bad.append("%s %.4g is not within 25 %% of the true %.4g" % (key, v, true))
    if not fs["trace"] or "rule" not in fs:
        bad.append("fix_sigma has no trace or rule")
    if not nis["fixes"] or not (0.8 <= nis["per_dof"] <= 1.25):
        bad.append("calibration pose-fix NIS per dof %s over %s fixes, not near 1" % (nis["per_dof"], nis["fixes"]))
    print("chosen %.4g m, %.4g rad (true %.4g, %.4g); NIS per dof %.3f over %d fixes" % (
        fs["sigma_xy_m"], fs["sigma_theta_rad"], true_xy, true_th, nis["per_dof"], nis["fixes"]))
    for b in bad:
        print("FAIL:", b)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

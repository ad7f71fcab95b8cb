#!/usr/bin/env python3
"""cli.evaluate_growth_default: `odoerr evaluate` with its defaults on a simulated pose-fix
log whose fixes declare ten times their noise. The default measures the fixes' noise in the
fixes themselves (--fix-sigma measured): within 25 % of the truth, the JSON says so and why,
and the growth K_w predicts on a held-out drive is within 1.5x of the one observed and
reported trusted. The same run with the logs' declared sigmas (--fix-sigma logs, the old
default: observed/predicted 2.4 here) is reported untrusted, with a reason.

Usage: check_evaluate_growth_default.py DEFAULT.json LOGS.json TRUE_SIGMA_XY TRUE_SIGMA_THETA
"""
import json
import sys


def main():
    d, lg = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
    true_xy, true_th = float(sys.argv[3]), float(sys.argv[4])
    bad = []
    fs = d["calibrated"]["fix_sigma"]
    if fs["mode"] != "measured" or fs["chosen_by"] != "default" or not fs.get("why") or not fs.get("rule"):
        bad.append("default fix_sigma is %r chosen by %r (why %r): not measured by default, with its rule" % (
            fs["mode"], fs.get("chosen_by"), fs.get("why")))
    for row in fs.get("per_log", []):
        if not row["measured"]:
            bad.append("%s: not measured (%s)" % (row["log"], row.get("note")))
        for key, true in (("sigma_xy_m", true_xy), ("sigma_theta_rad", true_th)):
            if not (true / 1.25 <= row[key] <= true * 1.25):
                bad.append("%s: %s %.4g is not within 25 %% of the true %.4g" % (row["log"], key, row[key], true))
    g = d["growth"]
    ratio = g.get("ratio_observed_to_predicted")
    if ratio is None or not (1 / 1.5 <= ratio <= 1.5):
        bad.append("default: observed/predicted 5 m growth %s is not within 1.5x" % ratio)
    if g.get("trusted") is not True or not g.get("reason"):
        bad.append("default: growth not trusted (%r: %r)" % (g.get("trusted"), g.get("reason")))
    gl, fl = lg["growth"], lg["calibrated"]["fix_sigma"]
    if fl["mode"] != "logs" or fl["chosen_by"] != "--fix-sigma logs":
        bad.append("--fix-sigma logs: fix_sigma is %r chosen by %r" % (fl["mode"], fl.get("chosen_by")))
    if gl.get("trusted") is not False or not gl.get("reason"):
        bad.append("--fix-sigma logs: growth not reported untrusted with a reason (%r)" % gl.get("trusted"))
    print("default: measured %s; 5 m growth observed/predicted %s (trusted %s); --fix-sigma logs: %s (trusted %s)" % (
        ", ".join("%.4g m / %.4g rad" % (r["sigma_xy_m"], r["sigma_theta_rad"]) for r in fs.get("per_log", [])),
        "%.2f" % ratio if ratio else None, g.get("trusted"),
        "%.2f" % gl["ratio_observed_to_predicted"] if gl.get("ratio_observed_to_predicted") else None, gl.get("trusted")))
    for b in bad:
        print("FAIL:", b)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

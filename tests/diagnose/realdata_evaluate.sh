#!/usr/bin/env bash
# odoerr evaluate on a small part of the OptiOdom data (2 squares, 2 circles, 2 ivanjko
# runs; the full evaluation is tools/import/run_optiodom_evaluate.py, docs/real-data.md).
# Checks the contract of `odoerr evaluate` and `odoerr umbmark`, and on the split
# "cw circle + squares -> ccw circle" the acceptance of issue 13 (calibrated 5 m RPE at
# least 30 % below nominal and no worse than UMBmark; observed/predicted growth within
# 1.5). Exit 77 without the data.
set -euo pipefail
odoerr="$1"; out="$2"
root="$(cd "$(dirname "$0")/../.." && pwd)"
rm -rf "$out"
set +e
/usr/bin/python3 "$root/tools/import/run_optiodom_evaluate.py" "$out" --odoerr "$odoerr" --quick --no-plots > "$out.log" 2>&1
rc=$?
set -e
cat "$out.log"
[ $rc -eq 77 ] && exit 77
[ $rc -eq 0 ] || exit $rc
/usr/bin/python3 - "$out" <<'PY'
import json, os, sys
out = sys.argv[1]
e = json.load(open(os.path.join(out, "evaluate-0-umbmark.json")))
for k in ("delta_R", "delta_L", "delta_d", "K_w", "sigma"):
    assert k in e["calibrated"], k
for L in ("1m", "5m"):
    for k in ("nominal", "calibrated", "constants"):
        r = e["rpe"][L][k]
        assert r["trans_m"] is not None and r["rot_rad"] is not None and r["segments"] > 0, (L, k, r)
assert e["growth"]["predicted_sigma_5m_m"] > 0 and e["growth"]["observed_rmse_5m_m"] > 0
assert len(e["test_logs"]) == 1
u = json.load(open(os.path.join(out, "umbmark.json")))
assert u["runs"] == {"cw": 1, "ccw": 1}, u["runs"]
for k, v in u["constants"].items():
    assert abs(v - 1) < 0.02, (k, v)
s = json.load(open(os.path.join(out, "summary.json")))
a = s["acceptance"][0]
assert a["split"].startswith("cw circles"), a
print("quick OptiOdom evaluate: %s: 5 m RPE %.0f %% below nominal, no worse than UMBmark %s, growth ratio %.2f" % (
    a["split"], 100 * a["reduction_vs_nominal"], a["odoerr_le_umbmark"], a["growth_ratio_observed_to_predicted"]))
assert a["pass"], a
PY

#!/usr/bin/env bash
# The loop on real data: an OptiOdom circular run (real wheel ticks, motion-capture truth),
# imported to odolog with mocap pose fixes once a second, then diagnosed with a held-out
# comparison. Checks that the whole contract is produced, that the nominal wheel scales
# come out near 1, and that the excitation report finds what the paper says of a circle:
# it cannot separate the wheelbase scale from the wheel scales. The run is taken from the
# data folder, else from the sample in tests/data (tools/import/data_dir.sh); exit 77 when
# neither has it.
set -euo pipefail
odoerr="$1"; out="$2"
root="$(cd "$(dirname "$0")/../.." && pwd)"
. "$root/tools/import/data_dir.sh"
rel=optiodom-diff/circular/231220200121/231220200121_run-01.csv
data="$(odoerr_data_find "$rel")" || odoerr_data_skip "the OptiOdom diagnose check" "$rel"
echo "data: $(odoerr_data_where "$data")"
mkdir -p "$out"
run="$data/$rel"
/usr/bin/python3 "$root/tools/import/optiodom_to_odolog.py" "$run" --out "$out/optiodom.odolog"
"$odoerr" diagnose "$out/optiodom.odolog" --json "$out/optiodom.json" --with rotation_slip
/usr/bin/python3 - "$out/optiodom.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
assert j["verdict"] in ("consistent", "inconsistent")
assert len(j["ranking"]) == 15, len(j["ranking"])
assert j["heldout"] and j["heldout"]["before"]["pose_rmse_m"] is not None
p = j["baseline"]["parameters"]
for k in ("delta_R", "delta_L", "delta_d"):
    assert abs(p[k]["estimate"] - 1) < 0.05, (k, p[k])
w = " ".join(j["excitation"]["warnings"])
assert "delta_d" in w and "cannot separate" in w, w
print("optiodom: verdict %s, named %s, delta_R %.4f delta_L %.4f delta_d %.4f, held-out pose RMSE %.4f -> %.4f m" % (
    j["verdict"], [r["effect"] for r in j["ranking"] if r["significant"]] or "none",
    p["delta_R"]["estimate"], p["delta_L"]["estimate"], p["delta_d"]["estimate"],
    j["heldout"]["before"]["pose_rmse_m"], j["heldout"]["after"]["pose_rmse_m"]))
PY

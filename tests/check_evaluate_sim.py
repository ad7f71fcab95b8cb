"""odoerr evaluate on a simulated drive: the contract, and the calibration within 3 sigma
of the simulator's true parameters (meta truth_param of the calibration log)."""
import json
import sys

j = json.load(open(sys.argv[1]))
truth = {}
for line in open(sys.argv[2]):
    f = line.split()
    if len(f) == 4 and f[:2] == ["meta", "truth_param"]:
        truth[f[2]] = float(f[3])
c = j["calibrated"]
for k in ("delta_R", "delta_L", "delta_d", "K_w"):
    z = (c[k] - truth[k]) / c["sigma"][k]
    assert abs(z) < 3, (k, c[k], truth[k], c["sigma"][k])
for L in ("1m", "5m"):
    for k in ("nominal", "calibrated", "constants"):
        r = j["rpe"][L][k]
        for m in ("trans_m", "rot_rad", "trans_rmse_m", "rot_rmse_rad"):
            assert isinstance(r[m], float) and r[m] >= 0, (L, k, m, r)
        assert r["segments"] > 0
g = j["growth"]
assert g["predicted_sigma_5m_m"] > 0 and g["observed_rmse_5m_m"] > 0
assert [t["reference"] for t in j["test_logs"]] == ["truth"]
assert len(j["rpe_by_length"]) == 8
print("evaluate on a simulated drive: delta_R %.4f delta_L %.4f delta_d %.4f K_w %.3g (truth %s)" % (
    c["delta_R"], c["delta_L"], c["delta_d"], c["K_w"], truth))

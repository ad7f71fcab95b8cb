#!/usr/bin/env bash
# A laser-free pose-fix log (a simulated drive whose laser is replaced by a pose fix from
# the truth once a second, with the noise its sigmas say): diagnose must compute no
# statistic from empty data (the laser tests are null with a note), rest its verdict on
# the pose fixes, and give no excitation warning about a laser effect.
set -euo pipefail
odoerr="$1"; out="$2"
mkdir -p "$out"
"$odoerr" sim --scenario excite --minutes 1 --drive diff --seed 3 --out "$out/laser.odolog" >/dev/null
/usr/bin/python3 - "$out/laser.odolog" "$out/fixes.odolog" <<'PY'
import random, sys
random.seed(1)
src, dst = sys.argv[1], sys.argv[2]
out, next_t = [], 1.0
for line in open(src):
    f = line.split()
    if f and f[0] in ("laser", "scan", "wall"):
        continue
    out.append(line)
    if f and f[0] == "truth" and float(f[1]) >= next_t:
        t, x, y, th = map(float, f[1:5])
        out.append("pose %.6f %.6f %.6f %.7f 0.01 0.01 0.01\n" % (
            t, x + random.gauss(0, 0.01), y + random.gauss(0, 0.01), th + random.gauss(0, 0.01)))
        next_t += 1.0
open(dst, "w").writelines(out)
PY
"$odoerr" diagnose "$out/fixes.odolog" --json "$out/fixes.json" --with turn_slip >/dev/null
/usr/bin/python3 - "$out/fixes.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
t = j["tests"]
assert j["verdict"] in ("consistent", "inconsistent"), j["verdict"]
assert t["verdict_rests_on"] == ["pose_fixes"], t["verdict_rests_on"]
for k in ("nis_mean", "nis_band", "ljung_box", "scans_outside_band_frac", "windowed_nis_outside_frac", "pose_correction"):
    assert t[k] is None, (k, t[k])
assert "no laser" in t["laser_note"]
assert j["unexplained"]["beam"]["sse_cv_model"] is None and j["map_misfit"]["t_critical"] is None
assert j["bins"]["turn_rate"] is None and j["cusum"]["alarms"] == []
p = t["pose_fixes"]
assert p["fixes"] >= 50, p["fixes"]
lo, hi = p["nis_band"]
assert p["nis_mean"] is not None and lo < 3 < hi, p
assert p["whiteness"]["p_min"] is not None
assert p["nees_pose"] is not None  # the simulated log has truth
laser = ("range_bias", "range_scale", "laser_mount", "scan_latency", "wall_offset")
w = " ".join(j["excitation"]["warnings"])
assert not any(e in w for e in laser), w
assert j["heldout"]["before"]["nis_mean"] is not None  # the held-out comparison runs on the fixes
print("pose-fix log: verdict %s on %s; %d fixes, mean NIS %.3f (band %.3f-%.3f), %d warnings, none about the laser" % (
    j["verdict"], t["verdict_rests_on"], p["fixes"], p["nis_mean"], lo, hi, len(j["excitation"]["warnings"])))
PY

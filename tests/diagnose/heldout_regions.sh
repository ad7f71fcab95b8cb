#!/usr/bin/env bash
# heldout_regions.sh ODOERR OUTDIR PYSIM: beams ending in a region the map gets wrong leave
# the held-out comparison as they leave the ranking (issue 12). A drive of the independent
# simulator with a cabinet missing from the map, diagnosed with --with turn_slip:
# - by default a region is found, heldout.region_beams_left_out > 0 and the map_misfit
#   block says the region beams left both;
# - with --map-beams keep nothing is left out (region_beams_left_out null) and the held-out
#   comparison scores more beam predictions.
set -euo pipefail
bin="$1"; out="$2"; pysim="$3"
mkdir -p "$out"
/usr/bin/python3 "$pysim" --out "$out/cab.odolog" --seed 21 --map-error object=5,0.2,0.6,0.4 > /dev/null
"$bin" diagnose "$out/cab.odolog" --json "$out/excl.json" --with turn_slip 2> /dev/null
"$bin" diagnose "$out/cab.odolog" --json "$out/keep.json" --with turn_slip --map-beams keep 2> /dev/null
/usr/bin/python3 - "$out/excl.json" "$out/keep.json" <<'PY'
import json, sys
e, k = (json.load(open(p)) for p in sys.argv[1:3])
fails = []
if not e["map_misfit"]["regions"]:
    fails.append("no region found for the missing cabinet")
n = e["heldout"].get("region_beams_left_out")
if not (isinstance(n, int) and n > 0):
    fails.append(f"default: region_beams_left_out is {n!r}, expected > 0")
if "held-out" not in e["map_misfit"]["region_beams"]:
    fails.append(f"default: map_misfit.region_beams says {e['map_misfit']['region_beams']!r}")
if k["heldout"].get("region_beams_left_out") is not None:
    fails.append("--map-beams keep: something was left out")
print(f"left out {n} beam predictions; region_beams: {e['map_misfit']['region_beams']!r}")
for f in fails:
    print("FAIL " + f)
sys.exit(1 if fails else 0)
PY

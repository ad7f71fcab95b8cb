#!/usr/bin/env bash
# test_report.sh: end-to-end test of tools/report/make_report.py and tests/report/check_render.sh.
#
#  (a) make a fixture of odoerr diagnose's output with make_fixture.py (100k beams, 274 CUSUM
#      alarms in seven bursts);
#  (b) make_report.py writes report.html from it; its headline names the effects, the region
#      where the map is wrong and what is left unexplained, before what was not found; the
#      alarms are said as 274 in 7 clusters, 5 labelled (test_alarms_headline.py checks the
#      figures' labels and the headline's rules without a browser);
#  (c) check_render.sh passes on it (Chromium decodes every image, >= 5 images);
#  (d) with one image's data URI corrupted, a section asked for that is not there and more
#      images asked for than the page has, check_render.sh fails and names all three;
#  (e) make_report.py fails with a message naming the file when diagnose.json is missing,
#      and likewise for a malformed diagnose.json / scans.csv / beams.csv;
#  (f) the optional parts may be absent: no truth, heldout null, no alarms, sync drive;
#  (g) discovery, change points and --with auto: their sections, the partial-residual plots and
#      the change point on the timeline are there (and render), the tests table holds no JSON;
#      without the keys (an older odoerr) the sections say "not run"; with nothing found, so;
#  (h) where the map is wrong: the map with its regions renders, the region's table and the ranking
#      line are there; no region, no map_grid.csv, an older diagnose.json: said in words; a bad
#      region or map_grid.csv: a message naming the file.
#  (i) detection power: its section (sizes, families not excited, noise families); an older
#      diagnose.json says "not run"; a consistent verdict's headline says what it could not miss.
#
# Exit 0 all passed; 1 something failed; 77 Chromium is missing (the steps that need no browser
# still ran and passed). Closes with the line "report: N passed, N failed".
set -u
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
PY=${PYTHON:-/usr/bin/python3}
report="$root/tools/report/make_report.py"
fixture="$here/make_fixture.py"
check="$here/check_render.sh"

tmp=$(mktemp -d "${TMPDIR:-/tmp}/test_report.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
pass=0; fail=0; skipped=0
ok()  { pass=$((pass + 1)); echo "ok: $*"; }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }

# expect_error NAME REGEX DIR: make_report.py on DIR exits 1 with a message matching REGEX.
expect_error() {
  local name=$1 regex=$2 dir=$3 out rc
  out=$("$PY" "$report" "$dir" 2>&1); rc=$?
  if [ "$rc" -ne 1 ]; then bad "$name: exit $rc, expected 1: $out"
  elif ! grep -Eq -- "$regex" <<<"$out"; then bad "$name: message does not match /$regex/: $out"
  else ok "$name: $out"; fi
}

# (a) fixture
if "$PY" "$fixture" "$tmp/full" --beams 100000 --seed 1 --alarms 274 2>"$tmp/fixture.log"; then
  ok "fixture: $(cat "$tmp/fixture.log")"
else
  bad "fixture: $(cat "$tmp/fixture.log")"; echo "report: $pass passed, $fail failed"; exit 1
fi

# (b) report
start=$(date +%s.%N)
if "$PY" "$report" "$tmp/full" 2>"$tmp/report.log" && [ -s "$tmp/full/report.html" ]; then
  secs=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
  ok "make_report on 100k beams (${secs} s): $(cat "$tmp/report.log")"
else
  bad "make_report: $(cat "$tmp/report.log")"
fi
page="$tmp/full/report.html"
if [ -s "$page" ]; then
  n_img=$(grep -o 'src="data:image/png;base64,' "$page" | wc -l)
  if [ "$n_img" -ge 5 ] && ! grep -Eqi '<script|(src|href)="(https?:)?//' "$page"; then
    ok "self-contained: $n_img embedded PNGs, no script, no external link"
  else
    bad "page not self-contained or too few images ($n_img)"
  fi
fi

# The headline and the alarms, in the page's words (the rules themselves: test_alarms_headline.py).
# headline FILE: the text of the page's headline paragraph, tags removed.
headline() { "$PY" -c 'import re,sys,html; m=re.search(r"<p class=.headline. id=.headline.>(.*?)</p>", open(sys.argv[1], encoding="utf-8").read())
print(html.unescape(re.sub(r"<[^>]+>", "", m.group(1))) if m else "NO HEADLINE")' "$1"; }
if [ -s "$page" ]; then
  h=$(headline "$page")
  want="Found: named effects: wall_offset, turn_slip, range_bias; 1 region where the map is wrong: R1 at (10.12, 4.99) m, 4,123 beams, short — something the map lacks; structure no catalogue effect explains: the robot drifts 1.15 cm per m"
  if [[ "$h" == "$want"* ]] && [[ "$h" == *"and 1 more term; 1 change point at t = 76.8 s." ]]; then
    ok "headline: the effects, the map region and the unexplained first: $h"
  else bad "headline: expected it to start with [$want]: $h"; fi
  if out=$("$PY" "$here/test_alarms_headline.py" 2>&1); then ok "$(tail -n 1 <<<"$out")"
  else bad "test_alarms_headline.py: $(grep FAIL <<<"$out" | head -n 5)"; fi
  cap="274 CUSUM alarms in 7 clusters"
  if grep -qF "$cap" "$page" && grep -qF "the first 5 are labelled A1…A5 with their number of alarms" "$page" \
     && grep -qF "The largest, A4, holds 94 alarms" "$page" && grep -qF "Dotted lines: the 7 clusters of CUSUM alarms" "$page"; then
    ok "alarms: 274 in 7 clusters, 5 labelled, the largest named, in the captions"
  else bad "alarms: the captions do not say [$cap], 5 labelled and the largest"; fi
fi

# (c) renders in Chromium
have_browser=1
if [ -s "$page" ]; then   # the map's figure decodes too, found by its alt text
  out=$(REQUIRE_IDS="headline tests ranking unexplained changes auto heldout map-misfit" MIN_IMGS=12 \
        MIN_ALT="partial residual against:2|map with the residual grid and the regions:1" \
        bash "$check" "$page" 2>&1); rc=$?
  if [ "$rc" -eq 77 ]; then have_browser=0; skipped=1; echo "skip: $out"
  elif [ "$rc" -eq 0 ]; then ok "check_render on the report: $(grep RENDER_OK <<<"$out")"
  else bad "check_render on the report (exit $rc): $out"; fi
fi

# (d) a corrupted image, a missing section and too few images must be caught (one browser run: all named)
if [ "$have_browser" -eq 1 ] && [ -s "$page" ]; then
  # The third image's PNG signature and header are replaced by bytes that are not a PNG.
  "$PY" - "$page" "$tmp/broken.html" <<'EOF'
import sys
s = open(sys.argv[1], encoding="utf-8").read()
key = 'src="data:image/png;base64,'
i = -1
for _ in range(3):
    i = s.index(key, i + 1)
j = i + len(key)
s = s[:j] + "AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA" + s[j + 32:]
open(sys.argv[2], "w", encoding="utf-8").write(s)
EOF
  out=$(REQUIRE_IDS="unexplained no-such-section" MIN_IMGS=13 bash "$check" "$tmp/broken.html" 2>&1); rc=$?
  if [ "$rc" -ne 0 ] && [ "$rc" -ne 77 ] && grep -q 'broken=1' <<<"$out"; then
    ok "check_render fails on a corrupted image (exit $rc): $(grep -m1 FAIL <<<"$out")"
  else
    bad "check_render did not fail on a corrupted image (exit $rc): $out"
  fi
  # The section that is not there is named, the one that is there is not.
  if [ "$rc" -eq 1 ] && grep -q 'no element with id="no-such-section"' <<<"$out" \
     && ! grep -q 'id="unexplained"' <<<"$out"; then
    ok "check_render fails on a missing section"
  else bad "check_render on a missing section (exit $rc): $out"; fi
  # A page with fewer images than asked for fails too.
  if [ "$rc" -eq 1 ] && grep -q 'only 12 image(s), expected at least 13' <<<"$out"; then
    ok "check_render fails on a page with too few images"
  else bad "check_render on a page with too few images (exit $rc): $out"; fi
fi

# (e) missing and malformed inputs
mkdir -p "$tmp/nojson" && cp "$tmp/full/"*.csv "$tmp/nojson/"
expect_error "missing diagnose.json" "diagnose\.json.*not found" "$tmp/nojson"
mkdir -p "$tmp/badjson" && cp "$tmp/full/"*.csv "$tmp/badjson/"
head -c 300 "$tmp/full/diagnose.json" > "$tmp/badjson/diagnose.json"
expect_error "truncated diagnose.json" "diagnose\.json: not valid JSON" "$tmp/badjson"
mkdir -p "$tmp/badkey" && cp "$tmp/full/"*.csv "$tmp/badkey/"
"$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); del d["verdict"]; json.dump(d, open(sys.argv[2],"w"))' \
  "$tmp/full/diagnose.json" "$tmp/badkey/diagnose.json"
expect_error "diagnose.json without verdict" "diagnose\.json: missing key 'verdict'" "$tmp/badkey"
mkdir -p "$tmp/badtype" && cp "$tmp/full/"*.csv "$tmp/badtype/"
"$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); d["ranking"][2]["bic_gain"]="big"; json.dump(d, open(sys.argv[2],"w"))' \
  "$tmp/full/diagnose.json" "$tmp/badtype/diagnose.json"
expect_error "non-numeric bic_gain" "diagnose\.json: 'ranking\[2\]\.bic_gain' should be a number" "$tmp/badtype"
mkdir -p "$tmp/noscans" && cp "$tmp/full/diagnose.json" "$tmp/full/beams.csv" "$tmp/full/trajectory.csv" "$tmp/noscans/"
expect_error "missing scans.csv" "scans\.csv.*not found" "$tmp/noscans"
mkdir -p "$tmp/badscans" && cp "$tmp/full/diagnose.json" "$tmp/full/beams.csv" "$tmp/full/trajectory.csv" "$tmp/badscans/"
sed '5s/^\([^,]*\),[^,]*,/\1,oops,/' "$tmp/full/scans.csv" > "$tmp/badscans/scans.csv"
expect_error "non-numeric scans.csv field" "scans\.csv:5: column 'dist_m': 'oops' is not a number" "$tmp/badscans"
mkdir -p "$tmp/badbeams" && cp "$tmp/full/diagnose.json" "$tmp/full/scans.csv" "$tmp/full/trajectory.csv" "$tmp/badbeams/"
sed '1s/innovation_m/innov/' "$tmp/full/beams.csv" > "$tmp/badbeams/beams.csv"
expect_error "beams.csv without innovation_m" "beams\.csv: header lacks column\(s\) innovation_m" "$tmp/badbeams"
mkdir -p "$tmp/shortrow" && cp "$tmp/full/diagnose.json" "$tmp/full/scans.csv" "$tmp/full/beams.csv" "$tmp/shortrow/"
sed '7s/,[^,]*$//' "$tmp/full/trajectory.csv" > "$tmp/shortrow/trajectory.csv"
expect_error "short row in trajectory.csv" "trajectory\.csv:7: 6 fields where the header has 7" "$tmp/shortrow"
expect_error "not a directory" "not a directory" "$tmp/does-not-exist"
out=$("$PY" "$report" 2>&1); rc=$?
if [ "$rc" -eq 2 ]; then ok "no argument: exit 2 (usage)"; else bad "no argument: exit $rc: $out"; fi

# (f) optional parts absent
"$PY" "$fixture" "$tmp/bare" --beams 8000 --drive sync --no-truth --no-heldout --no-alarms --seed 3 2>/dev/null
if out=$("$PY" "$report" "$tmp/bare" 2>&1) && grep -q 'No held-out check was run' "$tmp/bare/report.html" \
   && grep -q 'no CUSUM alarms' "$tmp/bare/report.html" && grep -q 'no truth' "$tmp/bare/report.html"; then
  ok "sync drive, no truth, heldout null, no alarms: $out"
  if [ "$have_browser" -eq 1 ]; then
    out=$(bash "$check" "$tmp/bare/report.html" 2>&1); rc=$?
    if [ "$rc" -eq 0 ]; then ok "check_render on the bare report: $(grep RENDER_OK <<<"$out")"
    else bad "check_render on the bare report (exit $rc): $out"; fi
  fi
else
  bad "bare report: $out"
fi
# heldout present but its per-scan CSVs missing; empty bins and empty alarms objects; no map.
mkdir -p "$tmp/partial" && cp "$tmp/full/"{scans,beams,trajectory}.csv "$tmp/partial/"
"$PY" - "$tmp/full/diagnose.json" "$tmp/partial/diagnose.json" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
d["bins"] = {k: [] for k in d["bins"]}
d["cusum"] = {"alarms": []}
d["map"] = {"walls": []}
d["excitation"] = {"parameters": [], "warnings": []}
d["tests"]["nees_pose"] = None
json.dump(d, open(sys.argv[2], "w"))
EOF
if out=$("$PY" "$report" "$tmp/partial" 2>&1) && grep -q 'heldout_before.csv / heldout_after.csv are not in' \
   "$tmp/partial/report.html"; then ok "partial inputs: $out"
else bad "partial inputs: $out"; fi
# Header-only CSVs: no scans, no beams.
mkdir -p "$tmp/empty" && cp "$tmp/full/diagnose.json" "$tmp/empty/"
for f in scans beams trajectory; do head -n 1 "$tmp/full/$f.csv" > "$tmp/empty/$f.csv"; done
if out=$("$PY" "$report" "$tmp/empty" 2>&1) && grep -q 'scans.csv has no rows' "$tmp/empty/report.html"; then
  ok "header-only CSVs: $out"
else bad "header-only CSVs: $out"; fi

# (g) discovery, change points, --with auto
# expect_in NAME FILE TEXT...: every TEXT (fixed string) is in FILE.
expect_in() {
  local name=$1 file=$2 miss=""; shift 2
  for x in "$@"; do grep -qF -- "$x" "$file" || miss="$miss [$x]"; done
  if [ -z "$miss" ]; then ok "$name"; else bad "$name: missing$miss"; fi
}
if [ -s "$page" ]; then
  expect_in "discovery sections in the full report" "$page" \
    "What the catalogue does not explain" "the robot drifts 1.15 cm per m of travel" "--with feature:abs_ds@world_x" \
    "--with feature:abs_ds@world_x,feature:alpha_angle_sens" 'alt="partial residual against world/world_x/abs_ds"' \
    'alt="partial residual against beam/range/alpha_angle_sens"' "explain 41 %" \
    "Change points" "<b style=\"color:#d35400\">C1</b>" "the right wheel&#39;s travel scale -2.12 %" \
    "Orange: the 1 change point(s)" "Automatic model search" "Tried and not kept" "laser_mount_yaw" \
    "2.14 → 1.22 cm" "−9.6" "not named: it explains 8 %" "motion 8 % · beam —" \
    "largest |t| =" "cross track (left +)</span> mean 0.18 mm" 'alt="t statistic per beam"'
  if grep -qE '\{&quot;|\[\{|&quot;beam&quot;' "$page"; then bad "the full report prints raw JSON"
  else ok "no raw JSON in the full report"; fi
fi
"$PY" "$fixture" "$tmp/old" --beams 8000 --no-discovery --seed 4 2>/dev/null
if out=$("$PY" "$report" "$tmp/old" 2>&1); then
  expect_in "an older diagnose.json (no discovery keys): sections say not run ($out)" "$tmp/old/report.html" \
    'Discovery was not run' 'The change-point scan was not run' 'Not run: diagnose was run without' \
    'No detection power in diagnose.json (an older odoerr): not run.'
else bad "an older diagnose.json: $out"; fi
mkdir -p "$tmp/nothing" && cp "$tmp/full/"{scans,beams,trajectory}.csv "$tmp/nothing/"
for f in motion beam; do head -n 1 "$tmp/full/discovery_$f.csv" | cut -d, -f1-4 > "$tmp/nothing/discovery_$f.csv"
  "$PY" -c 'import sys; import random
for i in range(50): print(f"{10 + i * 0.5:.3f},{i},{random.gauss(0, 1):.4f},0")' >> "$tmp/nothing/discovery_$f.csv"; done
"$PY" - "$tmp/full/diagnose.json" "$tmp/nothing/diagnose.json" <<'EOF2'
import json, sys
d = json.load(open(sys.argv[1]))
d["unexplained"] = {"significant": False, "explained_fraction": None, "features": [], "baseline_features": [],
                    "motion": None, "beam": {}, "note": "the model's residuals show no structure in the feature library"}
d["change_points"] = []
d["auto"] = {"steps": [], "tried": [], "final_with": [], "rule": None}
for r in d["ranking"]:
    r["explains"] = None
    r["significant"] = False
d["verdict"] = "consistent"
d["verdict_detail"] = "consistent: nothing larger than turn_slip.k_s2_per_m 0.00321 (80 % power)"
d["map_misfit"]["regions"] = []
json.dump(d, open(sys.argv[2], "w"))
EOF2
if out=$("$PY" "$report" "$tmp/nothing" 2>&1); then
  expect_in "discovery found nothing: said in words ($out)" "$tmp/nothing/report.html" \
    'Nothing is left unexplained' 'No term of the feature library is left' 'No change point' \
    'No step was kept' 'the baseline (nothing added)'
  h=$(headline "$tmp/nothing/report.html")
  if [[ "$h" == "The model explains this log"*"Nothing larger than turn_slip.k_s2_per_m 0.00321 (80 % power)."* ]]; then
    ok "a consistent verdict: the headline says what the drive could not have missed"
  else bad "a consistent verdict: headline: $h"; fi
else bad "discovery found nothing: $out"; fi
mkdir -p "$tmp/badcp" && cp "$tmp/full/"*.csv "$tmp/badcp/"
"$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); d["change_points"][0]["t"]="soon"; json.dump(d, open(sys.argv[2],"w"))' \
  "$tmp/full/diagnose.json" "$tmp/badcp/diagnose.json"
expect_error "non-numeric change point time" "diagnose\.json: 'change_points\[0\]\.t' should be a number" "$tmp/badcp"
mkdir -p "$tmp/baddisc" && cp "$tmp/full/"{scans,beams,trajectory}.csv "$tmp/full/diagnose.json" "$tmp/baddisc/"
cp "$tmp/full/discovery_beam.csv" "$tmp/baddisc/"
sed '1s/,partial_[^,]*$//' "$tmp/full/discovery_motion.csv" | cut -d, -f1-5 > "$tmp/baddisc/discovery_motion.csv"
expect_error "discovery_motion.csv without its partial column" "discovery_motion\.csv: header lacks column\(s\) partial_world/world_x/abs_ds" "$tmp/baddisc"

# (h) where the map is wrong
# The number of cells tested is the fixture's (cells with 30 beams or more): one cell sits on
# that edge, and which side it falls on moved with the machine's libm (228 on one, 227 on
# another), so it is read from the fixture rather than written here.
cells=$("$PY" -c 'import json,sys; print(json.load(open(sys.argv[1]))["map_misfit"]["cells_tested"])' \
  "$tmp/full/diagnose.json" 2>/dev/null || echo "?")
if [ -s "$page" ]; then
  expect_in "map section in the full report" "$page" \
    '<h2 id="map-misfit">Where the map is wrong</h2>' "href='#map-misfit'" \
    'alt="map with the residual grid and the regions where the map is wrong"' \
    "1 region(s) where the laser disagrees with the map" "R1 <b>short</b>, <b>persistent</b> at (10.12, 4.99) m (something the map lacks)" \
    "the map is wrong here: every pass disagrees" "disagreed in" \
    "(9.65, 4.50) → (9.65, 5.50) m" "1.00 m long" "0.25 × 1.00 m" "−4.18" "over the $cells cells tested" \
    "The effect ranking above left out the 4,123 beams" "laser_mount_xy (p &lt; 0.0001)" \
    "without them it names wall_offset, turn_slip, range_bias."
fi
if [ -s "$page" ]; then
  expect_in "detection power section in the full report" "$page" \
    'Detection power: what this drive could not have missed' "href='#power'" 'smallest detectable (80 % power)' \
    'turn_slip.k_s2_per_m' '0.00321' 'not excited by this drive: reverse the direction of travel many times' \
    'a noise effect is tested on its likelihood profile' "The feature library's terms" 'abs_ds@world_x' \
    '0.00184' 'column is zero or follows the drive parameters'
fi
if [ -s "$tmp/old/report.html" ]; then
  expect_in "an older diagnose.json: the map section says not run" "$tmp/old/report.html" \
    '<h2 id="map-misfit">Where the map is wrong</h2>' 'Not run: diagnose.json has no "map_misfit"'
  h=$(headline "$tmp/old/report.html")
  if [[ "$h" == "Found: named effects: "* ]] && [[ "$h" != *map* ]] && [[ "$h" != *unexplained* ]]; then
    ok "an older diagnose.json: the headline names the effects, says nothing of what was not run"
  else bad "an older diagnose.json: headline: $h"; fi
fi
mkdir -p "$tmp/noregion" && cp "$tmp/full/"*.csv "$tmp/noregion/"
"$PY" - "$tmp/full/diagnose.json" "$tmp/noregion/diagnose.json" <<'EOF3'
import json, sys
d = json.load(open(sys.argv[1]))
d["map_misfit"]["regions"] = []
d["map_misfit"]["region_beams"] = "none"
d["map_misfit"]["ranking_with_region_beams"] = None
json.dump(d, open(sys.argv[2], "w"))
EOF3
sed -i 's/,0$/,-1/' "$tmp/noregion/map_grid.csv"
if out=$("$PY" "$report" "$tmp/noregion" 2>&1); then
  expect_in "no region: said in words ($out)" "$tmp/noregion/report.html" \
    'No region: the ranges agree with the map everywhere it was seen.' "$cells cells were tested" '4.11' \
    'alt="map with the residual grid'
  h=$(headline "$tmp/noregion/report.html")
  if [[ "$h" == "Found: named effects: wall_offset, turn_slip, range_bias; structure"* ]] \
     && [[ "$h" == *". The ranges agree with the map everywhere it was seen." ]] && [[ "$h" != *"map is wrong"* ]]; then
    ok "no region: the headline says the map agrees, after what was found"
  else bad "no region: headline: $h"; fi
else bad "no region: $out"; fi
mkdir -p "$tmp/nogrid" && cp "$tmp/full/"{scans,beams,trajectory}.csv "$tmp/full/diagnose.json" "$tmp/nogrid/"
if out=$("$PY" "$report" "$tmp/nogrid" 2>&1); then
  expect_in "map_grid.csv missing: regions only, said so ($out)" "$tmp/nogrid/report.html" \
    'map_grid.csv is not in the directory' 'R1 <b>short</b>' 'alt="map with the residual grid'
else bad "map_grid.csv missing: $out"; fi
mkdir -p "$tmp/badmap" && cp "$tmp/full/"*.csv "$tmp/badmap/"
"$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); d["map_misfit"]["regions"][0]["candidate_segment"]=[1,2]; json.dump(d, open(sys.argv[2],"w"))' \
  "$tmp/full/diagnose.json" "$tmp/badmap/diagnose.json"
expect_error "a candidate segment of two numbers" "diagnose\.json: 'map_misfit\.regions\[0\]\.candidate_segment' should be null or \[x1, y1, x2, y2\]" "$tmp/badmap"
mkdir -p "$tmp/badgrid" && cp "$tmp/full/"{scans,beams,trajectory}.csv "$tmp/full/diagnose.json" "$tmp/badgrid/"
sed '1s/mean_norm/mean/' "$tmp/full/map_grid.csv" > "$tmp/badgrid/map_grid.csv"
expect_error "map_grid.csv without mean_norm" "map_grid\.csv: header lacks column\(s\) mean_norm" "$tmp/badgrid"

echo "report: $pass passed, $fail failed"
[ "$fail" -ne 0 ] && exit 1
[ "$skipped" -ne 0 ] && { echo "report: Chromium missing: render checks skipped"; exit 77; }
exit 0

#!/usr/bin/env bash
# realdata_buildings.sh ODOERR OUTDIR: the five CARMEN buildings of the data folder's carmen/
# (intel, aces, freiburg-079, csail, orebro; docs/real-data.md, "Maps of the five
# buildings") through `odoerr map grid-from-carmen` and `odoerr map import --faces`, each
# with the options it needs (--no-return for the codes no PARAM states). The logs have no
# stated licence: they are read from the data folder ($ODOERR_DATA, else ../shared/data;
# tools/import/data_dir.sh) and never copied; a building whose log is absent is skipped
# with a message naming ODOERR_DATA, and the script exits 77 when all five are.
# Per building:
# - the grid states the beams the log's rules give (count, step) and at least 85 % of the
#   returns land within one cell of an occupied cell (measured 91.1 to 96.4 %);
# - the import writes 300 to 1500 segments, RMS over the cells outside specks <= 10 cm
#   and >= 60 % of them within one cell (measured 5.3 to 8.7 cm, 66.1 to 86.2 %);
# - aces and orebro without --no-return: the grid notes the no-return code and names the
#   --no-return that takes it;
# - csail read 1 deg apart (--beam-step 1, the old reading): import refuses the grid.
# A table of the times (s) and figures is printed.
set -u
bin="$1"; out="$2"
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
py=/usr/bin/python3
. "$root/tools/import/data_dir.sh"
declare -A opts=([intel]="" [aces]="--no-return 50" [freiburg-079]="" [csail]="" [orebro]="--no-return 32.759")
declare -A beams=([intel]="180 1" [aces]="180 1" [freiburg-079]="360 0.5" [csail]="361 0.5" [orebro]="181 1")
declare -A code=([aces]="--no-return 50 leaves them out" [orebro]="--no-return 32.759 leaves them out")
fails=0; seen=0
pass() { echo "ok   $*"; }
fail() { echo "FAIL $*"; fails=$((fails + 1)); }
ge() { "$py" -c "import sys; sys.exit(0 if float('$1') >= float('$2') else 1)"; }
fit() { sed -n 's/^meta fit .*'"$2"'=\([^ ]*\).*/\1/p' "$1"; }
now() { date +%s.%N; }
secs() { "$py" -c "print(f'{$2 - $1:.1f}')"; }
mkdir -p "$out" || exit 1
rows=()
for b in intel aces freiburg-079 csail orebro; do
  rel="carmen/$b-corrected.log.gz"
  if ! d="$(odoerr_data_full "$rel")"; then odoerr_data_skip_message "the $b map checks" "$rel"; continue; fi
  seen=$((seen + 1))
  log="$d/$rel"
  t0="$(now)"
  # shellcheck disable=SC2086
  if ! gmsg="$("$bin" map grid-from-carmen "$log" --out "$out/$b" ${opts[$b]} 2>&1)"; then
    fail "$b grid-from-carmen: $gmsg"; continue
  fi
  t1="$(now)"
  read -r n step <<<"${beams[$b]}"
  near="$(sed -n 's/.* \([0-9.]*\) % within one cell of one.*/\1/p' <<<"$gmsg")"
  if grep -q "scans of $n beams from [-0-9.]* deg, $step deg apart" <<<"$gmsg" && [ -n "$near" ] && ge "$near" 85; then
    pass "$b grid: $n beams $step deg apart, $near % of the returns within one cell of an occupied cell"
  else
    fail "$b grid: expected $n beams $step deg apart and >= 85 % within one cell: $gmsg"
  fi
  if ! imsg="$("$bin" map import "$out/$b.yaml" --out "$out/$b.odomap" --faces 2>&1)"; then
    fail "$b import: $imsg"; continue
  fi
  t2="$(now)"
  o="$out/$b.odomap"
  nseg="$(grep -c '^segment ' "$o")"
  w="$(fit "$o" within_one_cell_outside_specks)"; r="$(fit "$o" rms_m_outside_specks)"
  if [ "$nseg" -ge 300 ] && [ "$nseg" -le 1500 ] && ge "$w" 0.60 && ge 0.10 "$r"; then
    pass "$b import --faces: $nseg segments, outside specks RMS $r m, $w within one cell"
  else
    fail "$b import --faces: $nseg segments, outside specks RMS $r m, $w within one cell: $imsg"
  fi
  rows+=("| $b | $(secs "$t0" "$t1") | $(secs "$t1" "$t2") | $nseg | $r | $w | $near % |")
  if [ -n "${code[$b]:-}" ]; then
    if msg="$("$bin" map grid-from-carmen "$log" --out "$out/$b-nocode" 2>&1)" && grep -q -- "${code[$b]}" <<<"$msg"; then
      pass "$b without --no-return: the code is noted ('${code[$b]}')"
    else
      fail "$b without --no-return: no note naming '${code[$b]}': $msg"
    fi
  fi
  if [ "$b" = csail ]; then
    "$bin" map grid-from-carmen "$log" --out "$out/csail-step1" --beam-step 1 >/dev/null 2>&1
    if msg="$("$bin" map import "$out/csail-step1.yaml" --out "$out/csail-step1.odomap" 2>&1)"; then
      fail "csail read 1 deg apart: import accepted the grid: $msg"
    elif grep -q "no map in this grid: .* are specks" <<<"$msg" && [ ! -e "$out/csail-step1.odomap" ]; then
      pass "csail read 1 deg apart: import refused: $msg"
    else
      fail "csail read 1 deg apart: unexpected message: $msg"
    fi
  fi
done
[ "$seen" -eq 0 ] && exit 77
echo "| building | grid (s) | import --faces (s) | segments | RMS outside specks (m) | within one cell | returns within one cell |"
echo "|---|---|---|---|---|---|---|"
printf '%s\n' "${rows[@]}"
[ "$fails" -eq 0 ] && echo "all building map checks passed ($seen of 5 buildings)" && exit 0
echo "$fails check(s) failed"; exit 1

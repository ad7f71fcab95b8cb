#!/usr/bin/env bash
# check_importers.sh: runs the two dataset importers on the real data and checks what they
# write. Usage: tools/import/check_importers.sh [--all] [--keep DIR] [--only optiodom|carmen]
#                                               [--odoerr BIN]
#   --all       every OptiOdom run (148 in the full data, about a minute) instead of run-01
#               of each set
#   --keep DIR  leave the outputs in DIR (default: a temporary folder, removed at the end)
#   --only P    only the OptiOdom or only the CARMEN part (the two ctest entries)
#   --odoerr B  the odoerr binary that replays each CARMEN building's output (default
#               build/host/tools/odoerr/odoerr when it exists; without one, no replays)
# The data (tools/import/data_dir.sh; docs/real-data.md, "Where the data comes from"): the
# data folder is $ODOERR_DATA when set, else ../shared/data from the repository root. The
# OptiOdom part reads its optiodom-diff, else the sample in tests/data/optiodom-diff (3
# sets' run-01). The CARMEN part needs carmen/intel-corrected.log.gz in the data folder (no
# sample: the logs state no licence); without it that part prints "skipped: ..." naming
# ODOERR_DATA. The four other buildings of carmen/ (aces, freiburg-079, csail, orebro) are
# checked when present, each skipped with the same message when absent. Exit 77 when every
# part asked for is skipped, else 0 when every check passes, 1 if not.
#
# Checks:
# - every output passes odolog_check.py (an independent reader of the odolog v1 rules)
#   together with its physical check: the ticks dead-reckoned with the file's nominal
#   constants give the mocap path length / net rotation (OptiOdom) or the raw odometry
#   path, rotation and the pose at every ODOM line (CARMEN);
# - CARMEN: each of the five buildings imported with --scans and the options it needs
#   (docs/real-data.md, "CARMEN logs: what the importer reads"), checked against its log
#   (odolog_check.py --carmen-log: the ticks at every ODOM line, the scans against the FLASER
#   ranges, the laser record against the PARAMs) and replayed by odoerr; csail and orebro
#   without those options are refused, naming the line and the reason;
# - each importer twice on the same input gives byte-identical output;
# - a copy of an OptiOdom run with a UTF-8 byte-order mark converts to the same records;
# - malformed copies (a non-numeric field, a wrong field count, time going backwards)
#   make the importer exit 2 with FILE:LINE naming the corrupted line, and leave no output.
set -u
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
py="${PYTHON:-python3}"

all=0
keep=""
only=""
odoerr=""
while [ $# -gt 0 ]; do
  case "$1" in
    --all) all=1 ;;
    --keep) keep="${2:?--keep needs a folder}"; shift ;;
    --odoerr) odoerr="${2:?--odoerr needs the odoerr binary}"; shift ;;
    --only) only="${2:?--only needs optiodom or carmen}"; shift
            case "$only" in optiodom|carmen) ;; *) echo "$0: --only optiodom|carmen" >&2; exit 2 ;; esac ;;
    *) echo "usage: $0 [--all] [--keep DIR] [--only optiodom|carmen] [--odoerr BIN]" >&2; exit 2 ;;
  esac
  shift
done

. "$here/data_dir.sh"
if [ -z "$odoerr" ] && [ -x "$root/build/host/tools/odoerr/odoerr" ]; then odoerr="$root/build/host/tools/odoerr/odoerr"; fi
opt_data=""  # the folder holding optiodom-diff: the data folder, else the sample
car_data=""  # the folder holding carmen/intel-corrected.log.gz: the data folder only
skips=()
if [ "$only" != carmen ]; then
  opt_data="$(odoerr_data_find optiodom-diff)" ||
    skips+=("$(odoerr_data_skip_message "the OptiOdom importer checks" optiodom-diff)")
fi
if [ "$only" != optiodom ]; then
  car_data="$(odoerr_data_full carmen/intel-corrected.log.gz)" ||
    skips+=("$(odoerr_data_skip_message "the CARMEN importer checks" carmen/intel-corrected.log.gz)")
fi
for m in "${skips[@]}"; do echo "$m"; done
if [ -z "$opt_data" ] && [ -z "$car_data" ]; then exit 77; fi

if [ -n "$keep" ]; then
  mkdir -p "$keep" || exit 2
  out="$(cd "$keep" && pwd)"
  scratch="$(mktemp -d)"
else
  out="$(mktemp -d)"
  scratch="$out"
fi
cleanup() { if [ -n "$keep" ]; then rm -rf "$scratch"; else rm -rf "$out"; fi; }
trap cleanup EXIT

opt="$here/optiodom_to_odolog.py"
car="$here/carmen_to_odolog.py"
chk="$here/odolog_check.py"
fails=0
pass() { echo "ok   $*"; }
fail() { echo "FAIL $*"; fails=$((fails + 1)); }
now() { date +%s.%N; }
secs() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", b - a }'; }
size() { stat -c %s "$1"; }

# expect_exit2 WHAT LINE FILE CMD...: CMD must exit 2, name FILE:LINE, and write no --out.
expect_exit2() {
  local what="$1" line="$2" file="$3" target="$4"; shift 4
  rm -f "$target"
  local msg rc
  msg="$("$@" 2>&1)"; rc=$?
  if [ "$rc" -ne 2 ]; then
    fail "$what: exit $rc, expected 2: $msg"
  elif ! grep -qF -- "$file:$line:" <<<"$msg"; then
    fail "$what: the message does not name $file:$line: $msg"
  elif [ -e "$target" ]; then
    fail "$what: an output file was left behind"
  else
    pass "$what: exit 2: $msg"
  fi
}

echo "== outputs: $out"

# ---------------------------------------------------------------- OptiOdom
if [ -n "$opt_data" ]; then
  echo "== OptiOdom, from $(odoerr_data_where "$opt_data")"
  if [ "$all" -eq 1 ]; then
    mapfile -t runs < <(find "$opt_data/optiodom-diff" -name '*_run-*.csv' | sort)
  else
    mapfile -t runs < <(find "$opt_data/optiodom-diff" -name '*_run-01.csv' | sort)
  fi
  if [ "${#runs[@]}" -eq 0 ]; then fail "no OptiOdom run files under $opt_data/optiodom-diff"; fi
  n_ok=0
  for f in "${runs[@]}"; do
    name="$(basename "$f" .csv)"
    o="$out/optiodom-$name.odolog"
    if ! msg="$("$py" "$opt" "$f" --out "$o" 2>&1)"; then fail "import $name: $msg"; continue; fi
    if res="$("$py" "$chk" "$o" --optiodom-csv "$f")"; then
      n_ok=$((n_ok + 1))
    else
      fail "check $name:"; echo "$res"
    fi
  done
  echo "ok   $n_ok of ${#runs[@]} OptiOdom runs imported and checked"

  first="${runs[0]:-}"
  if [ -n "$first" ]; then
    name="$(basename "$first" .csv)"
    o="$out/optiodom-$name.odolog"
    t0=$(now); "$py" "$opt" "$first" --out "$scratch/again.odolog" 2>/dev/null; t1=$(now)
    echo "--   example $name: $(size "$o") bytes, $(wc -l <"$o") lines, import $(secs "$t0" "$t1") s"
    "$py" "$chk" "$o" --optiodom-csv "$first" | sed 's/^/     /'
    if cmp -s "$o" "$scratch/again.odolog"; then pass "optiodom: reproducible (byte-identical twice)"
    else fail "optiodom: two runs on the same input differ"; fi

    # a byte-order mark changes nothing but the provenance lines
    { printf '\xef\xbb\xbf'; cat "$first"; } >"$scratch/bom.csv"
    if "$py" "$opt" "$scratch/bom.csv" --out "$scratch/bom.odolog" 2>/dev/null &&
       cmp -s <(grep -v '^meta source' "$o") <(grep -v '^meta source' "$scratch/bom.odolog"); then
      pass "optiodom: a UTF-8 BOM is ignored (same records)"
    else
      fail "optiodom: the BOM copy converts differently"
    fi

    # malformed copies: non-numeric field, wrong field count, time going backwards
    bad="$scratch/bad.csv"
    sed '57s/^\([^,]*\),[^,]*,/\1,abc,/' "$first" >"$bad"
    expect_exit2 "optiodom non-numeric x at line 57" 57 "$bad" "$scratch/bad.odolog" \
      "$py" "$opt" "$bad" --out "$scratch/bad.odolog"
    sed '100s/$/,1/' "$first" >"$bad"
    expect_exit2 "optiodom 7 fields at line 100" 100 "$bad" "$scratch/bad.odolog" \
      "$py" "$opt" "$bad" --out "$scratch/bad.odolog"
    sed '150s/^[^,]*,/1.0,/' "$first" >"$bad"
    expect_exit2 "optiodom time backwards at line 150" 150 "$bad" "$scratch/bad.odolog" \
      "$py" "$opt" "$bad" --out "$scratch/bad.odolog"
    sed '42s/,\([^,]*\)$/,2.5/' "$first" >"$bad"
    expect_exit2 "optiodom fractional nL at line 42" 42 "$bad" "$scratch/bad.odolog" \
      "$py" "$opt" "$bad" --out "$scratch/bad.odolog"
  fi
fi

# ---------------------------------------------------------------- CARMEN
if [ -n "$car_data" ]; then
  echo "== CARMEN (the Intel Research Lab, then the five buildings, corrected), from $(odoerr_data_where "$car_data")"
  log="$car_data/carmen/intel-corrected.log.gz"
  o="$out/carmen-intel.odolog"
  t0=$(now)
  if msg="$("$py" "$car" "$log" --out "$o" 2>&1)"; then
    t1=$(now)
    echo "--   $msg"
    echo "--   $(size "$o") bytes, $(wc -l <"$o") lines, import $(secs "$t0" "$t1") s"
    if res="$("$py" "$chk" "$o" --carmen-log "$log")"; then pass "carmen: checked"; else fail "carmen: check"; fi
    echo "$res" | sed 's/^/     /'
    "$py" "$car" "$log" --out "$scratch/again.odolog" 2>/dev/null
    if cmp -s "$o" "$scratch/again.odolog"; then pass "carmen: reproducible (byte-identical twice)"
    else fail "carmen: two runs on the same input differ"; fi
  else
    fail "carmen import: $msg"
fi

o2="$out/carmen-intel-100-fix10.odolog"
if msg="$("$py" "$car" "$log" --out "$o2" --max-scans 100 --fix-every 10 2>&1)" &&
   res="$("$py" "$chk" "$o2" --carmen-log "$log")" &&
   [ "$(grep -c '^truth' "$o2")" -eq 100 ] && [ "$(grep -c '^pose' "$o2")" -eq 9 ]; then
  pass "carmen --max-scans 100 --fix-every 10: 100 truth, 9 pose fixes, checked"
else
  fail "carmen --max-scans 100 --fix-every 10: $msg"; echo "${res:-}"
fi

# malformed copies (line numbers count lines of the decompressed text)
plain="$scratch/intel.log"
gzip -dc "$log" >"$plain"
ln_odom=$(awk 'NR > 5000 && $1 == "ODOM" { print NR; exit }' "$plain")
ln_flaser=$(awk 'NR > 9000 && $1 == "FLASER" { print NR; exit }' "$plain")
awk -v n="$ln_odom" 'NR == n { $2 = "1.2.3" } { print }' "$plain" | gzip -n >"$scratch/bad.log.gz"
expect_exit2 "carmen non-numeric ODOM x at line $ln_odom (.gz)" "$ln_odom" "$scratch/bad.log.gz" \
  "$scratch/bad.odolog" "$py" "$car" "$scratch/bad.log.gz" --out "$scratch/bad.odolog"
awk -v n="$ln_flaser" 'NR == n { $3 = "" } { print }' "$plain" >"$scratch/bad.log"
expect_exit2 "carmen FLASER missing a range at line $ln_flaser" "$ln_flaser" "$scratch/bad.log" \
  "$scratch/bad.odolog" "$py" "$car" "$scratch/bad.log" --out "$scratch/bad.odolog"

# The five buildings, each with the options it needs (docs/real-data.md, "CARMEN logs: what
# the importer reads"): aces and orebro write a no-return code no PARAM states (50 m, 32.759
# to 32.767 m); csail's stamps have 6 significant digits and orebro's are 0 (--time order);
# orebro keeps raw odometry for 17 of its 236 intervals (--missing-odometry flaser).
declare -A bopts=([intel]="" [aces]="--no-return 50" [freiburg-079]="" [csail]="--time order"
                  [orebro]="--time order --missing-odometry flaser --no-return 32.759")
printf '%s\n' "--   building      beams  laser record (N ANGLE_MIN ANGLE_INC RANGE_MAX SIGMA MOUNT)      scans   enc  split gaps"
for b in intel aces freiburg-079 csail orebro; do
  blog="$car_data/carmen/$b-corrected.log.gz"
  if [ ! -e "$blog" ]; then odoerr_data_skip_message "the CARMEN building $b" "carmen/$b-corrected.log.gz"; continue; fi
  bo="$out/carmen-$b-scans.odolog"
  # shellcheck disable=SC2086
  if ! msg="$("$py" "$car" "$blog" --out "$bo" --scans ${bopts[$b]} 2>&1)"; then fail "carmen $b import: $msg"; continue; fi
  if res="$("$py" "$chk" "$bo" --carmen-log "$blog")"; then
    pass "carmen $b --scans${bopts[$b]:+ ${bopts[$b]}}: checked against its log"
  else
    fail "carmen $b: check"
  fi
  echo "$res" | sed 's/^/     /'
  printf -- '--   %-13s %5s  %-62s %5s %5s %5s %4s\n' "$b" "$(awk '/^laser /{print $2}' "$bo")" \
    "$(grep '^laser ' "$bo" | cut -d' ' -f2-)" "$(grep -c '^truth ' "$bo")" "$(grep -c '^enc ' "$bo")" \
    "$(awk '/^meta odometry_split /{print $3}' "$bo")" "$(awk '/^meta odometry_gaps /{print $3}' "$bo")"
  if [ -n "$odoerr" ]; then
    if rmsg="$("$odoerr" replay "$bo" --out "$scratch/replay-$b" 2>&1)" &&
       "$py" -c "import json,sys; j=json.load(open(sys.argv[1])); sys.exit(0 if j['truth_records_scored'] == int(sys.argv[2]) else 1)" \
         "$scratch/replay-$b/replay.json" "$(grep -c '^truth ' "$bo")"; then
      pass "carmen $b: odoerr replay reads it (every truth record scored)"
    else
      fail "carmen $b: odoerr replay: $rmsg"
    fi
  fi
done
[ -n "$odoerr" ] || echo "--   no odoerr binary (--odoerr): the replays are skipped"
# what those options are for: without them the importer refuses, naming the line and why
if [ -e "$car_data/carmen/csail-corrected.log.gz" ]; then
  expect_exit2 "carmen csail without --time order (stamps of 6 significant digits)" 184 \
    "$car_data/carmen/csail-corrected.log.gz" "$scratch/bad.odolog" \
    "$py" "$car" "$car_data/carmen/csail-corrected.log.gz" --out "$scratch/bad.odolog"
fi
if [ -e "$car_data/carmen/orebro-corrected.log.gz" ]; then
  expect_exit2 "carmen orebro without --time order (stamps 0)" 2 \
    "$car_data/carmen/orebro-corrected.log.gz" "$scratch/bad.odolog" \
    "$py" "$car" "$car_data/carmen/orebro-corrected.log.gz" --out "$scratch/bad.odolog"
  expect_exit2 "carmen orebro without --missing-odometry flaser (no raw odometry since the anchor)" 5 \
    "$car_data/carmen/orebro-corrected.log.gz" "$scratch/bad.odolog" \
    "$py" "$car" "$car_data/carmen/orebro-corrected.log.gz" --out "$scratch/bad.odolog" --time order
fi
fi

echo
if [ "$fails" -eq 0 ]; then
  echo "all importer checks passed${skips[*]:+ (${#skips[@]} part skipped, above)}"
  exit 0
fi
echo "$fails importer check(s) failed"
exit 1

#!/usr/bin/env bash
# cli_import.sh ODOERR OUTDIR: `odoerr map import | render | compile` end to end on a
# synthetic map (no real data needed): the tool hands over to tools/map/odoerr_map.py, the
# .odomap it writes is read back by the C++ side (map compile), and a bad map is refused
# with the file and the problem named.
set -u
bin="$1"; out="$2"
here="$(cd "$(dirname "$0")" && pwd)"
py=/usr/bin/python3
fails=0
pass() { echo "ok   $*"; }
fail() { echo "FAIL $*"; fails=$((fails + 1)); }
mkdir -p "$out" || exit 1

"$py" "$here/synth_grid.py" "$out/syn" >/dev/null || { echo "FAIL synthetic grid"; exit 1; }
if msg="$("$bin" map import "$out/syn.yaml" --out "$out/syn.odomap" --png "$out/syn.png" 2>&1)"; then
  pass "odoerr map import: $msg"
else
  fail "odoerr map import exit $?: $msg"
fi
n="$(grep -c '^segment ' "$out/syn.odomap" 2>/dev/null || echo 0)"
if [ "$(head -n 1 "$out/syn.odomap" 2>/dev/null)" = "odomap 1" ] && [ "$n" -ge 8 ] && [ "$n" -le 24 ]; then
  pass "syn.odomap: 'odomap 1', $n segments for 8 walls"
else
  fail "syn.odomap: header or segment count ($n) wrong"
fi
grep -q '^meta fit rms_m=' "$out/syn.odomap" && pass "the fit is recorded (meta fit)" || fail "no 'meta fit' line"
[ -s "$out/syn.png" ] && pass "PNG written by import --png" || fail "no PNG from import --png"
if msg="$("$bin" map compile "$out/syn.odomap" --out "$out/syn_table.cpp" 2>&1)" && grep -q "$n walls" <<<"$msg"; then
  pass "the C++ reader takes the odomap: $msg"
else
  fail "odoerr map compile on the odomap: $msg"
fi
if msg="$("$bin" map render "$out/syn.odomap" --grid "$out/syn.yaml" --out "$out/syn-render.png" 2>&1)" && [ -s "$out/syn-render.png" ]; then
  pass "odoerr map render: $msg"
else
  fail "odoerr map render: $msg"
fi
sed '/^origin:/d' "$out/syn.yaml" > "$out/bad.yaml"
if msg="$("$bin" map import "$out/bad.yaml" --out "$out/bad.odomap" 2>&1)"; then
  fail "a YAML without origin was accepted"
elif grep -q "bad.yaml: missing key 'origin'" <<<"$msg" && [ ! -e "$out/bad.odomap" ]; then
  pass "missing key refused, nothing written: $msg"
else
  fail "missing key: unexpected message: $msg"
fi
[ "$fails" -eq 0 ] && echo "all cli map checks passed" && exit 0
echo "$fails check(s) failed"; exit 1

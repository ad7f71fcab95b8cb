#!/usr/bin/env bash
# The README's one-minute tour, as written there: a differential drive with 4 % turn slip
# hidden in it; diagnose must call it inconsistent and name turn_slip, and --with auto must
# add turn_slip and lower the held-out pose error (the printed line the README shows).
# Usage: readme_tour.sh ODOERR OUT_DIR
set -euo pipefail
odoerr="$1"; out="$2"
mkdir -p "$out"; cd "$out"
"$odoerr" sim --drive diff --effect turn_slip=0.04 --seed 4 --out drive.odolog 2>/dev/null
"$odoerr" diagnose drive.odolog --json d.json 2> plain.txt
"$odoerr" diagnose drive.odolog --json d.json --with auto 2> auto.txt
cat plain.txt auto.txt
grep -q "verdict inconsistent; effects named: turn_slip " plain.txt
# "  added turn_slip (0.0395...): held-out pose error A -> B mm (paired z Z over N blocks)", B < A, Z <= -2
/usr/bin/python3 - auto.txt <<'PY'
import re, sys
text = open(sys.argv[1]).read()
m = re.search(r"added turn_slip \(([0-9.]+)\): held-out pose error ([0-9.]+) -> ([0-9.]+) mm \(paired z (-?[0-9.]+)", text)
assert m, "no 'added turn_slip' line:\n" + text
est, before, after, z = map(float, m.groups())
assert abs(est - 0.04) < 0.004, est
assert after < before and z <= -2, (before, after, z)
print("tour: turn_slip %.4f (truth 0.04), held-out pose error %.1f -> %.1f mm, z %.1f" % (est, before, after, z))
PY

#!/usr/bin/env bash
# suggest_compiles.sh ODOERR OUTDIR CXX SRC_DIR: `diagnose --suggest` on a drive whose
# residuals depend on a feature writes an effect skeleton, and the skeleton compiles into a
# model (the tutorial's form: exact Jacobians from the feature library).
set -euo pipefail
odoerr="$1"; out="$2"; cxx="$3"; src="$4"
mkdir -p "$out"
"$odoerr" sim --drive diff --effect turn_slip=0.04 --seed 4 --out "$out/drive.odolog"
"$odoerr" diagnose "$out/drive.odolog" --json "$out/d.json" --suggest "$out/suggest"
hpp="$out/suggest/discovered_effect.hpp"
test -s "$hpp" || { echo "no $hpp"; exit 1; }
grep -q "struct DiscoveredMotion" "$hpp" || { echo "no motion effect in $hpp:"; cat "$hpp"; exit 1; }
cat > "$out/use.cpp" <<CPP
#include "odoerr/estimator.hpp"
#include "$hpp"
using M = odoerr::Model<odoerr::DiffDrive<double>, odoerr::effects::DiscoveredMotion>;
int main() {
  M m(odoerr::DiffDrive<double>{});
  M::StateVec x = M::StateVec::Zero();
  M::setNominal(x);
  const auto inc = m.increment(M::Input{0.01, 0.012}, x, M::NoiseVec::Zero());
  return inc.rho > 0 ? 0 : 1;
}
CPP
"$cxx" -std=c++17 -Wall -Wextra -Werror -Wdouble-promotion -Wshadow -I "$src/core/include" -isystem /usr/include/eigen3 \
  "$out/use.cpp" -o "$out/use"
"$out/use"
echo "ok: $hpp compiles into a model and runs"

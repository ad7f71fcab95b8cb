#!/usr/bin/env bash
# Builds everything and runs all tests: the host suite (unit, Monte Carlo, CLI, the paper
# acceptance run), then the Cortex-M4F images under QEMU against the host's references.
# Usage: scripts/test.sh [--long]   (--long adds the statistical diagnose tests over many
#                                     seeds, label diagnose-long, about 10 minutes)
set -euo pipefail
long="${1:-}"
cd "$(dirname "$0")/.."
bash scripts/deps.sh --target
cmake --preset host
cmake --build --preset host -j 2
if [ "$long" = "--long" ]; then
  ctest --preset host
else
  ctest --preset host -LE diagnose-long
fi
cmake --preset cortex-m4f
cmake --build --preset cortex-m4f -j 2
ctest --preset cortex-m4f

#!/usr/bin/env bash
# Builds everything and runs all tests (unit, Monte Carlo, CLI, the paper acceptance run).
# Usage: scripts/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
cmake --preset host
cmake --build --preset host -j 2
ctest --preset host

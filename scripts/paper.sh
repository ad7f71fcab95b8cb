#!/usr/bin/env bash
# The main job: reproduce the paper's experiment (Section 5) for both drives.
# Usage: scripts/paper.sh [RUNS]   -> out/paper-sync/, out/paper-diff/
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS="${1:-100}"
bash scripts/deps.sh
cmake --preset host >/dev/null
cmake --build --preset host --target odoerr -j 2
for drive in sync diff; do
  ./build/host/tools/odoerr/odoerr paper --drive "$drive" --runs "$RUNS" --out "out/paper-$drive"
done
echo "Results: out/paper-sync/ and out/paper-diff/ (summary.json, paper_*.csv, fig*.png, pose_*.png)"

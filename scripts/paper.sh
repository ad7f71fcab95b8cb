#!/usr/bin/env bash
# The main job: reproduce the paper's experiment (Section 5) for both drives.
# Usage: scripts/paper.sh [RUNS]   -> out/paper-{sync,diff}/ (the paper's OF), out/paper-{sync,diff}-ml/
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS="${1:-100}"
bash scripts/deps.sh
cmake --preset host >/dev/null
# Only the experiment's binary (odoerr-paper: `odoerr paper` alone, linking odoerr::paper).
cmake --build --preset host --target odoerr-paper -j 2 >/dev/null
# The paper's Observable Filter, then odoerr's maximum-likelihood K estimator (--of ml,
# docs/nonsystematic.md) on the same drives (the same seeds), side by side.
for drive in sync diff; do
  ./build/host/tools/odoerr/odoerr-paper --drive "$drive" --runs "$RUNS" --out "out/paper-$drive"
  ./build/host/tools/odoerr/odoerr-paper --drive "$drive" --runs "$RUNS" --of ml --out "out/paper-$drive-ml"
done
# --paired: each quantity's end error, ml over the OF's run by run, with a 95 % interval
# (needs 10 runs or more).
paired=()
if [ "$RUNS" -ge 10 ]; then paired=(--paired); fi
for drive in sync diff; do
  echo
  /usr/bin/python3 tools/report/paper_compare.py "out/paper-$drive" "out/paper-$drive-ml" "${paired[@]}"
done
# K against its bound over the drive, both estimators side by side (docs/nonsystematic.md).
/usr/bin/python3 sim_host/plots/plot_k_bound.py --run "paper's OF=out/paper-sync" --run "paper's OF=out/paper-diff" \
  --run "ml=out/paper-sync-ml" --run "ml=out/paper-diff-ml" --out out/k-bound.png \
  --title "K at $RUNS runs on the paper's circle: the paper's OF, --of ml, and the bound" >/dev/null
echo
echo "Results: out/paper-{sync,diff}/ (the paper's OF) and out/paper-{sync,diff}-ml/ (summary.json, paper_*.csv, fig*.png, pose_*.png); out/k-bound.png (K against its bound, both estimators)"

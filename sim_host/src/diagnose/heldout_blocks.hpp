// diagnose, the held-out blocks and folds: after the warm-up, the drive cut into short
// blocks (the fit dead-reckons through a block and its gaps, so a block must be short
// enough to relocalise after); fold f holds out blocks f, f + folds, ... A fit leaves out
// its fold's blocks and gap_s either side of them; its evaluation predicts them.
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace odoerr::sim::diag {

class HeldoutBlocks {
 public:
  HeldoutBlocks() = default;
  /// The blocks of a drive whose events are at `times` (non-decreasing; warmup_s, gap_s,
  /// block_s and folds as in DiagnoseOptions): the time after warmup_s + gap_s cut into
  /// whole blocks of block_s, of which those that hold an event are kept (a pause in the log
  /// makes none: the cost follows the events, not the time they span), numbered in time
  /// order. Fewer folds than asked when the drive has fewer blocks.
  HeldoutBlocks(const std::vector<double>& times, double warmup_s, double gap_s, double block_s, int folds)
      : gap_s_(gap_s), block_s_(block_s) {
    if (times.empty() || !(block_s > 0)) return;
    start_ = times.front() + warmup_s + gap_s;
    const double whole = std::floor((times.back() - start_) / block_s);  // whole blocks up to the last event
    for (double t : times) {
      const double g = std::floor((t - start_) / block_s);  // the block's index on the grid
      if (!(g >= 0 && g < whole)) continue;
      if (grid_.empty() || grid_.back() < g) {
        grid_.push_back(g);
        blocks_.push_back({start_ + g * block_s, start_ + (g + 1) * block_s});
      }
    }
    folds_ = std::max(0, std::min(folds, static_cast<int>(blocks_.size())));
  }

  /// The block that holds time t (-1: none).
  int blockAt(double t) const {
    if (blocks_.empty()) return -1;
    const double g = std::floor((t - start_) / block_s_);
    const auto it = std::lower_bound(grid_.begin(), grid_.end(), g);
    return it != grid_.end() && *it == g ? static_cast<int>(it - grid_.begin()) : -1;
  }
  bool heldBlock(int b, int fold) const { return b >= 0 && folds_ > 0 && b % folds_ == fold; }
  bool inHeldout(double t, int fold) const { return heldBlock(blockAt(t), fold); }
  /// Within gap_s of a block held out in this fold (the fit does not use it either).
  bool nearHeldout(double t, int fold) const {
    if (blocks_.empty()) return false;
    const double lo = std::floor((t - gap_s_ - start_) / block_s_);
    const double hi = std::floor((t + gap_s_ - start_) / block_s_);
    for (auto it = std::lower_bound(grid_.begin(), grid_.end(), lo); it != grid_.end() && *it <= hi; ++it)
      if (heldBlock(static_cast<int>(it - grid_.begin()), fold)) return true;
    return false;
  }
  const std::vector<std::pair<double, double>>& blocks() const { return blocks_; }
  int folds() const { return folds_; }

 private:
  std::vector<std::pair<double, double>> blocks_;  ///< [start, end) of each; block b in fold b % folds_
  std::vector<double> grid_;                        ///< each block's index on the grid of block_s from start_
  double start_ = 0, gap_s_ = 0, block_s_ = 0;
  int folds_ = 0;
};

}  // namespace odoerr::sim::diag

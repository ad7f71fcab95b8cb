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
  /// The blocks of a drive from t0 to t1 (warmup_s, gap_s, block_s and folds as in
  /// DiagnoseOptions); fewer folds than asked when the drive has fewer blocks.
  HeldoutBlocks(double t0, double t1, double warmup_s, double gap_s, double block_s, int folds)
      : start_(t0 + warmup_s + gap_s), gap_s_(gap_s), block_s_(block_s) {
    const double span = t1 - start_;
    const int nb = block_s > 0 && span > 0 ? static_cast<int>(span / block_s) : 0;
    for (int b = 0; b < nb; ++b) blocks_.push_back({start_ + b * block_s, start_ + (b + 1) * block_s});
    folds_ = std::max(0, std::min(folds, nb));
  }

  /// The block that holds time t (-1: none).
  int blockAt(double t) const {
    if (blocks_.empty() || t < start_) return -1;
    const int b = static_cast<int>((t - start_) / block_s_);
    return b < static_cast<int>(blocks_.size()) ? b : -1;
  }
  bool heldBlock(int b, int fold) const { return b >= 0 && folds_ > 0 && b % folds_ == fold; }
  bool inHeldout(double t, int fold) const { return heldBlock(blockAt(t), fold); }
  /// Within gap_s of a block held out in this fold (the fit does not use it either).
  bool nearHeldout(double t, int fold) const {
    if (blocks_.empty()) return false;
    const double lo = std::floor((t - gap_s_ - start_) / block_s_);
    const double hi = std::floor((t + gap_s_ - start_) / block_s_);
    const int last = static_cast<int>(blocks_.size()) - 1;
    for (int b = static_cast<int>(std::max(0.0, lo)); b <= std::min(double(last), hi); ++b)
      if (heldBlock(b, fold)) return true;
    return false;
  }
  const std::vector<std::pair<double, double>>& blocks() const { return blocks_; }
  int folds() const { return folds_; }

 private:
  std::vector<std::pair<double, double>> blocks_;  ///< [start, end) of each; block b in fold b % folds_
  double start_ = 0, gap_s_ = 0, block_s_ = 0;
  int folds_ = 0;
};

}  // namespace odoerr::sim::diag

// diagnose, the held-out comparison (--with), cross-validated over time: in each fold, fit
// on the kept data (OF free), then evaluate with everything fitted held, predicting the
// fold's held-out blocks from anchors. Before (the model as it is) and after (with the
// effects), compared over the beams both predicted, in means and paired by block.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine.hpp"

namespace odoerr::sim::diag {

struct HeldoutResult {
  nlohmann::ordered_json json;               ///< the "heldout" object of the contract
  std::vector<HeldScan> before, after;       ///< every used fold's predicted held-out scans, by time
};

/// Compares the model with the effects `before` (indices of the engine's effects) against
/// the model with the effects `after`, on held-out data. The two sides may run on different
/// engines of one type (the same effects, other feature slots: `--with feature:...`); the
/// models need not be nested (a catalogue effect against discovered features: the rival
/// test). `names` is what the JSON lists under "with"; its fold estimates are those of the
/// effects in `after` and not in `before`. `leave_out` (may be null): beams by key
/// (scan * beams + beam, as RunSpec::scored) that neither side scores, the beams ending in
/// a region the map gets wrong.
template <typename En>
HeldoutResult compareModels(const En& before_en, const std::vector<int>& before, const En& after_en,
                            const std::vector<int>& after, const std::vector<std::string>& names,
                            const DiagnoseOptions& opt, const std::vector<std::uint8_t>* leave_out);

/// The nested comparison: the model with `before` against the same with `added` too.
template <typename En>
HeldoutResult compareHeldout(const En& before_en, const std::vector<int>& before, const En& after_en,
                             const std::vector<int>& added, const std::vector<std::string>& names,
                             const DiagnoseOptions& opt, const std::vector<std::uint8_t>* leave_out) {
  std::vector<int> after = before;
  after.insert(after.end(), added.begin(), added.end());
  return compareModels(before_en, before, after_en, after, names, opt, leave_out);
}

/// The same on one engine.
template <typename En>
HeldoutResult compareHeldout(const En& en, const std::vector<int>& before, const std::vector<int>& added,
                             const std::vector<std::string>& names, const DiagnoseOptions& opt,
                             const std::vector<std::uint8_t>* leave_out) {
  return compareHeldout(en, before, en, added, names, opt, leave_out);
}

/// heldout_before.csv and heldout_after.csv in dir (false with *error if not writable).
bool writeHeldoutCsv(const std::string& dir, const HeldoutResult& r, std::string* error);

}  // namespace odoerr::sim::diag

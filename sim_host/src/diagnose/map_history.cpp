#include "map_history.hpp"

#include <algorithm>
#include <cmath>

namespace odoerr::sim::diag {

namespace {
constexpr int kMinSide = 20;          // a change needs this many scans on each side of it,
constexpr double kMinSideShare = 0.1; // and this share of them
constexpr double kHigh = 0.7;         // a side disagrees "always" at this share or more
constexpr double kLow = 0.2;          // and "never" at this share or less
constexpr double kPersistent = 0.6;   // no change: this share or more is a persistent misfit
constexpr double kTransient = 0.3;    // this share or less: something passing (people, things moved about)
}  // namespace

// The rules:
// - changed: some time splits the scans (at least kMinSide and kMinSideShare of them on each
//   side) into one side that
//   disagreed in kHigh or more of its scans and one that did in kLow or less; the split with
//   the largest difference of shares. A door opened or closed, an object moved in or out.
// - persistent: otherwise, disagreed in kPersistent or more of the scans that saw it: the
//   map is wrong there (a wall or object it lacks, one it has that is not there).
// - transient: disagreed in kTransient or less: something that comes and goes (people
//   walking by, a trolley), not the map's fault.
// - intermittent: in between.
RegionHistory regionHistory(std::vector<RegionSighting> seen) {
  RegionHistory h;
  if (seen.empty()) return h;
  std::sort(seen.begin(), seen.end(), [](const RegionSighting& a, const RegionSighting& b) { return a.t < b.t; });
  const int n = static_cast<int>(seen.size());
  h.scans = n;
  h.t_first = seen.front().t;
  h.t_last = seen.back().t;
  std::vector<int> cum(static_cast<std::size_t>(n) + 1, 0);
  for (int i = 0; i < n; ++i) {
    const RegionSighting& s = seen[static_cast<std::size_t>(i)];
    cum[static_cast<std::size_t>(i) + 1] = cum[static_cast<std::size_t>(i)] + (s.disagreed ? 1 : 0);
    if (s.disagreed) {
      if (h.disagreed == 0) h.t_disagreed_first = s.t;
      h.t_disagreed_last = s.t;
      ++h.disagreed;
    }
  }
  double best = 0;
  const int side = std::max(kMinSide, static_cast<int>(std::ceil(kMinSideShare * n)));
  for (int k = side; k <= n - side; ++k) {
    const double before = double(cum[static_cast<std::size_t>(k)]) / k;
    const double after = double(h.disagreed - cum[static_cast<std::size_t>(k)]) / (n - k);
    const bool step = (before >= kHigh && after <= kLow) || (before <= kLow && after >= kHigh);
    if (step && std::abs(before - after) > best) {
      best = std::abs(before - after);
      h.changed = true;
      h.t_change = 0.5 * (seen[static_cast<std::size_t>(k) - 1].t + seen[static_cast<std::size_t>(k)].t);
      h.share_before = before;
      h.share_after = after;
    }
  }
  const double share = double(h.disagreed) / n;
  h.kind = h.changed ? "changed" : share >= kPersistent ? "persistent" : share <= kTransient ? "transient" : "intermittent";
  return h;
}

using Json = nlohmann::ordered_json;

nlohmann::ordered_json regionHistoryJson(const RegionHistory& h) {
  Json j = {{"kind", h.kind},
            {"seen", {{"scans", h.scans}, {"t_first", h.t_first}, {"t_last", h.t_last}}},
            {"disagreed", {{"scans", h.disagreed},
                           {"share", h.scans > 0 ? Json(double(h.disagreed) / h.scans) : Json(nullptr)},
                           {"t_first", h.disagreed > 0 ? Json(h.t_disagreed_first) : Json(nullptr)},
                           {"t_last", h.disagreed > 0 ? Json(h.t_disagreed_last) : Json(nullptr)}}}};
  j["change"] = h.changed ? Json({{"t", h.t_change}, {"share_before", h.share_before}, {"share_after", h.share_after}})
                          : Json(nullptr);
  return j;
}

}  // namespace odoerr::sim::diag

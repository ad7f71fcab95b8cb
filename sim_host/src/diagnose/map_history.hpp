// diagnose, where the map is wrong: when. A region of the map misfit was seen by many
// scans; each of them either disagreed with the map there or did not. A wall the map lacks
// disagrees whenever it is seen; a door opened half-way through the drive disagrees only
// after (or before) a time; a person walking by disagrees in the few scans that caught
// them. docs/diagnostics.md ("Where the map is wrong: when") states the rules.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace odoerr::sim::diag {

/// A scan that saw a region: its time and whether its beams there disagreed with the map.
struct RegionSighting {
  double t;
  bool disagreed;
};

struct RegionHistory {
  int scans = 0;                   ///< scans that saw the region
  double t_first = 0, t_last = 0;  ///< the first and last of them (s)
  int disagreed = 0;               ///< scans whose beams there disagreed with the map
  double t_disagreed_first = 0, t_disagreed_last = 0;
  /// persistent | changed | transient | intermittent (RegionHistory rules in the .cpp)
  std::string kind;
  bool changed = false;            ///< the share of disagreeing scans steps at t_change
  double t_change = 0, share_before = 0, share_after = 0;
};

/// A scan disagrees when the mean normalised residual of its beams in the region is this
/// far beyond zero in the region's sign (short: below -kDisagreeZ; long: above).
constexpr double kDisagreeZ = 2.0;

/// The history of a region from its sightings (any order).
RegionHistory regionHistory(std::vector<RegionSighting> seen);

nlohmann::ordered_json regionHistoryJson(const RegionHistory& h);

}  // namespace odoerr::sim::diag

// sim_host: what the odolog reader found, for the tools' JSON reports.
#pragma once

#include <nlohmann/json.hpp>

#include "odoerr/sim/odolog.hpp"

namespace odoerr::sim {

/// The plausibility rule's outcome (docs/odolog.md, "Plausibility"): how many encoder
/// increments were rejected, the limits used and where they came from, and the first
/// rejections (time, line, channel, ticks, limit). Every tool that reads a log reports it.
nlohmann::ordered_json rejectionsJson(const Odolog& log, std::size_t first = 20);

}  // namespace odoerr::sim

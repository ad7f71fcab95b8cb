// sim_host: the map's tables as C++ source for the firmware (`odoerr map compile`): the
// walls and the grid index of a HostMap<float>, as constant arrays and one constant
// MapTables<float> that the firmware wraps in a MapView. Everything is a constant
// expression, so the linker places it in flash and nothing is built at boot.
#pragma once

#include <string>

#include "odoerr/sim/host_map.hpp"

namespace odoerr::sim {

/// The source text defining `extern const odoerr::MapTables<float> SYMBOL;` (declare it
/// with the same line where it is used). `provenance` goes into the leading comment.
std::string mapTableSource(const HostMap<float>& map, const std::string& symbol, const std::string& provenance);

/// Bytes of flash the tables take (walls, cell starts, items, the MapTables itself).
std::size_t mapTableBytes(const HostMap<float>& map);

}  // namespace odoerr::sim

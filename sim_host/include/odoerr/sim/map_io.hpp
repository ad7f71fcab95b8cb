// sim_host: the walls of a map file for the commands that take --map.
#pragma once

#include <string>
#include <vector>

#include "odoerr/sim/odolog.hpp"

namespace odoerr::sim {

/// The walls of MAP: an odolog file's `wall` records. False with *error naming the file
/// (and the line) when it cannot be read or has no wall.
bool readMapWalls(const std::string& path, std::vector<OdologWall>* walls, std::string* error);

}  // namespace odoerr::sim

#include "odoerr/sim/map_io.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

namespace odoerr::sim {

// Interim reader of the `segment` records of an .odomap file, until the map module's
// readMapSegments lands on this branch.
static bool readOdomapSegments(const std::string& path, std::vector<OdologWall>* walls, std::string* error) {
  std::ifstream f(path);
  std::string line;
  int n = 0;
  walls->clear();
  while (std::getline(f, line)) {
    ++n;
    std::istringstream is(line);
    std::string t;
    if (!(is >> t) || t[0] == '#') continue;
    if (t != "segment") continue;
    OdologWall w;
    if (!(is >> w.x1 >> w.y1 >> w.x2 >> w.y2)) {
      *error = path + ":" + std::to_string(n) + ": 'segment' takes 4 numbers";
      return false;
    }
    walls->push_back(w);
  }
  return true;
}

bool readMapWalls(const std::string& path, std::vector<OdologWall>* walls, std::string* error) {
  std::ifstream f(path);
  std::string first;
  if (!f || !(f >> first)) {
    *error = "cannot read map file '" + path + "'";
    return false;
  }
  if (first == "odomap") {
    if (!readOdomapSegments(path, walls, error)) return false;
  } else {
    Odolog log;
    if (!readOdolog(path, &log, error)) return false;
    *walls = log.walls;
  }
  if (walls->empty()) {
    *error = path + ": the map has no wall";
    return false;
  }
  return true;
}

}  // namespace odoerr::sim

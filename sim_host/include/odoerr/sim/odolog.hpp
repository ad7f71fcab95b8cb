// sim_host: reader of odolog v1 files (../shared/spec/odolog-v1.md). A file that breaks a
// rule is rejected with "FILE:LINE: rule"; the reader never guesses. Unknown record types
// are skipped and counted.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace odoerr::sim {

struct OdologLaser {
  int beams = 0;
  double angle_min = 0, angle_inc = 0, range_max = 0, sigma = 0;
  double mount_x = 0, mount_y = 0, mount_yaw = 0;
};

struct OdologEnc {
  double t;
  std::int64_t a;  ///< diff: right wheel ticks; sync: translation ticks (cumulative)
  std::int64_t b;  ///< diff: left wheel ticks; sync: steering ticks (cumulative)
};

struct OdologScan {
  double t;
  std::vector<double> ranges;  ///< nan = no return
};

struct OdologPose {
  double t, x, y, theta, sx, sy, stheta;
};

struct OdologTruth {
  double t, x, y, theta;
};

struct OdologWall {
  double x1, y1, x2, y2;
};

struct Odolog {
  std::string path;
  std::string drive;  ///< "diff" or "sync"
  std::vector<std::pair<std::string, double>> params;
  std::vector<std::pair<std::string, std::string>> meta;
  bool has_laser = false;
  OdologLaser laser;
  std::vector<OdologWall> walls;
  bool has_init = false;
  OdologPose init{};  ///< t unused
  std::vector<OdologEnc> enc;
  std::vector<OdologScan> scans;
  std::vector<OdologPose> poses;
  std::vector<OdologTruth> truth;
  int unknown_records = 0;

  /// The value of a `param`, or `fallback` when absent.
  double param(const std::string& name, double fallback) const;
  bool hasParam(const std::string& name) const;
};

/// Parses an odolog v1 text. On failure returns false and sets *error to
/// "NAME:LINE: what rule was broken". `name` is used in messages only.
bool parseOdolog(const std::string& text, const std::string& name, Odolog* out, std::string* error);

/// Reads and parses a file; errors name the file (and the line).
bool readOdolog(const std::string& path, Odolog* out, std::string* error);

}  // namespace odoerr::sim

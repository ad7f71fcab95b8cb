// sim_host: reader of odolog v1 files (docs/odolog.md). A file that breaks a
// rule is rejected with "FILE:LINE: rule"; the reader never guesses. Unknown record types
// are skipped and counted.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "odoerr/scalar.hpp"

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
  int line = 0;    ///< the record's line in the file (0: not from a file)
};

/// An encoder increment the reader rejected: more than the drive can do in its interval
/// (docs/odolog.md, "Plausibility"). It contributes nothing; the later counts of its channel
/// are shifted by it, so one glitch costs one interval, as in the firmware's encoder driver.
struct OdologRejection {
  double t;       ///< the record's time (s)
  int line;       ///< its line
  char channel;   ///< 'A' or 'B'
  double ticks;   ///< the increment (a double: it may lie beyond the 64-bit range)
  double limit;   ///< the most the drive can do in that interval (ticks)
};

/// The limits the plausibility rule used: the fastest each channel can count and the
/// margin allowed beyond it in any interval (the read time's jitter).
struct OdologLimits {
  double max_speed_mps = 0;        ///< diff: each wheel; sync: the translation
  double max_steer_rate_radps = 0; ///< sync only
  bool speed_given = false, steer_given = false;  ///< from the header's params, else defaults
  double ticks_per_s_a = 0, ticks_per_s_b = 0;
  double margin_ticks = 0;
  /// The shortest interval the speed rule uses: twice the log's median interval between
  /// `enc` records (a logger's stamps jitter: a record stamped early carries more motion).
  double dt_floor_s = 0;
  /// `meta time_base order`: the stamps order the records but do not measure time (an
  /// importer's `--time order`); the rule is then the log's own: kSyntheticFactor x the
  /// channel's median nonzero increment.
  bool synthetic_time = false;
  double median_increment_a = 0, median_increment_b = 0;
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
  OdologLimits enc_limits;                   ///< the plausibility rule's limits
  std::vector<OdologRejection> enc_rejected;  ///< the increments it rejected, in time order

  /// The value of a `param`, or `fallback` when absent.
  double param(const std::string& name, double fallback) const;
  bool hasParam(const std::string& name) const;
};

/// The drive constants a log gives: counts per unit of each encoder channel (sync: per m of
/// translation and per rad of steering; diff: per m of wheel travel, both wheels) and the
/// nominal wheelbase (diff; 0.5 m when absent).
struct DriveConstants {
  double ticks_a = 1, ticks_b = 1, wheelbase = 0.5;
};
DriveConstants driveConstants(const Odolog& log, bool sync);

/// Encoder counts (possibly interpolated) at time t from the sorted enc records.
struct CountsAt {
  double a, b;
};

/// Walks the sorted enc records forward in time.
class EncCursor {
 public:
  explicit EncCursor(const std::vector<OdologEnc>& e) : e_(e) {}
  CountsAt at(double t) {
    while (i_ + 1 < e_.size() && e_[i_ + 1].t <= t) ++i_;
    const OdologEnc& lo = e_[i_];
    if (t <= lo.t || i_ + 1 >= e_.size()) return {double(lo.a), double(lo.b)};
    const OdologEnc& hi = e_[i_ + 1];
    const double w = hi.t > lo.t ? (t - lo.t) / (hi.t - lo.t) : 1.0;
    return {double(lo.a) + w * double(hi.a - lo.a), double(lo.b) + w * double(hi.b - lo.b)};
  }

 private:
  const std::vector<OdologEnc>& e_;
  std::size_t i_ = 0;
};

/// Walks the truth records forward in time.
struct TruthCursor {
  const std::vector<OdologTruth>& v;
  std::size_t i = 0;
  /// Truth interpolated at t (false when the log has none around t).
  bool at(double t, double* x, double* y, double* th) {
    if (v.empty() || t < v.front().t || t > v.back().t) return false;
    while (i + 1 < v.size() && v[i + 1].t <= t) ++i;
    const OdologTruth& lo = v[i];
    const OdologTruth& hi = i + 1 < v.size() ? v[i + 1] : v[i];
    const double w = hi.t > lo.t ? (t - lo.t) / (hi.t - lo.t) : 0.0;
    *x = lo.x + w * (hi.x - lo.x);
    *y = lo.y + w * (hi.y - lo.y);
    *th = wrapAngle(lo.theta + w * wrapAngle(hi.theta - lo.theta));
    return true;
  }
  /// Whether the last at(t) fell on a truth record rather than between two.
  bool onRecord(double t) const { return !v.empty() && v[i].t == t; }
};

/// Parses an odolog v1 text. On failure returns false and sets *error to
/// "NAME:LINE: what rule was broken". `name` is used in messages only.
bool parseOdolog(const std::string& text, const std::string& name, Odolog* out, std::string* error);

/// Reads and parses a file; errors name the file (and the line).
bool readOdolog(const std::string& path, Odolog* out, std::string* error);

/// The defaults of the plausibility rule (docs/odolog.md, "Plausibility"), used when the
/// header has no `param max_speed_mps` / `param max_steer_rate_radps`.
inline constexpr double kDefaultMaxSpeedMps = 5.0;
inline constexpr double kDefaultMaxSteerRateRadps = 10.0;
inline constexpr double kEncMarginTicks = 16.0;
inline constexpr double kSyntheticFactor = 100.0;
/// The reach of a pose's X and Y (`init`, `pose`, `truth`; docs/odolog.md, rule R34): 2^46 m,
/// 7.04 x 10^13 m. Below it doubles are at most 2^-7 m apart, finer than the 1 cm travel
/// cycle; beyond it a coordinate is a damaged field, and its square could overflow.
inline constexpr double kPoseReachM = 70368744177664.0;

/// One line for a printed summary: "" when nothing was rejected, else e.g.
/// "2 encoder increments rejected as impossible (the first at LOG:57, t=12.30 s, channel A:
/// 1000000 ticks, at most 44)".
std::string rejectionSummary(const Odolog& log);

}  // namespace odoerr::sim

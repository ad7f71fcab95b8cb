#include "odoerr/sim/odolog.hpp"

#include "odoerr/scalar.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

namespace odoerr::sim {

double Odolog::param(const std::string& name, double fallback) const {
  for (const auto& p : params) {
    if (p.first == name) return p.second;
  }
  return fallback;
}

bool Odolog::hasParam(const std::string& name) const {
  for (const auto& p : params) {
    if (p.first == name) return true;
  }
  return false;
}

namespace {

struct Parser {
  std::string name;
  int line = 0;
  std::string* error;

  bool fail(const std::string& rule) {
    *error = name + ":" + std::to_string(line) + ": " + rule;
    return false;
  }

  /// A finite decimal number (or nan when allowed); the whole token must be consumed.
  bool number(const std::string& tok, const char* what, bool allow_nan, double* out) {
    if (tok == "nan" || tok == "NaN" || tok == "NAN") {
      if (!allow_nan) return fail(std::string(what) + ": nan is allowed only in scan ranges");
      *out = std::nan("");
      return true;
    }
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(tok.c_str(), &end);
    // strtod also reads C hexadecimal floats (0x1p-3); the format's numbers are decimal.
    if (end == tok.c_str() || *end != '\0' || tok.find_first_of("xX") != std::string::npos)
      return fail(std::string(what) + ": '" + tok + "' is not a number");
    if (!std::isfinite(v)) return fail(std::string(what) + ": '" + tok + "' is not a finite number");
    *out = v;
    return true;
  }

  /// A pose's X or Y (init, pose, truth), already read: within kPoseReachM (rule R34).
  bool withinReach(const std::string& tok, const char* what, double v) {
    if (std::fabs(v) < kPoseReachM) return true;
    return fail(std::string(what) + ": " + tok +
                " m is beyond +-2^46 m (7.04e13 m), where doubles are coarser than the 1 cm travel cycle");
  }

  bool integer(const std::string& tok, const char* what, std::int64_t* out) {
    char* end = nullptr;
    errno = 0;
    const long long v = std::strtoll(tok.c_str(), &end, 10);
    if (end == tok.c_str() || *end != '\0') {
      return fail(std::string(what) + ": '" + tok + "' is not a signed 64-bit integer");
    }
    if (errno == ERANGE) return fail(std::string(what) + ": '" + tok + "' does not fit in 64 bits");
    *out = v;
    return true;
  }

  bool count(const std::vector<std::string>& f, std::size_t n, const char* usage) {
    if (f.size() - 1 != n) {
      return fail("'" + f[0] + "' takes " + std::to_string(n) + " fields (" + usage + "), got " +
                  std::to_string(f.size() - 1));
    }
    return true;
  }
};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : line) {
    if (c == '#') break;
    if (c == ' ' || c == '\t' || c == '\r') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

bool isHeader(const std::string& t) {
  return t == "drive" || t == "param" || t == "laser" || t == "wall" || t == "init" || t == "meta";
}
bool isData(const std::string& t) { return t == "enc" || t == "scan" || t == "pose" || t == "truth"; }

// The plausibility rule's fastest counts (docs/odolog.md, "Plausibility"): each channel's
// ticks per second from the drive's constants and its top speed.
void setEncoderLimits(Odolog* log) {
  const bool sync = log->drive == "sync";
  const DriveConstants c = driveConstants(*log, sync);
  OdologLimits& L = log->enc_limits;
  L.speed_given = log->hasParam("max_speed_mps");
  L.max_speed_mps = log->param("max_speed_mps", kDefaultMaxSpeedMps);
  L.ticks_per_s_a = L.max_speed_mps * c.ticks_a;
  if (sync) {
    L.steer_given = log->hasParam("max_steer_rate_radps");
    L.max_steer_rate_radps = log->param("max_steer_rate_radps", kDefaultMaxSteerRateRadps);
    L.ticks_per_s_b = L.max_steer_rate_radps * c.ticks_b;
  } else {
    L.ticks_per_s_b = L.max_speed_mps * c.ticks_b;
  }
  L.margin_ticks = kEncMarginTicks;
  for (const auto& [k, v] : log->meta)
    if (k == "time_base" && v == "order") L.synthetic_time = true;
}

// The plausibility rule, the firmware encoder driver's on the host: an increment of a channel
// beyond its fastest count times the interval, plus a margin, is rejected and recorded; it
// contributes nothing, and the channel's later counts are shifted by it. A difference or a
// shifted count that would leave the 64-bit range is rejected the same way, so no difference
// the tools take can overflow. The limits are setEncoderLimits' and finite.
void rejectImpossibleIncrements(Odolog* log) {
  OdologLimits& L = log->enc_limits;
  std::vector<OdologEnc>& e = log->enc;
  if (e.size() < 2) return;
  auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    const std::size_t m = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m), v.end());
    return v[m];
  };
  {
    std::vector<double> dts, inc_a, inc_b;
    for (std::size_t i = 1; i < e.size(); ++i) {
      if (e[i].t > e[i - 1].t) dts.push_back(e[i].t - e[i - 1].t);
      const double da = std::fabs(static_cast<double>(e[i].a) - static_cast<double>(e[i - 1].a));
      const double db = std::fabs(static_cast<double>(e[i].b) - static_cast<double>(e[i - 1].b));
      if (da > 0) inc_a.push_back(da);
      if (db > 0) inc_b.push_back(db);
    }
    L.dt_floor_s = 2 * median(dts);
    L.median_increment_a = median(inc_a);
    L.median_increment_b = median(inc_b);
  }
  std::int64_t prev[2] = {e[0].a, e[0].b};  // the raw counts of the previous record
  std::int64_t kept[2] = {e[0].a, e[0].b};  // the counts with the rejected increments left out
  const double tps[2] = {L.ticks_per_s_a, L.ticks_per_s_b};
  const double own[2] = {kSyntheticFactor * L.median_increment_a, kSyntheticFactor * L.median_increment_b};
  for (std::size_t i = 1; i < e.size(); ++i) {
    const double dt = std::max({0.0, e[i].t - e[i - 1].t, L.dt_floor_s});
    std::int64_t* now[2] = {&e[i].a, &e[i].b};
    for (int k = 0; k < 2; ++k) {
      const std::int64_t raw = *now[k];
      const double limit = (L.synthetic_time ? own[k] : tps[k] * dt) + L.margin_ticks;
      std::int64_t d = 0, next = 0;
      const bool overflow = __builtin_sub_overflow(raw, prev[k], &d);
      if (overflow || std::fabs(static_cast<double>(d)) > limit || __builtin_add_overflow(kept[k], d, &next)) {
        log->enc_rejected.push_back({e[i].t, e[i].line, k == 0 ? 'A' : 'B',
                                     static_cast<double>(raw) - static_cast<double>(prev[k]), limit});
      } else {
        kept[k] = next;
      }
      prev[k] = raw;
      *now[k] = kept[k];
    }
  }
}

}  // namespace

bool parseOdolog(const std::string& text, const std::string& name, Odolog* out, std::string* error) {
  Parser p{name, 0, error};
  *out = Odolog{};
  out->path = name;
  std::istringstream in(text);
  std::string raw;
  bool seen_version = false;
  bool in_data = false;
  double last_t = -std::numeric_limits<double>::infinity();
  int drive_line = 0;
  while (std::getline(in, raw)) {
    ++p.line;
    const std::vector<std::string> f = split(raw);
    if (f.empty()) continue;
    const std::string& type = f[0];
    if (!seen_version) {
      if (type != "odolog" || f.size() != 2 || f[1] != "1") {
        return p.fail("the first record must be 'odolog 1'");
      }
      seen_version = true;
      continue;
    }
    if (type == "odolog") return p.fail("'odolog' may appear only once, as the first record");
    if (isHeader(type)) {
      if (in_data) return p.fail("header record '" + type + "' after the first data record");
      if (type == "drive") {
        if (!p.count(f, 1, "diff|sync")) return false;
        if (!out->drive.empty()) return p.fail("'drive' given twice");
        if (f[1] != "diff" && f[1] != "sync") return p.fail("drive must be 'diff' or 'sync', got '" + f[1] + "'");
        out->drive = f[1];
        drive_line = p.line;
      } else if (type == "param") {
        if (!p.count(f, 2, "NAME VALUE")) return false;
        if (out->hasParam(f[1])) return p.fail("param '" + f[1] + "' given twice");
        double v;
        if (!p.number(f[2], "param value", false, &v)) return false;
        out->params.emplace_back(f[1], v);
      } else if (type == "laser") {
        if (!p.count(f, 8, "N ANGLE_MIN ANGLE_INC RANGE_MAX SIGMA MOUNT_X MOUNT_Y MOUNT_YAW")) return false;
        if (out->has_laser) return p.fail("'laser' given twice");
        std::int64_t n;
        if (!p.integer(f[1], "laser N", &n)) return false;
        if (n <= 0 || n > 4096) return p.fail("laser N must be between 1 and 4096");
        OdologLaser& l = out->laser;
        l.beams = static_cast<int>(n);
        double* dst[7] = {&l.angle_min, &l.angle_inc, &l.range_max, &l.sigma, &l.mount_x, &l.mount_y, &l.mount_yaw};
        for (int i = 0; i < 7; ++i) {
          if (!p.number(f[2 + i], "laser field", false, dst[i])) return false;
        }
        if (!(l.range_max > 0)) return p.fail("laser RANGE_MAX must be positive");
        if (!(l.sigma > 0)) return p.fail("laser SIGMA must be positive");
        out->has_laser = true;
      } else if (type == "wall") {
        if (!p.count(f, 4, "X1 Y1 X2 Y2")) return false;
        OdologWall w;
        double* dst[4] = {&w.x1, &w.y1, &w.x2, &w.y2};
        for (int i = 0; i < 4; ++i) {
          if (!p.number(f[1 + i], "wall coordinate", false, dst[i])) return false;
        }
        if (w.x1 == w.x2 && w.y1 == w.y2) return p.fail("wall has zero length");
        out->walls.push_back(w);
      } else if (type == "init") {
        if (!p.count(f, 6, "X Y THETA SX SY STHETA")) return false;
        if (out->has_init) return p.fail("'init' given twice");
        OdologPose& q = out->init;
        double* dst[6] = {&q.x, &q.y, &q.theta, &q.sx, &q.sy, &q.stheta};
        for (int i = 0; i < 6; ++i) {
          if (!p.number(f[1 + i], "init field", false, dst[i])) return false;
        }
        if (!(q.sx > 0 && q.sy > 0 && q.stheta > 0)) return p.fail("init standard deviations must be positive");
        if (!p.withinReach(f[1], "init x", q.x) || !p.withinReach(f[2], "init y", q.y)) return false;
        out->has_init = true;
      } else {  // meta
        if (f.size() < 2) return p.fail("'meta' takes KEY VALUE...");
        std::string v;
        for (std::size_t i = 2; i < f.size(); ++i) v += (i > 2 ? " " : "") + f[i];
        out->meta.emplace_back(f[1], v);
      }
      continue;
    }
    if (isData(type)) {
      if (out->drive.empty()) return p.fail("data record '" + type + "' before the 'drive' record");
      in_data = true;
      if (f.size() < 2) return p.fail("'" + type + "' needs a time");
      double t;
      if (!p.number(f[1], "time", false, &t)) return false;
      if (t < last_t) {
        std::ostringstream m;
        m << "data records must be in non-decreasing time: t=" << f[1] << " after t=" << last_t;
        return p.fail(m.str());
      }
      last_t = t;
      if (type == "enc") {
        if (!p.count(f, 3, "T A B")) return false;
        OdologEnc e{t, 0, 0};
        e.line = p.line;
        if (!p.integer(f[2], "enc A", &e.a) || !p.integer(f[3], "enc B", &e.b)) return false;
        out->enc.push_back(e);
      } else if (type == "scan") {
        if (!out->has_laser) return p.fail("'scan' before any 'laser' record");
        if (f.size() - 2 != static_cast<std::size_t>(out->laser.beams)) {
          return p.fail("scan has " + std::to_string(f.size() - 2) + " ranges, the laser record says " +
                        std::to_string(out->laser.beams));
        }
        OdologScan s{t, {}};
        s.ranges.resize(f.size() - 2);
        for (std::size_t i = 2; i < f.size(); ++i) {
          if (!p.number(f[i], "scan range", true, &s.ranges[i - 2])) return false;
        }
        out->scans.push_back(std::move(s));
      } else if (type == "pose") {
        if (!p.count(f, 7, "T X Y THETA SX SY STHETA")) return false;
        OdologPose q{t, 0, 0, 0, 0, 0, 0};
        double* dst[6] = {&q.x, &q.y, &q.theta, &q.sx, &q.sy, &q.stheta};
        for (int i = 0; i < 6; ++i) {
          if (!p.number(f[2 + i], "pose field", false, dst[i])) return false;
        }
        if (!(q.sx > 0 && q.sy > 0 && q.stheta > 0)) return p.fail("pose standard deviations must be positive");
        if (!p.withinReach(f[2], "pose x", q.x) || !p.withinReach(f[3], "pose y", q.y)) return false;
        out->poses.push_back(q);
      } else {  // truth
        if (!p.count(f, 4, "T X Y THETA")) return false;
        OdologTruth q{t, 0, 0, 0};
        if (!p.number(f[2], "truth x", false, &q.x) || !p.number(f[3], "truth y", false, &q.y) ||
            !p.number(f[4], "truth theta", false, &q.theta) || !p.withinReach(f[2], "truth x", q.x) ||
            !p.withinReach(f[3], "truth y", q.y)) {
          return false;
        }
        out->truth.push_back(q);
      }
      continue;
    }
    if (!std::all_of(type.begin(), type.end(), [](char c) { return (c >= 'a' && c <= 'z') || c == '_' || (c >= '0' && c <= '9'); })) {
      return p.fail("record type '" + type + "' is not a lower-case word");
    }
    ++out->unknown_records;  // newer writers stay readable
  }
  p.line = 0;
  if (!seen_version) return p.fail("empty file: the first record must be 'odolog 1'");
  if (out->drive.empty()) return p.fail("no 'drive' record");
  p.line = drive_line;
  const char* const diff_req[] = {"wheel_radius_m", "ticks_per_rev", "wheelbase_m"};
  const char* const sync_req[] = {"ticks_per_m", "ticks_per_rad"};
  for (const char* r : out->drive == "diff" ? std::vector<const char*>(diff_req, diff_req + 3)
                                              : std::vector<const char*>(sync_req, sync_req + 2)) {
    if (!out->hasParam(r)) return p.fail(std::string("drive ") + out->drive + " needs 'param " + r + "'");
    if (!(out->param(r, 0) > 0)) return p.fail(std::string("param ") + r + " must be positive");
  }
  for (const char* r : {"max_speed_mps", "max_steer_rate_radps"}) {
    if (out->hasParam(r) && !(out->param(r, 0) > 0)) return p.fail(std::string("param ") + r + " must be positive");
  }
  setEncoderLimits(out);
  const OdologLimits& L = out->enc_limits;
  if (!std::isfinite(L.ticks_per_s_a) || !std::isfinite(L.ticks_per_s_b)) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "the drive's constants give no finite count rate at its top speed (A: %g, B: %g ticks/s)",
                  L.ticks_per_s_a, L.ticks_per_s_b);
    return p.fail(buf);
  }
  rejectImpossibleIncrements(out);
  return true;
}

bool readOdolog(const std::string& path, Odolog* out, std::string* error) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    *error = path + ": cannot open: " + std::strerror(errno);
    return false;
  }
  std::ostringstream ss;
  ss << f.rdbuf();
  return parseOdolog(ss.str(), path, out, error);
}

std::string rejectionSummary(const Odolog& log) {
  const std::size_t n = log.enc_rejected.size();
  if (n == 0) return "";
  const OdologRejection& r = log.enc_rejected.front();
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "%zu encoder increment%s rejected as impossible for the drive (the first at %s:%d, t=%.2f s, "
                "channel %c: %.0f ticks, at most %.0f)",
                n, n == 1 ? "" : "s", log.path.c_str(), r.line, r.t, r.channel, r.ticks, r.limit);
  return buf;
}

DriveConstants driveConstants(const Odolog& log, bool sync) {
  DriveConstants c;
  if (sync) {
    c.ticks_a = log.param("ticks_per_m", 1);
    c.ticks_b = log.param("ticks_per_rad", 1);
  } else {
    c.wheelbase = log.param("wheelbase_m", 0.5);
    c.ticks_a = c.ticks_b = log.param("ticks_per_rev", 1) / (2 * kPi<double> * log.param("wheel_radius_m", 1));
  }
  return c;
}

}  // namespace odoerr::sim

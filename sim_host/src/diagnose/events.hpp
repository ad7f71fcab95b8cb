// diagnose, the log as filter events: one per cm of encoder travel, one per scan and pose
// fix at its own stamp (encoder counts interpolated to it), as `odoerr replay` does. Every
// filter run of diagnose (Engine::run) steps through the same events.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include "odoerr/sim/odolog.hpp"

namespace odoerr::sim::diag {

/// One filter step: its time, the time since the previous step, the wheel (or drive)
/// travel since then, and the measurement it carries (a scan or pose fix index; -1: none).
struct Event {
  double t, dt, a, b;
  int scan = -1, pose = -1;
};

/// The events of a log. ticks_a / ticks_b: encoder ticks per unit of the drive's inputs;
/// cycle_m: the travel of one event without a measurement; with_scans: false when the
/// laser has no beams (its scans are then left out). Never empty.
template <typename Drive>
std::vector<Event> buildEvents(const Odolog& log, double ticks_a, double ticks_b, double cycle_m, bool with_scans) {
  std::vector<Event> events;
  const auto& e = log.enc;
  EncCursor enc(e);
  auto countsAt = [&](double t, double* a, double* b) {
    const CountsAt c = enc.at(t);
    *a = c.a;
    *b = c.b;
  };
  double fa = double(e.front().a), fb = double(e.front().b), ft = e.front().t;
  auto push = [&](double t, double a, double b, int scan, int pose) {
    Event ev{t, t - ft, (a - fa) / ticks_a, (b - fb) / ticks_b, scan, pose};
    events.push_back(ev);
    fa = a;
    fb = b;
    ft = t;
  };
  std::size_t ie = 0, is = 0, ip = 0;
  const double inf = std::numeric_limits<double>::infinity();
  while (ie < e.size() || is < log.scans.size() || ip < log.poses.size()) {
    const double te = ie < e.size() ? e[ie].t : inf;
    const double ts = is < log.scans.size() ? log.scans[is].t : inf;
    const double tp = ip < log.poses.size() ? log.poses[ip].t : inf;
    if (te <= ts && te <= tp) {
      const OdologEnc& r = e[ie++];
      const typename Drive::Input u{(double(r.a) - fa) / ticks_a, (double(r.b) - fb) / ticks_b};
      if (Drive::pathLength(u) >= cycle_m) push(r.t, double(r.a), double(r.b), -1, -1);
    } else if (ts <= tp) {
      const double t = log.scans[is].t;
      if (t >= ft && with_scans) {
        double a, b;
        countsAt(t, &a, &b);
        push(t, a, b, static_cast<int>(is), -1);
      }
      ++is;
    } else {
      const double t = log.poses[ip].t;
      if (t >= ft) {
        double a, b;
        countsAt(t, &a, &b);
        push(t, a, b, -1, static_cast<int>(ip));
      }
      ++ip;
    }
  }
  if (events.empty()) events.push_back({ft, 0, 0, 0, -1, -1});
  return events;
}

}  // namespace odoerr::sim::diag

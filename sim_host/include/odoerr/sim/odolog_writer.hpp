// sim_host: writes a simulated drive as an odolog v1 file (docs/odolog.md), so
// any run can be replayed later by the same estimator or by other tools.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

#include "odoerr/sim/paper_sim.hpp"

namespace odoerr::sim {

namespace detail {
inline void appendf(std::string& out, const char* fmt, double v) {
  char buf[48];
  if (std::isnan(v)) {
    out += " nan";
    return;
  }
  std::snprintf(buf, sizeof buf, fmt, v);
  out += buf;
}
}  // namespace detail

/// Header records: version, provenance, drive, nominal constants, laser, walls, init.
/// `truth_note` is free text for a `meta truth` record (the simulated parameters).
template <typename Drive>
std::string odologHeader(const PaperSim<Drive>& sim, std::uint64_t seed, double init_sigma_xy,
                         double init_sigma_theta) {
  const SimConfig& c = sim.config();
  constexpr bool kSync = PaperSim<Drive>::kSync;
  std::string out = "odolog 1\n";
  out += "meta source odoerr-sim paper-circle seed=" + std::to_string(seed) +
         " steps=" + std::to_string(c.steps) + "\n";
  char buf[256];
  if constexpr (kSync) {
    std::snprintf(buf, sizeof buf,
                  "meta truth delta_rho=%.9g E_theta=%.9g K_rho=%.9g K_theta=%.9g\n", c.delta_rho,
                  c.e_theta, c.k_rho, c.k_theta);
    out += buf;
    out += "drive sync\n";
    std::snprintf(buf, sizeof buf, "param ticks_per_m %.9g\nparam ticks_per_rad %.9g\n",
                  c.sync_ticks_per_m, c.sync_ticks_per_rad);
    out += buf;
  } else {
    std::snprintf(buf, sizeof buf, "meta truth delta_R=%.9g delta_L=%.9g delta_d=%.9g K_w=%.9g\n",
                  c.delta_r, c.delta_l, c.delta_d, c.k_w);
    out += buf;
    out += "drive diff\n";
    std::snprintf(buf, sizeof buf,
                  "param wheel_radius_m %.9g\nparam ticks_per_rev %.9g\nparam wheelbase_m %.9g\n",
                  c.wheel_radius_m, c.ticks_per_rev, c.wheelbase_m);
    out += buf;
  }
  const auto& l = c.laser;
  std::snprintf(buf, sizeof buf, "laser %d %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", l.beams,
                l.angle_min, l.angle_inc, l.range_max, l.sigma, l.mount_x, l.mount_y, l.mount_yaw);
  out += buf;
  for (int i = 0; i < sim.map().size(); ++i) {
    const auto& w = sim.map().wall(i);
    std::snprintf(buf, sizeof buf, "wall %.9g %.9g %.9g %.9g\n", w.x1, w.y1, w.x2, w.y2);
    out += buf;
  }
  const Pose<double> p = sim.initialEstimate();
  std::snprintf(buf, sizeof buf, "init %.9g %.9g %.9g %.9g %.9g %.9g\n", p.x, p.y, p.theta,
                init_sigma_xy, init_sigma_xy, init_sigma_theta);
  out += buf;
  const Pose<double> t = sim.truth();
  std::snprintf(buf, sizeof buf, "enc 0.000000 0 0\ntruth 0.000000 %.9g %.9g %.9g\n", t.x, t.y,
                t.theta);
  out += buf;
  return out;
}

/// Data records of one cycle: enc, scan, truth (all at the cycle's time).
template <typename Drive>
void appendOdologStep(std::string& out, const SimStep<Drive>& st, int beams) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "enc %.6f %lld %lld\n", st.t,
                static_cast<long long>(st.counts.count_a), static_cast<long long>(st.counts.count_b));
  out += buf;
  std::snprintf(buf, sizeof buf, "scan %.6f", st.t);
  out += buf;
  for (int i = 0; i < beams; ++i) detail::appendf(out, " %.5f", st.ranges[i]);
  out += "\n";
  std::snprintf(buf, sizeof buf, "truth %.6f %.9g %.9g %.9g\n", st.t, st.truth.x, st.truth.y,
                st.truth.theta);
  out += buf;
}

}  // namespace odoerr::sim

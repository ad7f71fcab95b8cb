// sim_host: the filter's settings for a real robot, shared by replay and diagnose (the
// paper's settings stay the defaults). docs/real-data.md, the Intel lab, says why each
// one exists.
#pragma once

#include "odoerr/akf.hpp"
#include "odoerr/fw/paper_setup.hpp"

namespace odoerr::sim {

struct FilterTuning {
  bool order_beams = false;  ///< fuse a scan's beams most consistent first (AkfConfig::order_by_prior_nis)
  double range_sigma = 0;    ///< range noise std (m); 0: the log's laser record
  double param_sigma = 0;    ///< prior sigma of the systematic parameters (relative); 0: the paper's 0.2
  double gate_nis = 0;       ///< innovation gate on the NIS; 0: the filter's 25 (5 sigma)

  /// The paper's set-up with these settings applied.
  fw::FilterSetup setup() const {
    fw::FilterSetup s;
    if (gate_nis > 0) s.akf.gate_nis = gate_nis;
    if (param_sigma > 0) s.sigma_scale = param_sigma;
    return s;
  }
  template <typename S>
  AkfConfig<S> akfConfig(const fw::FilterSetup& s) const {
    AkfConfig<S> c{S(s.akf.max_incidence_rad), S(s.akf.gate_nis)};
    c.order_by_prior_nis = order_beams;
    return c;
  }
  double rangeSigma(double log_sigma) const { return range_sigma > 0 ? range_sigma : log_sigma; }
};

}  // namespace odoerr::sim

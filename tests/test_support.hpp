// Shared test helpers (tests only).
#pragma once

#include <Eigen/Core>

#include "odoerr/model.hpp"

namespace odoerr::test {

/// A test-only motion effect (lateral slip proportional to rho * theta) used to prove that
/// effects compose into the state at compile time with correct indices and Jacobians.
struct TurnSlipForTest {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 1;
  static constexpr const char* kParamNames[kParams] = {"slip_gain"};
  template <typename S>
  static Eigen::Matrix<S, kParams, 1> nominal() {
    return Eigen::Matrix<S, kParams, 1>::Zero();
  }
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>&,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    Increment<S> out = in;
    out.side = in.side + p[0] * in.rho * in.theta;
    d_in.setIdentity();
    d_in(2, 0) = p[0] * in.theta;
    d_in(2, 1) = p[0] * in.rho;
    d_p << S(0), S(0), in.rho * in.theta;
    return out;
  }
};

/// A second test-only effect (a translation scale) to check chaining of two effects.
struct ScaleForTest {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 1;
  static constexpr const char* kParamNames[kParams] = {"extra_scale"};
  template <typename S>
  static Eigen::Matrix<S, kParams, 1> nominal() {
    return Eigen::Matrix<S, kParams, 1>::Ones();
  }
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>&,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    Increment<S> out = in;
    out.rho = p[0] * in.rho;
    d_in.setIdentity();
    d_in(0, 0) = p[0];
    d_p << in.rho, S(0), S(0);
    return out;
  }
};

}  // namespace odoerr::test

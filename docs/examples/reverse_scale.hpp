// The worked example of docs/writing-an-effect.md: a motion effect that is not in the
// catalogue. tests/test_effects.cpp compiles it, checks its Jacobians against finite
// differences and estimates it from a simulated drive, so the tutorial cannot go stale.
#pragma once

#include <Eigen/Core>

#include "odoerr/effects/motion_effects.hpp"

namespace odoerr::examples {

/// Travel scale when reversing: rho *= 1 + k while rho < 0. A caster that trails the other
/// way, or a tyre whose tread grips differently backwards, makes a robot travel a little
/// more (k > 0) or less (k < 0) in reverse than the encoders say.
struct ReverseScale : effects::NominalZero<ReverseScale> {
  // 1. What it is: its kind, size, names, prior and a size worth detecting.
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "reverse_scale";
  static constexpr const char* kParamNames[kParams] = {"k"};
  static constexpr const char* kDescription =
      "the robot travels a different distance backwards than the encoders say (caster, tread)";
  static constexpr double kPriorSigma[kParams] = {0.05};
  static constexpr double kReference[kParams] = {0.01};

  // 2. How it enters the motion model, and its exact Jacobians: d_in is d(out)/d(in) over
  //    (rho, theta, side); d_p is d(out)/d(parameters). Scalar(…) literals only: the core
  //    runs in float on the target, and a bare 1.0 would promote to double.
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>&, Eigen::Matrix<S, 3, 3>& d_in,
                     Eigen::Matrix<S, 3, kParams>& d_p) const {
    effects::startJacobians(d_in, d_p);
    Increment<S> out = in;
    if (in.rho < S(0)) {
      out.rho = in.rho * (S(1) + p[0]);
      d_in(0, 0) = S(1) + p[0];
      d_p(0, 0) = in.rho;
    }
    return out;
  }
};

}  // namespace odoerr::examples

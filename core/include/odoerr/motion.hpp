// odoerr core: the odometry error models of Section 2 and the pose propagation shared by
// the filters and the simulator (one motion model, so the simulated truth and the
// estimator agree by construction).
#pragma once

#include <Eigen/Core>

#include "odoerr/scalar.hpp"

namespace odoerr {

/// Pose index constants: the single source of truth for the pose block of every state.
struct PoseIdx {
  static constexpr int kX = 0;
  static constexpr int kY = 1;
  static constexpr int kTheta = 2;
  static constexpr int kDim = 3;
};

/// The robot's motion over one cycle in its own frame at the start of the cycle:
/// translation along the mid-cycle heading, rotation, and a lateral (sideways) slip that
/// the basic drives leave at zero but physical effects may use.
template <typename S>
struct Increment {
  S rho = S(0);
  S theta = S(0);
  S side = S(0);
};

template <typename S>
struct Pose {
  S x = S(0);
  S y = S(0);
  S theta = S(0);
};

/// Applies one increment with the mid-point heading rule:
///   x' = x + rho cos(th + dth/2) - side sin(th + dth/2)
///   y' = y + rho sin(th + dth/2) + side cos(th + dth/2)
///   th' = th + dth
/// and returns the Jacobians wrt the pose (only d/dtheta is non-trivial) and wrt the
/// increment (3x3: columns rho, theta, side).
template <typename S>
struct IncrementJacobians {
  S dx_dth;
  S dy_dth;
  Eigen::Matrix<S, 3, 3> d_inc;  // rows x, y, th; cols rho, theta, side
};

template <typename S>
inline Pose<S> applyIncrementCS(const Pose<S>& p, const Increment<S>& d, S c, S s,
                                IncrementJacobians<S>* jac);

template <typename S>
inline Pose<S> applyIncrement(const Pose<S>& p, const Increment<S>& d,
                              IncrementJacobians<S>* jac = nullptr) {
  const S m = p.theta + S(0.5) * d.theta;
  return applyIncrementCS(p, d, std::cos(m), std::sin(m), jac);
}

/// applyIncrement with c = cos and s = sin of the mid-point heading given by the caller.
template <typename S>
inline Pose<S> applyIncrementCS(const Pose<S>& p, const Increment<S>& d, S c, S s,
                                IncrementJacobians<S>* jac) {
  Pose<S> out;
  out.x = p.x + d.rho * c - d.side * s;
  out.y = p.y + d.rho * s + d.side * c;
  out.theta = wrapAngle(p.theta + d.theta);
  if (jac != nullptr) {
    const S dxm = -d.rho * s - d.side * c;  // d x'/d m
    const S dym = d.rho * c - d.side * s;   // d y'/d m
    jac->dx_dth = dxm;
    jac->dy_dth = dym;
    jac->d_inc << c, S(0.5) * dxm, -s,  //
        s, S(0.5) * dym, c,             //
        S(0), S(1), S(0);
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// Drive models. A drive names its systematic parameters (which join the augmented state),
// its non-systematic parameters (estimated by the Observable Filter), its encoder input,
// and maps (input, parameters, noise) to an Increment with the Jacobians the AKF needs.
// ---------------------------------------------------------------------------------------

/// Synchronous drive, eq. (1)-(2): U = [drho_e, dtheta_e] from a translation and a steering
/// encoder; systematic [delta_rho, E_theta]; non-systematic [K_rho, K_theta].
template <typename S>
struct SyncDrive {
  using Scalar = S;
  static constexpr int kParams = 2;
  static constexpr int kNoise = 2;
  static constexpr int kNonSys = 2;
  enum ParamIdx : int { kDeltaRho = 0, kETheta = 1 };
  enum NonSysIdx : int { kKRho = 0, kKTheta = 1 };
  static constexpr const char* kParamNames[kParams] = {"delta_rho", "E_theta"};
  static constexpr const char* kNonSysNames[kNonSys] = {"K_rho", "K_theta"};

  /// The two encoder channels of a cycle (see convertInput).
  struct Input {
    using Scalar = S;
    S rho_e = S(0);    ///< encoder translation this cycle (m)
    S theta_e = S(0);  ///< encoder rotation this cycle (rad)
  };
  using ParamVec = Eigen::Matrix<S, kParams, 1>;
  using NonSysVec = Eigen::Matrix<S, kNonSys, 1>;
  using NoiseVec = Eigen::Matrix<S, kNoise, 1>;

  static ParamVec nominal() { return ParamVec(S(1), S(0)); }

  static bool inputFinite(const Input& u) { return isFinite(u.rho_e) && isFinite(u.theta_e); }

  /// Encoder path length of the cycle (the unit of the error growth).
  static S pathLength(const Input& u) { return std::abs(u.rho_e); }
  /// Signed translation the encoders report with the nominal constants.
  static S encoderTravel(const Input& u) { return u.rho_e; }

  /// Mean increment (1) plus noise nu = [nu_rho, nu_theta] (2).
  Increment<S> increment(const Input& u, const ParamVec& p, const NoiseVec& nu) const {
    Increment<S> d;
    d.rho = p[kDeltaRho] * u.rho_e + nu[0];
    d.theta = u.theta_e + p[kETheta] * u.rho_e + nu[1];
    return d;
  }
  /// d increment / d params (3 x kParams)
  Eigen::Matrix<S, 3, kParams> dIncDParams(const Input& u, const ParamVec&) const {
    Eigen::Matrix<S, 3, kParams> j;
    j << u.rho_e, S(0), S(0), u.rho_e, S(0), S(0);
    return j;
  }
  /// d increment / d noise (3 x kNoise)
  Eigen::Matrix<S, 3, kNoise> dIncDNoise(const Input&, const ParamVec&) const {
    Eigen::Matrix<S, 3, kNoise> j;
    j << S(1), S(0), S(0), S(1), S(0), S(0);
    return j;
  }
  /// Noise variances of (2) for the non-systematic parameters K.
  NoiseVec noiseVariance(const Input& u, const NonSysVec& k) const {
    const S l = pathLength(u);
    return NoiseVec(k[kKRho] * l, k[kKTheta] * l);
  }
};

/// Differential drive, eq. (3)-(4): U = [drho_eR, drho_eL] from two wheel encoders;
/// systematic [delta_R, delta_L, delta_d]; non-systematic [K_w]. The nominal wheelbase d
/// is a property of the robot (runtime configuration).
template <typename S>
struct DiffDrive {
  using Scalar = S;
  static constexpr int kParams = 3;
  static constexpr int kNoise = 2;
  static constexpr int kNonSys = 1;
  enum ParamIdx : int { kDeltaR = 0, kDeltaL = 1, kDeltaD = 2 };
  enum NonSysIdx : int { kKw = 0 };
  static constexpr const char* kParamNames[kParams] = {"delta_R", "delta_L", "delta_d"};
  static constexpr const char* kNonSysNames[kNonSys] = {"K_w"};

  /// The two encoder channels of a cycle (see convertInput).
  struct Input {
    using Scalar = S;
    S right = S(0);  ///< right wheel encoder travel this cycle (m)
    S left = S(0);   ///< left wheel encoder travel this cycle (m)
  };
  using ParamVec = Eigen::Matrix<S, kParams, 1>;
  using NonSysVec = Eigen::Matrix<S, kNonSys, 1>;
  using NoiseVec = Eigen::Matrix<S, kNoise, 1>;

  S wheelbase = S(0.5);  ///< nominal distance between the wheels d (m)

  static ParamVec nominal() { return ParamVec(S(1), S(1), S(1)); }
  static bool inputFinite(const Input& u) { return isFinite(u.right) && isFinite(u.left); }
  static S pathLength(const Input& u) { return S(0.5) * (std::abs(u.right) + std::abs(u.left)); }
  /// Signed translation the encoders report with the nominal constants.
  static S encoderTravel(const Input& u) { return S(0.5) * (u.right + u.left); }

  Increment<S> increment(const Input& u, const ParamVec& p, const NoiseVec& nu) const {
    const S r = p[kDeltaR] * u.right + nu[0];
    const S l = p[kDeltaL] * u.left + nu[1];
    Increment<S> d;
    d.rho = S(0.5) * (r + l);
    d.theta = (r - l) / (wheelbase * p[kDeltaD]);
    return d;
  }
  Eigen::Matrix<S, 3, kParams> dIncDParams(const Input& u, const ParamVec& p) const {
    const S dd = wheelbase * p[kDeltaD];
    const S diff = p[kDeltaR] * u.right - p[kDeltaL] * u.left;
    Eigen::Matrix<S, 3, kParams> j;
    j << S(0.5) * u.right, S(0.5) * u.left, S(0),  //
        u.right / dd, -u.left / dd, -diff / (dd * p[kDeltaD]),  //
        S(0), S(0), S(0);
    return j;
  }
  Eigen::Matrix<S, 3, kNoise> dIncDNoise(const Input&, const ParamVec& p) const {
    const S inv = S(1) / (wheelbase * p[kDeltaD]);
    Eigen::Matrix<S, 3, kNoise> j;
    j << S(0.5), S(0.5), inv, -inv, S(0), S(0);
    return j;
  }
  NoiseVec noiseVariance(const Input& u, const NonSysVec& k) const {
    return NoiseVec(k[kKw] * std::abs(u.right), k[kKw] * std::abs(u.left));
  }
};

/// Converts a drive input to another scalar type (or another drive's input of the same
/// shape). Every drive input is two channels: A (translation / right wheel) then B
/// (steering / left wheel), which is also the order of odolog's `enc T A B`.
template <typename ToInput, typename FromInput>
ToInput convertInput(const FromInput& u) {
  const auto& [a, b] = u;
  using T = typename ToInput::Scalar;
  return ToInput{T(a), T(b)};
}

}  // namespace odoerr

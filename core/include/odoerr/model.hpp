// odoerr core: the augmented-state layout, composed at compile time.
//
//   state = [ x, y, theta | drive systematic parameters | effect 1 params | effect 2 ... ]
//
// Model<Drive, Effects...> is the one source of truth for state indices: the pose block
// is PoseIdx, the drive block starts at kDriveOffset, effect E's block at offsetOf<E>().
// A motion effect is a small self-contained type that transforms the drive's increment:
//
//   struct MyEffect {
//     static constexpr int kParams = 1;
//     static constexpr const char* kParamNames[kParams] = {"my_gain"};
//     template <typename S> static Eigen::Matrix<S, kParams, 1> nominal();
//     // inc_out = g(inc_in, p); fills d inc_out / d inc_in (3x3) and d inc_out / d p.
//     template <typename S>
//     Increment<S> apply(const Increment<S>& in, const S* p,
//                        Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const;
//   };
//
// Adding an effect to the type list enlarges the fixed-size state; the filter code is
// unchanged (nothing is copied) and nothing is allocated.
#pragma once

#include <tuple>
#include <type_traits>
#include <utility>

#include "odoerr/motion.hpp"

namespace odoerr {

template <typename DriveT, typename... Effects>
class Model {
 public:
  using Drive = DriveT;
  using S = typename Drive::Scalar;
  using Scalar = S;
  using Input = typename Drive::Input;
  using NonSysVec = typename Drive::NonSysVec;

  static constexpr int kDriveOffset = PoseIdx::kDim;
  static constexpr int kEffectParams = (0 + ... + Effects::kParams);
  static constexpr int kParams = Drive::kParams + kEffectParams;
  static constexpr int kStates = PoseIdx::kDim + kParams;
  static constexpr int kNoise = Drive::kNoise;
  static constexpr int kNonSys = Drive::kNonSys;

  using StateVec = Eigen::Matrix<S, kStates, 1>;
  using StateMat = Eigen::Matrix<S, kStates, kStates>;
  using NoiseVec = Eigen::Matrix<S, kNoise, 1>;

  /// Index of the first parameter of effect E in the state.
  template <typename E>
  static constexpr int offsetOf() {
    return offsetImpl<E, Effects...>(kDriveOffset + Drive::kParams);
  }

  Drive drive{};
  std::tuple<Effects...> effects{};

  Model() = default;
  explicit Model(const Drive& d) : drive(d) {}

  /// The parameter block of a state at its nominal (no systematic error) values.
  static void setNominal(StateVec& x) {
    x.template segment<Drive::kParams>(kDriveOffset) = Drive::nominal();
    setEffectNominal(x, std::index_sequence_for<Effects...>{});
  }

  /// Increment for input u at state x with noise nu; optionally the Jacobians of the
  /// increment wrt the whole state (3 x kStates; pose columns zero) and wrt the noise.
  Increment<S> increment(const Input& u, const StateVec& x, const NoiseVec& nu,
                         Eigen::Matrix<S, 3, kStates>* d_state = nullptr,
                         Eigen::Matrix<S, 3, kNoise>* d_noise = nullptr) const {
    const auto p = x.template segment<Drive::kParams>(kDriveOffset);
    Increment<S> inc = drive.increment(u, p, nu);
    if (d_state != nullptr) {
      d_state->setZero();
      d_state->template block<3, Drive::kParams>(0, kDriveOffset) = drive.dIncDParams(u, p);
      *d_noise = drive.dIncDNoise(u, p);
    }
    applyEffects(x, inc, d_state, d_noise, std::index_sequence_for<Effects...>{});
    return inc;
  }

 private:
  template <typename E>
  static constexpr int offsetImpl(int) {
    static_assert(sizeof(E) == 0, "effect is not part of this model");
    return -1;
  }
  template <typename E, typename First, typename... Rest>
  static constexpr int offsetImpl(int at) {
    if constexpr (std::is_same_v<E, First>) {
      return at;
    } else {
      return offsetImpl<E, Rest...>(at + First::kParams);
    }
  }

  template <std::size_t... I>
  static void setEffectNominal(StateVec& x, std::index_sequence<I...>) {
    (setOneNominal<std::tuple_element_t<I, std::tuple<Effects...>>>(x), ...);
  }
  template <typename E>
  static void setOneNominal(StateVec& x) {
    x.template segment<E::kParams>(offsetOf<E>()) = E::template nominal<S>();
  }

  template <std::size_t... I>
  void applyEffects(const StateVec& x, Increment<S>& inc, Eigen::Matrix<S, 3, kStates>* d_state,
                    Eigen::Matrix<S, 3, kNoise>* d_noise, std::index_sequence<I...>) const {
    (void)x;  // unused when the model has no effects
    (void)d_state;
    (void)d_noise;
    (applyOne(std::get<I>(effects), x, inc, d_state, d_noise), ...);
  }
  template <typename E>
  void applyOne(const E& e, const StateVec& x, Increment<S>& inc,
                Eigen::Matrix<S, 3, kStates>* d_state, Eigen::Matrix<S, 3, kNoise>* d_noise) const {
    constexpr int off = offsetOf<E>();
    Eigen::Matrix<S, 3, 3> d_in;
    Eigen::Matrix<S, 3, E::kParams> d_p;
    const S* p = x.data() + off;
    inc = e.apply(inc, p, d_in, d_p);
    if (d_state != nullptr) {
      // chain rule: everything upstream of this effect passes through d_in
      *d_state = d_in * (*d_state);
      d_state->template block<3, E::kParams>(0, off) += d_p;
      *d_noise = d_in * (*d_noise);
    }
  }
};

}  // namespace odoerr

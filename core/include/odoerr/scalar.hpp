// odoerr core: scalar helpers shared by every filter.
// No I/O, no heap, no exceptions. Everything is templated on the scalar S (float or double).
#pragma once

#include <cmath>
#include <cstdint>

namespace odoerr {

template <typename S>
constexpr S kPi = S(3.141592653589793238462643383279502884L);

template <typename S>
constexpr S kTwoPi = S(6.283185307179586476925286766559005768L);

/// Wraps an angle to [-pi, pi).
template <typename S>
inline S wrapAngle(S a) {
  // remainder() rounds to nearest, so the result lies in [-pi, pi].
  S r = std::remainder(a, kTwoPi<S>);
  if (r >= kPi<S>) r -= kTwoPi<S>;
  return r;
}

template <typename S>
inline bool isFinite(S v) {
  return std::isfinite(v);
}

template <typename S>
constexpr S sq(S v) {
  return v * v;
}

/// sin(x)/x, exact to the last bit at small |x| by its series.
template <typename S>
inline S sinc(S x) {
  const S x2 = x * x;
  if (std::abs(x) < S(1e-2)) {
    return S(1) - x2 / S(6) + x2 * x2 / S(120);
  }
  return std::sin(x) / x;
}

}  // namespace odoerr

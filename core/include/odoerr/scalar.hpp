// odoerr core: scalar helpers shared by every filter.
// No I/O, no heap, no exceptions. Everything is templated on the scalar S (float or double).
#pragma once

#include <cmath>
#include <cstdint>

// Inlining the hot ray cast into its caller keeps its result in registers (measured on the
// Cortex-M4F, docs/performance.md); a rarely taken path stays out of line.
#if defined(__GNUC__) || defined(__clang__)
#define ODOERR_ALWAYS_INLINE inline __attribute__((always_inline))
#define ODOERR_NOINLINE __attribute__((noinline))
#else
#define ODOERR_ALWAYS_INLINE inline
#define ODOERR_NOINLINE
#endif

namespace odoerr {

template <typename S>
constexpr S kPi = S(3.141592653589793238462643383279502884L);

template <typename S>
constexpr S kTwoPi = S(6.283185307179586476925286766559005768L);

/// Wraps an angle to [-pi, pi). The filters' angles are within a turn or two of that range,
/// where one or two additions suffice; far-off values fall back to remainder().
template <typename S>
inline S wrapAngle(S a) {
  if (a >= -kPi<S> && a < kPi<S>) return a;
  if (a >= -S(3) * kPi<S> && a < S(3) * kPi<S>) {
    a += (a < S(0)) ? kTwoPi<S> : -kTwoPi<S>;
    return a >= kPi<S> ? a - kTwoPi<S> : a;
  }
  S r = std::remainder(a, kTwoPi<S>);  // in [-pi, pi]
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
  if (std::abs(x) < S(0.05)) {
    return S(1) - x2 / S(6) * (S(1) - x2 / S(20) * (S(1) - x2 / S(42)));
  }
  return std::sin(x) / x;
}

/// sin and cos together; below |x| < 0.05 by their Taylor series (error < x^9/9!, under
/// 1e-17 there; below 1e-4 two terms suffice), which costs a few multiplications instead of
/// two library calls. The filters' per-cycle angles (rotation per cm, per-beam heading
/// corrections) are almost always there.
template <typename S>
inline void sinCos(S x, S* s, S* c) {
  const S ax = std::abs(x);
  if (ax < S(1e-4)) {
    // x - x^3/6 and 1 - x^2/2 (+ x^4/24): errors below 1e-17, exact in double and float.
    const S x2 = x * x;
    *s = x - x * x2 / S(6);
    *c = S(1) - S(0.5) * x2;
    return;
  }
  if (ax < S(0.05)) {
    const S x2 = x * x;
    *s = x * (S(1) - x2 / S(6) * (S(1) - x2 / S(20) * (S(1) - x2 / S(42))));
    *c = S(1) - x2 / S(2) * (S(1) - x2 / S(12) * (S(1) - x2 / S(30) * (S(1) - x2 / S(56))));
    return;
  }
  *s = std::sin(x);
  *c = std::cos(x);
}

}  // namespace odoerr

// odoerr core: the special functions of the synchronous-drive observable mean.
//
// All of them are ratios whose numerator and denominator vanish together at small
// arguments (catastrophic cancellation). Each is evaluated by its Taylor series below a
// threshold and by the closed form above it. See docs/paper-notes.md, sections (a)-(b).
#pragma once

#include <complex>
#include <limits>

#include "odoerr/scalar.hpp"

namespace odoerr {

namespace detail {
// Below this modulus the series are used; terms fall like 0.5^n / n! so kSeriesTerms
// terms reach below double precision.
template <typename S>
constexpr S kSeriesRadius = S(0.5);
constexpr int kSeriesTerms = 16;

/// 1/n! for n <= 16, exact to the scalar's precision.
template <typename S>
S invFactorial(int n) {
  static constexpr long double kInv[17] = {
      1.0L, 1.0L, 1.0L / 2, 1.0L / 6, 1.0L / 24, 1.0L / 120, 1.0L / 720, 1.0L / 5040,
      1.0L / 40320, 1.0L / 362880, 1.0L / 3628800, 1.0L / 39916800, 1.0L / 479001600,
      1.0L / 6227020800, 1.0L / 87178291200, 1.0L / 1307674368000, 1.0L / 20922789888000};
  return S(kInv[n]);
}
}  // namespace detail

/// phi1(c) = (e^c - 1) / c   (= integral_0^1 e^{c t} dt)
template <typename S>
std::complex<S> phi1(std::complex<S> c) {
  if (std::abs(c) < detail::kSeriesRadius<S>) {
    // sum_{n>=0} c^n / (n+1)!
    std::complex<S> term(S(1), S(0));
    std::complex<S> sum = term;
    for (int n = 1; n < detail::kSeriesTerms; ++n) {
      term *= c / S(n + 1);
      sum += term;
    }
    return sum;
  }
  return (std::exp(c) - S(1)) / c;
}

/// phi2(c) = (e^c - 1 - c) / c^2   (= integral_0^1 (1-t) e^{c t} dt)
template <typename S>
std::complex<S> phi2(std::complex<S> c) {
  if (std::abs(c) < detail::kSeriesRadius<S>) {
    // sum_{n>=0} c^n / (n+2)!
    std::complex<S> term(S(0.5), S(0));
    std::complex<S> sum = term;
    for (int n = 1; n < detail::kSeriesTerms; ++n) {
      term *= c / S(n + 2);
      sum += term;
    }
    return sum;
  }
  return (std::exp(c) - S(1) - c) / (c * c);
}

/// The paper's F(z) = (z - 1 + e^{-z}) / z^2 (eq. 9) = phi2(-z).
template <typename S>
std::complex<S> paperF(std::complex<S> z) {
  return phi2(-z);
}

/// C(x) = (1 - cos x) / x^2 (the cosine term of eq. 9) = Re phi2(i x).
template <typename S>
S cosTerm(S x) {
  if (std::abs(x) < detail::kSeriesRadius<S>) {
    // sum_{n>=0} (-1)^n x^{2n} / (2n+2)!
    const S x2 = x * x;
    S term = S(0.5);
    S sum = term;
    for (int n = 1; n < detail::kSeriesTerms / 2; ++n) {
      term *= -x2 / S((2 * n + 1) * (2 * n + 2));
      sum += term;
    }
    return sum;
  }
  return (S(1) - std::cos(x)) / (x * x);
}

/// Value and k-derivative of the bracket of the exact mean of observable (8):
///   B(k, b) = 2 Re[ phi2(p) + phi2(q) - phi1(p) phi1(q) ],  p = i b - k,  q = -i b,
/// with k = K_theta L / 2 and b = the corrected rotation over the segment.
/// E z1 = K_rho L + (delta_rho L)^2 B(k, b). B vanishes at k = 0 for every b (no heading
/// noise, no displacement error): the terms cancel, so near k = 0 the double series in
/// (p, q) is used, whose constant term is zero by construction.
template <typename S>
struct Bracket {
  S value;   ///< B(k, b)
  S d_dk;    ///< dB/dk
};

template <typename S>
Bracket<S> observableBracket(S k, S b) {
  using C = std::complex<S>;
  const C p(-k, b);
  const C q(S(0), -b);
  const S r = std::max(std::abs(p), std::abs(q));
  if (r < detail::kSeriesRadius<S>) {
    // G(p,q) = sum_{N>=1} [ (p^N + q^N)/(N+2)! - sum_{m=0}^{N} p^m q^{N-m} / ((m+1)!(N-m+1)!) ]
    // G = (p + q) H(p, q), so the tail after order N is below |k| (2r)^N / (N+1)! : the
    // order is chosen adaptively (about 5 terms at the 1 cm steps of j = 1, 14 at r = 0.5).
    constexpr int kN = 14;
    const S eps = std::numeric_limits<S>::epsilon();
    int order = 1;
    for (S bound = S(2) * r; order < kN; ++order) {
      bound *= S(2) * r / S(order + 2);
      if (bound < eps) break;
    }
    C pw[kN + 1];
    C qw[kN + 1];
    pw[0] = C(S(1), S(0));
    qw[0] = C(S(1), S(0));
    for (int i = 1; i <= order; ++i) {
      pw[i] = pw[i - 1] * p;
      qw[i] = qw[i - 1] * q;
    }
    C g(S(0), S(0));
    C dg(S(0), S(0));  // dG/dp
    for (int n = 1; n <= order; ++n) {
      C cn = (pw[n] + qw[n]) * detail::invFactorial<S>(n + 2);
      C dn = S(n) * pw[n - 1] * detail::invFactorial<S>(n + 2);
      for (int m = 0; m <= n; ++m) {
        const S w = detail::invFactorial<S>(m + 1) * detail::invFactorial<S>(n - m + 1);
        cn -= pw[m] * qw[n - m] * w;
        if (m > 0) dn -= S(m) * pw[m - 1] * qw[n - m] * w;
      }
      g += cn;
      dg += dn;
    }
    // dp/dk = -1
    return {S(2) * g.real(), -S(2) * dg.real()};
  }
  const C f1p = phi1(p);
  const C f1q = phi1(q);
  const C f2p = phi2(p);
  const C g = f2p + phi2(q) - f1p * f1q;
  // phi1'(p) = (e^p - phi1(p)) / p ;  phi2'(p) = (phi1'(p) - phi2(p)) / p
  const C ep = std::exp(p);
  const C d1p = (ep - f1p) / p;
  const C d2p = (d1p - f2p) / p;
  const C dg = d2p - d1p * f1q;
  return {S(2) * g.real(), -S(2) * dg.real()};
}

}  // namespace odoerr

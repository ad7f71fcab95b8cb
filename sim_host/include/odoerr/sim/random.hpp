// random.hpp: the simulators' normal and uniform draws, owned by the project.
//
// The standard library's distributions are implementation-defined: the same engine and seed
// give other numbers under another standard library, so a drive that `odoerr sim --seed N`
// writes, and every seeded test, would change with it. These two give the same numbers
// everywhere, and they are the numbers libstdc++'s std::normal_distribution and
// std::uniform_real_distribution give (tests/test_random.cpp checks that, draw for draw, where
// the standard library is libstdc++), so drives written before them are unchanged.
//
// The uniform draw is the engine's words scaled into [0, 1) (as std::generate_canonical);
// the normal draw is Marsaglia's polar method, which makes two deviates per accepted pair and
// keeps the second for the next call. Computing the engine's range in the type (not through a
// run-time long-double logarithm) also keeps the draw cheap under every compiler.
#pragma once

#include <cmath>
#include <limits>
#include <type_traits>

namespace odoerr::sim {

/// A uniform draw in [0, 1) from a 32- or 64-bit engine whose minimum is 0.
template <typename T, typename Engine>
T canonical(Engine& engine) {
  static_assert(std::is_floating_point_v<T>, "canonical: a floating-point type");
  static_assert(Engine::min() == 0, "canonical: an engine whose minimum is 0");
  constexpr auto kMax = Engine::max();
  static_assert(kMax == 0xffffffffULL || kMax == 0xffffffffffffffffULL, "canonical: a 32- or 64-bit engine");
  constexpr int kBits = kMax == 0xffffffffULL ? 32 : 64;
  constexpr int kDigits = std::numeric_limits<T>::digits;
  constexpr int kWords = (kDigits + kBits - 1) / kBits;  // at least 1: kDigits >= 1
  const T range = kBits == 32 ? T(4294967296.0) : T(18446744073709551616.0);
  T sum = T(0);
  T scale = T(1);
  for (int k = 0; k < kWords; ++k) {
    sum += static_cast<T>(engine()) * scale;
    scale *= range;
  }
  T r = sum / scale;
  if (r >= T(1)) r = std::nextafter(T(1), T(0));
  return r;
}

/// Uniform in [a, b).
template <typename T>
class UniformDist {
 public:
  explicit UniformDist(T a = T(0), T b = T(1)) : a_(a), b_(b) {}
  template <typename Engine>
  T operator()(Engine& engine) const {
    return canonical<T>(engine) * (b_ - a_) + a_;
  }

 private:
  T a_;
  T b_;
};

/// Normal with a mean and a standard deviation (Marsaglia's polar method).
template <typename T>
class NormalDist {
 public:
  explicit NormalDist(T mean = T(0), T stddev = T(1)) : mean_(mean), stddev_(stddev) {}
  template <typename Engine>
  T operator()(Engine& engine) {
    T z;
    if (saved_available_) {
      saved_available_ = false;
      z = saved_;
    } else {
      T x, y, r2;
      do {
        x = T(2) * canonical<T>(engine) - T(1);
        y = T(2) * canonical<T>(engine) - T(1);
        r2 = x * x + y * y;
      } while (r2 > T(1) || r2 == T(0));
      const T mult = std::sqrt(T(-2) * std::log(r2) / r2);
      saved_ = x * mult;
      saved_available_ = true;
      z = y * mult;
    }
    return z * stddev_ + mean_;
  }
  /// Forgets the kept deviate (the next call draws a new pair).
  void reset() { saved_available_ = false; }

 private:
  T mean_;
  T stddev_;
  T saved_ = T(0);
  bool saved_available_ = false;
};

}  // namespace odoerr::sim

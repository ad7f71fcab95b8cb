// The project's normal and uniform draws (sim_host/include/odoerr/sim/random.hpp): the range
// and moments hold under every standard library; where the standard library is libstdc++, the
// draws are those of std::normal_distribution and std::uniform_real_distribution, draw for
// draw, so seeded drives written before random.hpp are unchanged.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "odoerr/sim/random.hpp"

namespace {

using odoerr::sim::canonical;
using odoerr::sim::NormalDist;
using odoerr::sim::UniformDist;

// An engine that returns its maximum: the largest word rounds to 1 in the floating type, so
// canonical must step back below 1.
struct MaxEngine {
  using result_type = unsigned long long;
  static constexpr result_type min() { return 0; }
  static constexpr result_type max() { return 0xffffffffffffffffULL; }
  result_type operator()() { return max(); }
};

TEST(Random, CanonicalStaysBelowOne) {
  MaxEngine e;
  EXPECT_LT(canonical<double>(e), 1.0);
  EXPECT_LT(canonical<float>(e), 1.0F);
  std::mt19937 g32(5);
  std::mt19937_64 g64(5);
  for (int i = 0; i < 100000; ++i) {
    const double a = canonical<double>(g32);
    const double b = canonical<double>(g64);
    ASSERT_TRUE(a >= 0.0 && a < 1.0) << a;
    ASSERT_TRUE(b >= 0.0 && b < 1.0) << b;
  }
}

TEST(Random, MomentsOfTheNormalAndUniformDraws) {
  std::mt19937_64 g(11);
  NormalDist<double> n(2.0, 0.5);
  UniformDist<double> u(-1.0, 3.0);
  const int count = 200000;
  double sn = 0, sn2 = 0, su = 0, su2 = 0;
  for (int i = 0; i < count; ++i) {
    const double a = n(g);
    const double b = u(g);
    sn += a;
    sn2 += a * a;
    su += b;
    su2 += b * b;
    ASSERT_TRUE(b >= -1.0 && b < 3.0) << b;
  }
  const double mn = sn / count, vn = sn2 / count - mn * mn;
  const double mu = su / count, vu = su2 / count - mu * mu;
  // Five standard errors of each estimate.
  EXPECT_NEAR(mn, 2.0, 5 * 0.5 / std::sqrt(count));
  EXPECT_NEAR(vn, 0.25, 5 * 0.25 * std::sqrt(2.0 / count));
  EXPECT_NEAR(mu, 1.0, 5 * std::sqrt(16.0 / 12.0 / count));
  EXPECT_NEAR(vu, 16.0 / 12.0, 5 * std::sqrt(256.0 / 180.0 / count));
}

#if defined(__GLIBCXX__)
template <typename T, typename Engine>
void expectSameAsLibstdcxx(unsigned seed) {
  Engine a(seed), b(seed);
  std::normal_distribution<T> sn(T(0.25), T(3));
  NormalDist<T> on(T(0.25), T(3));
  std::uniform_real_distribution<T> su(T(-2), T(5));
  UniformDist<T> ou(T(-2), T(5));
  for (int i = 0; i < 20000; ++i) {
    // Interleaved, as the simulators draw: an odd count of normals between uniforms.
    ASSERT_EQ(sn(a), on(b)) << "normal draw " << i;
    if (i % 3 == 0) {
      ASSERT_EQ(su(a), ou(b)) << "uniform draw " << i;
    }
  }
}

TEST(Random, DrawForDrawTheNumbersOfLibstdcxx) {
  expectSameAsLibstdcxx<double, std::mt19937_64>(1);
  expectSameAsLibstdcxx<double, std::mt19937>(2);
  expectSameAsLibstdcxx<float, std::mt19937_64>(3);
  expectSameAsLibstdcxx<float, std::mt19937>(4);
}
#endif

}  // namespace

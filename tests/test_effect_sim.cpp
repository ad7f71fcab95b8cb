// The hidden-effect simulator's arguments and its feature terms (sim_host/src/effect_sim.cpp):
// "feature:FEATURE@TARGET=C" parsed and refused as the catalogue's effects are, and a term
// injected into the truth the way the estimator's FeatureMotion applies it.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "odoerr/sim/effect_sim.hpp"

using odoerr::sim::EffectSimConfig;
using odoerr::sim::parseEffectArg;
using odoerr::sim::simulateEffectDrive;

namespace {

/// The length of the truth's path in an odolog text (the sum of its steps).
double truthPathLength(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  double len = 0, px = 0, py = 0;
  bool first = true;
  while (std::getline(in, line)) {
    if (line.rfind("truth ", 0) != 0) continue;
    std::istringstream f(line.substr(6));
    double t, x, y, th;
    if (!(f >> t >> x >> y >> th)) continue;
    if (!first) len += std::hypot(x - px, y - py);
    px = x;
    py = y;
    first = false;
  }
  return len;
}

}  // namespace

TEST(EffectSim, FeatureTermsAreParsedAndRefusedWithTheirReason) {
  EffectSimConfig cfg;
  std::string err;
  ASSERT_TRUE(parseEffectArg("feature:acc_pos_ds@along=-0.1", &cfg, &err)) << err;
  ASSERT_TRUE(parseEffectArg("turn_slip=0.05", &cfg, &err)) << err;
  ASSERT_EQ(cfg.features.size(), 1u);
  EXPECT_EQ(cfg.features[0].feature, "acc_pos_ds");
  EXPECT_EQ(cfg.features[0].target, "along");
  EXPECT_EQ(cfg.features[0].coef, -0.1);
  EXPECT_EQ(cfg.effects.count("turn_slip"), 1u);
  for (const char* bad : {"feature:acc_pos@along=1", "feature:acc_pos_ds=1", "feature:acc_pos_ds@sideways=1",
                          "feature:acc_pos_ds@along=x", "feature:none@along=1", "feature:acc_pos_ds@along=inf"}) {
    EffectSimConfig c;
    err.clear();
    EXPECT_FALSE(parseEffectArg(bad, &c, &err)) << bad;
    EXPECT_NE(err.find(bad), std::string::npos) << err;
  }
  EffectSimConfig four;
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(parseEffectArg("feature:t_ds@along=0.001", &four, &err));
  EXPECT_FALSE(parseEffectArg("feature:t_ds@along=0.001", &four, &err));
  EXPECT_NE(err.find("at most 4"), std::string::npos) << err;
}

TEST(EffectSim, AFeatureTermChangesTheTruthAndIsRecordedInTheLog) {
  // Travel lost while speeding up: the truth's path is shorter than the same drive's without
  // the term, by a little (the drive speeds up a few times a minute).
  EffectSimConfig clean, slip;
  clean.minutes = slip.minutes = 0.5;
  std::string err, a, b;
  ASSERT_TRUE(parseEffectArg("feature:acc_pos_ds@along=-0.1", &slip, &err)) << err;
  ASSERT_TRUE(simulateEffectDrive(clean, &a, &err)) << err;
  ASSERT_TRUE(simulateEffectDrive(slip, &b, &err)) << err;
  EXPECT_NE(b.find("meta truth_feature acc_pos_ds@along -0.1\n"), std::string::npos);
  EXPECT_EQ(a.find("truth_feature"), std::string::npos);
  const double la = truthPathLength(a), lb = truthPathLength(b);
  ASSERT_GT(la, 1.0);
  EXPECT_LT(lb, la);
  EXPECT_GT(lb, 0.9 * la);
}

// diagnose's units that need no drive: the --with grammar, the feature terms' names,
// tokens and words.
#include <gtest/gtest.h>

#include "diagnose/model_search.hpp"

using namespace odoerr;
using namespace odoerr::sim::diag;

namespace {

std::vector<EffectInfo> catalogue() {
  std::vector<EffectInfo> v;
  for (const char* n : {"turn_slip", "range_bias"}) {
    EffectInfo e;
    e.name = n;
    e.kind = std::string(n) == "turn_slip" ? EffectKind::kMotion : EffectKind::kMeasurement;
    v.push_back(e);
  }
  return v;
}

}  // namespace

TEST(DiagnoseWith, CatalogueNamesFeaturesAndAuto) {
  WithSpec w;
  std::string err;
  ASSERT_TRUE(parseWith({"range_bias", "feature:abs_ds@world_y", "ds_R_speed@wheel_R", "feature:inv_cos_inc"},
                        catalogue(), false, &w, &err))
      << err;
  ASSERT_EQ(w.catalogue, std::vector<int>{1});
  ASSERT_EQ(w.features.size(), 3u);  // the prefix carries over to the next token
  EXPECT_EQ(w.features[0].kind, Term::Kind::kMotion);
  EXPECT_EQ(w.features[0].mf, effects::MotionFeature::kAbsDs);
  EXPECT_EQ(w.features[0].mt, effects::MotionTarget::kWorldY);
  EXPECT_EQ(w.features[1].mt, effects::MotionTarget::kWheelR);
  EXPECT_EQ(w.features[2].kind, Term::Kind::kBeam);
  EXPECT_EQ(w.features[2].bf, effects::BeamFeature::kInvCosInc);
  EXPECT_EQ(w.names, (std::vector<std::string>{"range_bias", "feature:abs_ds@world_y", "feature:ds_R_speed@wheel_R",
                                               "feature:inv_cos_inc"}));
  // the printed token parses back to the same term
  WithSpec back;
  ASSERT_TRUE(parseWith({withToken(w.features[1])}, catalogue(), false, &back, &err));
  EXPECT_EQ(back.features[0].mf, w.features[1].mf);
  EXPECT_EQ(back.features[0].mt, w.features[1].mt);
  WithSpec a;
  ASSERT_TRUE(parseWith({"auto"}, catalogue(), false, &a, &err));
  EXPECT_TRUE(a.automatic);
}

TEST(DiagnoseWith, RefusesWhatItCannotCarry) {
  std::string err;
  WithSpec w;
  EXPECT_FALSE(parseWith({"tank_slip"}, catalogue(), false, &w, &err));
  EXPECT_NE(err.find("unknown effect 'tank_slip'"), std::string::npos) << err;
  EXPECT_FALSE(parseWith({"feature:ds_R_speed"}, catalogue(), false, &w, &err));
  EXPECT_NE(err.find("needs a target"), std::string::npos) << err;
  EXPECT_FALSE(parseWith({"feature:warp@along"}, catalogue(), false, &w, &err));
  EXPECT_NE(err.find("unknown feature"), std::string::npos) << err;
  EXPECT_FALSE(parseWith({"feature:ds_R_speed@wheel_R"}, catalogue(), true, &w, &err));  // sync: no wheels
  EXPECT_NE(err.find("synchronous"), std::string::npos) << err;
  WithSpec many;
  EXPECT_FALSE(parseWith({"feature:ds@along", "ds@cross", "dth@cross", "dt@world_x", "dt@world_y"}, catalogue(),
                         false, &many, &err));  // 5 motion slots: the feature effect holds 4
  EXPECT_NE(err.find("at most 4"), std::string::npos) << err;
}

TEST(DiagnoseTerms, FramesTokensAndWords) {
  const Term drift{Term::Kind::kMotion, effects::MotionFeature::kAbsDs, effects::MotionTarget::kWorldX};
  EXPECT_EQ(drift.frame(), "world");
  EXPECT_EQ(withToken(drift), "feature:abs_ds@world_x");
  EXPECT_NE(drift.words(0.0116, 0.0007).find("drifts 1.16 cm per m of travel toward +x"), std::string::npos)
      << drift.words(0.0116, 0.0007);
  EXPECT_NE(drift.words(-0.0116, 0.0007).find("toward -x"), std::string::npos);
  const Term play{Term::Kind::kReversal, effects::MotionFeature::kNone, effects::MotionTarget::kWheelL,
                  effects::BeamFeature::kNone, 1};
  EXPECT_EQ(play.name(), "rev_L");
  EXPECT_EQ(play.frame(), "wheel_L");
  EXPECT_EQ(withToken(play), "");  // host-only: no feature effect carries it
  EXPECT_NE(play.words(-0.003, 0.0005).find("the left wheel loses 3.0 mm"), std::string::npos)
      << play.words(-0.003, 0.0005);
  const Term scale{Term::Kind::kBeam, effects::MotionFeature::kNone, effects::MotionTarget::kAlong,
                   effects::BeamFeature::kAlphaAngleSens};
  EXPECT_EQ(scale.frame(), "beam");
  EXPECT_NE(scale.words(0.002, 0.00004).find("scaled by 1 +0.0020"), std::string::npos) << scale.words(0.002, 0.00004);
}

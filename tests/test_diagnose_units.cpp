// diagnose's units that need no drive: the --with grammar, the feature terms' names,
// tokens and words; the detection power's sizes and sentence; the held-out blocks.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "diagnose/heldout_blocks.hpp"
#include "diagnose/map_misfit.hpp"
#include "diagnose/model_search.hpp"
#include "diagnose/power.hpp"
#include "odoerr/sim/stats.hpp"

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

// The hit point of a beam, against hand-computed cases: a 10 m room, a laser 0.1 m ahead of
// the robot centre, 4 beams at -180, -90, 0 and 90 degrees.
TEST(DiagnoseMap, BeamHitPoints) {
  SegmentMap<double, 16> map;
  ASSERT_TRUE(map.add({0, 0, 10, 0}) && map.add({10, 0, 10, 10}) && map.add({10, 10, 0, 10}) && map.add({0, 10, 0, 0}));
  LaserConfig<double> cfg;
  cfg.beams = 4;
  cfg.angle_min = -kPi<double>;
  cfg.angle_inc = kPi<double> / 2;
  cfg.mount_x = 0.1;
  LaserGeometry<double, 64> laser;
  ASSERT_TRUE(laser.init(cfg));
  BeamHit h;
  // robot at (2, 5) heading +x: beam 2 (0 deg) from the laser at (2.1, 5) ends at (10, 5)
  ASSERT_TRUE(beamHit(map, laser, 2.0, 5.0, 0.0, 2, &h));
  EXPECT_NEAR(h.range, 7.9, 1e-12);
  EXPECT_NEAR(h.hx, 10.0, 1e-12);
  EXPECT_NEAR(h.hy, 5.0, 1e-12);
  EXPECT_EQ(h.wall, 1);
  // beam 3 (+90 deg) ends on the top wall above the laser: (2.1, 10), 5 m
  ASSERT_TRUE(beamHit(map, laser, 2.0, 5.0, 0.0, 3, &h));
  EXPECT_NEAR(h.hx, 2.1, 1e-12);
  EXPECT_NEAR(h.hy, 10.0, 1e-12);
  EXPECT_NEAR(h.range, 5.0, 1e-12);
  EXPECT_EQ(h.wall, 2);
  // heading +90 deg: the laser sits at (2, 5.1); beam 2 points up, 4.9 m to (2, 10); beam 0
  // (-180 deg) points down, 5.1 m to (2, 0)
  ASSERT_TRUE(beamHit(map, laser, 2.0, 5.0, kPi<double> / 2, 2, &h));
  EXPECT_NEAR(h.range, 4.9, 1e-9);
  EXPECT_NEAR(h.hx, 2.0, 1e-9);
  EXPECT_NEAR(h.hy, 10.0, 1e-9);
  ASSERT_TRUE(beamHit(map, laser, 2.0, 5.0, kPi<double> / 2, 0, &h));
  EXPECT_NEAR(h.range, 5.1, 1e-9);
  EXPECT_NEAR(h.hy, 0.0, 1e-9);
  EXPECT_EQ(h.wall, 0);
  // an oblique beam: heading 45 deg from (5, 5), beam 2 runs along the diagonal to (10, 10)
  ASSERT_TRUE(beamHit(map, laser, 5.0, 5.0, kPi<double> / 4, 2, &h));
  EXPECT_NEAR(h.hx, 10.0, 1e-9);
  EXPECT_NEAR(h.hy, 10.0, 1e-9);
  EXPECT_NEAR(h.range, std::sqrt(50.0) - 0.1, 1e-9);
}

// A region's history (map_history.hpp): the kind from when it disagreed.
TEST(DiagnoseMap, RegionHistoryKinds) {
  using odoerr::sim::diag::regionHistory;
  using odoerr::sim::diag::RegionSighting;
  auto make = [](int n, auto disagree) {
    std::vector<RegionSighting> v;
    for (int i = n - 1; i >= 0; --i) v.push_back({0.1 * i, disagree(i)});  // any order
    return v;
  };
  // every pass disagrees: the map is wrong there
  auto h = regionHistory(make(200, [](int i) { return i % 10 != 0; }));
  EXPECT_EQ(h.kind, "persistent");
  EXPECT_EQ(h.scans, 200);
  EXPECT_EQ(h.disagreed, 180);
  EXPECT_DOUBLE_EQ(h.t_first, 0.0);
  EXPECT_NEAR(h.t_last, 19.9, 1e-12);
  // a door opened at scan 120: agreed before, disagreed after
  h = regionHistory(make(200, [](int i) { return i >= 120; }));
  EXPECT_EQ(h.kind, "changed");
  EXPECT_TRUE(h.changed);
  EXPECT_NEAR(h.t_change, 11.95, 1e-9);
  EXPECT_DOUBLE_EQ(h.share_before, 0.0);
  EXPECT_DOUBLE_EQ(h.share_after, 1.0);
  EXPECT_NEAR(h.t_disagreed_first, 12.0, 1e-12);
  // a step too near the start (fewer than 20 scans on a side) is not a change
  h = regionHistory(make(200, [](int i) { return i >= 15; }));
  EXPECT_EQ(h.kind, "persistent");
  // people passing: a few scans now and then
  h = regionHistory(make(200, [](int i) { return i % 7 == 0; }));
  EXPECT_EQ(h.kind, "transient");
  // in between
  h = regionHistory(make(200, [](int i) { return i % 2 == 0; }));
  EXPECT_EQ(h.kind, "intermittent");
  // nothing seen
  h = regionHistory({});
  EXPECT_EQ(h.scans, 0);
  EXPECT_EQ(h.kind, "");
}

TEST(DiagnosePower, SizesFromTheCandidatesSigmaAndReasonsWhereThereIsNone) {
  // Five families: one excited parameter; one left at its prior; a measurement effect on a log
  // without a laser; a noise effect; two parameters of which one is informed.
  auto info = [](const char* name, EffectKind kind, int n) {
    EffectInfo e;
    e.name = name;
    e.kind = kind;
    e.n = n;
    for (int i = 0; i < n; ++i) {
      e.pnames.push_back("p" + std::to_string(i));
      e.ref.push_back(0.04);
      e.prior.push_back(0.1);
    }
    return e;
  };
  const std::vector<EffectInfo> fx = {info("turn_slip", EffectKind::kMotion, 1), info("backlash", EffectKind::kMotion, 1),
                                      info("range_bias", EffectKind::kMeasurement, 1),
                                      info("turn_noise", EffectKind::kNoise, 1),
                                      info("wheel_eccentricity", EffectKind::kMotion, 2)};
  std::vector<Candidate> cand(fx.size());
  auto set = [&](int e, std::vector<double> sig, std::vector<bool> informed) {
    cand[e].sig = Eigen::Map<Eigen::VectorXd>(sig.data(), static_cast<Eigen::Index>(sig.size()));
    cand[e].informed = informed;
  };
  set(0, {0.001}, {true});
  set(1, {0.09}, {false});
  set(2, {0.0001}, {true});
  set(3, {0.0002}, {true});
  set(4, {0.002, 0.08}, {true, false});
  const long n = 20000;
  const auto j = detectionPower(fx, cand, n, /*has_laser=*/false);
  ASSERT_EQ(j["families"].size(), 5u);
  // k = 1: the largest of chi2_1(0.999), ln n and chi2_1(0.99) is ln 20000 = 9.90 < 10.83.
  const double tau = std::max(sim::chiSquareQuantile(0.999, 1), std::log(double(n)));
  const double lambda = sim::noncentralityForPower(1, tau, kDetectionPower);
  const auto& ts = j["families"][0];
  EXPECT_TRUE(ts["excited"].get<bool>());
  EXPECT_NEAR(ts["threshold"].get<double>(), 10.8276, 1e-3);
  EXPECT_NEAR(ts["parameters"][0]["min_detectable"].get<double>(), 0.001 * std::sqrt(lambda), 1e-12);
  EXPECT_GT(ts["parameters"][0]["min_detectable"].get<double>(), 0.001 * std::sqrt(tau));  // 80 % needs more than the threshold
  EXPECT_FALSE(j["families"][1]["excited"].get<bool>());
  EXPECT_TRUE(j["families"][1]["parameters"][0]["min_detectable"].is_null());
  EXPECT_NE(j["families"][1]["why"].get<std::string>().find("reverse the direction"), std::string::npos);
  EXPECT_EQ(j["families"][2]["why"], "needs a laser; the log has none");
  EXPECT_TRUE(j["families"][3]["parameters"][0]["min_detectable"].is_null());
  EXPECT_TRUE(j["families"][4]["excited"].get<bool>());
  EXPECT_EQ(j["families"][4]["informed_params"], 1);
  EXPECT_TRUE(j["families"][4]["parameters"][1]["min_detectable"].is_null());
  const std::string s = nothingLargerThan(j);
  EXPECT_EQ(s.rfind("nothing larger than turn_slip.p0 ", 0), 0u) << s;
  EXPECT_NE(s.find("wheel_eccentricity.p0 "), std::string::npos) << s;
  EXPECT_NE(s.find("(p1 not excited)"), std::string::npos) << s;
  EXPECT_NE(s.find("(80 % power); not excited by this drive: backlash, range_bias; no size stated for turn_noise"),
            std::string::npos)
      << s;
}

TEST(DiagnoseHeldout, BlocksFollowTheEventsNotTheTimeTheySpan) {
  // Events every 0.1 s for 40 s: after 10 s of warm-up and a 0.5 s gap, 14 whole blocks of
  // 2 s from 10.5 s, in 4 folds.
  std::vector<double> t;
  for (int k = 0; k <= 400; ++k) t.push_back(0.1 * k);
  const HeldoutBlocks a(t, 10.0, 0.5, 2.0, 4);
  ASSERT_EQ(a.blocks().size(), 14u);
  EXPECT_DOUBLE_EQ(a.blocks()[0].first, 10.5);
  EXPECT_DOUBLE_EQ(a.blocks()[13].second, 38.5);
  EXPECT_EQ(a.folds(), 4);
  EXPECT_EQ(a.blockAt(11.0), 0);
  EXPECT_EQ(a.blockAt(10.0), -1);  // warm-up
  EXPECT_EQ(a.blockAt(39.0), -1);  // after the last whole block
  EXPECT_TRUE(a.inHeldout(13.0, 1));
  EXPECT_FALSE(a.inHeldout(13.0, 0));
  EXPECT_TRUE(a.nearHeldout(12.3, 1));   // 0.2 s before block 1
  EXPECT_FALSE(a.nearHeldout(11.5, 1));  // 1 s before it
  // The same drive paused for 70 days (a scan stamped 6,010,000 s, as a fuzzed log had) and
  // resumed for 10 s: the blocks are those that hold events, numbered on across the pause,
  // not the 3 million of 2 s the pause spans.
  std::vector<double> p(t.begin(), t.begin() + 201);  // to 20 s
  for (int k = 0; k <= 100; ++k) p.push_back(6010000.0 + 0.1 * k);
  const HeldoutBlocks b(p, 10.0, 0.5, 2.0, 4);
  ASSERT_EQ(b.blocks().size(), 10u);  // 10.5 .. 20.5 s: 5; from 6,009,998.5 s: 5 whole ones
  EXPECT_EQ(b.blockAt(19.0), 4);
  EXPECT_EQ(b.blockAt(6010000.2), 5);
  EXPECT_EQ(b.blockAt(6010001.0), 6);
  EXPECT_EQ(b.blockAt(1000.0), -1);  // in the pause
  EXPECT_TRUE(b.inHeldout(6010000.2, 1));
  EXPECT_FALSE(b.nearHeldout(1000.0, 1));
  // Times a double holds but an int does not: no block, no conversion.
  const HeldoutBlocks c({0.0, 1e300}, 10.0, 0.5, 2.0, 4);
  EXPECT_EQ(c.blocks().size(), 0u);
  EXPECT_EQ(c.blockAt(5e299), -1);
}

// The odolog v1 reader (docs/odolog.md): the simulator's own output round-trips, and rules
// are enforced with an error naming the line and the rule (every rule of the doc has a
// case in tests/odolog/, run through odoerr replay).
#include <gtest/gtest.h>

#include <cmath>

#include "odoerr/sim/odolog.hpp"
#include "odoerr/sim/odolog_writer.hpp"
#include "odoerr/sim/runner.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

const char* kHeader =
    "odolog 1\n"
    "# a comment\n"
    "drive diff\n"
    "param wheel_radius_m 0.05\n"
    "param ticks_per_rev 4096\n"
    "param wheelbase_m 0.5   # trailing comment\n"
    "laser 2 -1.5 3.0 20.0 0.03 0.0 0.0 0.0\n"
    "wall 0 0 10 0\n"
    "init 5.0 1.0 0.0 0.01 0.01 0.0175\n";

std::string parseError(const std::string& text) {
  Odolog log;
  std::string err;
  EXPECT_FALSE(parseOdolog(text, "t.odolog", &log, &err)) << text;
  return err;
}

}  // namespace

TEST(OdologReader, ReadsAValidFile) {
  Odolog log;
  std::string err;
  const std::string text = std::string(kHeader) +
                           "enc 0.0 0 0\nfuture_record 1 2 3\nscan 0.01 5.0 nan\npose 0.02 5 1 0 0.1 0.1 0.01\n"
                           "truth 0.02 5.001 1.0 0.0\nenc 0.02 -131 129\n";
  ASSERT_TRUE(parseOdolog(text, "ok.odolog", &log, &err)) << err;
  EXPECT_EQ(log.drive, "diff");
  EXPECT_DOUBLE_EQ(log.param("wheelbase_m", 0), 0.5);
  EXPECT_EQ(log.laser.beams, 2);
  ASSERT_EQ(log.enc.size(), 2u);
  EXPECT_EQ(log.enc[1].a, -131);
  ASSERT_EQ(log.scans.size(), 1u);
  EXPECT_TRUE(std::isnan(log.scans[0].ranges[1]));
  EXPECT_EQ(log.poses.size(), 1u);
  EXPECT_EQ(log.truth.size(), 1u);
  EXPECT_EQ(log.unknown_records, 1) << "unknown record types are skipped and counted";
}

TEST(OdologReader, EveryRuleIsEnforcedWithItsLine) {
  const std::string h = kHeader;  // 9 lines
  struct Case { std::string text; std::string expect; };
  const Case cases[] = {
      {"drive diff\n", "t.odolog:1: the first record must be 'odolog 1'"},
      {"odolog 2\n", "t.odolog:1: the first record must be 'odolog 1'"},
      {h + "enc 0.0 1\n", "t.odolog:10: 'enc' takes 3 fields (T A B), got 2"},
      {h + "enc 0.0 1.5 2\n", "t.odolog:10: enc A: '1.5' is not a signed 64-bit integer"},
      {h + "enc 0.0 1 99999999999999999999\n", "t.odolog:10: enc B: '99999999999999999999' does not fit in 64 bits"},
      {h + "enc 1.0 0 0\nenc 0.5 0 0\n", "t.odolog:11: data records must be in non-decreasing time"},
      {h + "scan 0.0 1.0\n", "t.odolog:10: scan has 1 ranges, the laser record says 2"},
      {h + "scan 0.0 1.0 abc\n", "t.odolog:10: scan range: 'abc' is not a number"},
      {h + "pose 0.0 nan 0 0 1 1 1\n", "t.odolog:10: pose field: nan is allowed only in scan ranges"},
      {h + "enc 0.0 0 0\nwall 0 0 1 1\n", "t.odolog:11: header record 'wall' after the first data record"},
      {h + "param wheelbase_m 0.6\n", "t.odolog:10: param 'wheelbase_m' given twice"},
      {h + "truth inf 0 0 0\n", "t.odolog:10: time: 'inf' is not a finite number"},
      {h + "wall 1 1 1 1\n", "t.odolog:10: wall has zero length"},
      {h + "Scan 0 1 2\n", "t.odolog:10: record type 'Scan' is not a lower-case word"},
      {"odolog 1\ndrive tank\n", "t.odolog:2: drive must be 'diff' or 'sync', got 'tank'"},
      {"odolog 1\nenc 0 0 0\n", "t.odolog:2: data record 'enc' before the 'drive' record"},
      {"odolog 1\ndrive diff\nparam ticks_per_rev 4096\nparam wheelbase_m 0.5\n",
       "t.odolog:2: drive diff needs 'param wheel_radius_m'"},
      {"odolog 1\ndrive sync\nscan 0 1\n", "t.odolog:3: 'scan' before any 'laser' record"},
      {"", "t.odolog:0: empty file: the first record must be 'odolog 1'"},
      {"odolog 1\ndrive diff\nparam wheel_radius_m 0.05\nparam ticks_per_rev 4096\nparam wheelbase_m 0.5\n"
       "param max_speed_mps -1\n",
       "t.odolog:2: param max_speed_mps must be positive"},
  };
  for (const Case& c : cases) {
    const std::string err = parseError(c.text);
    EXPECT_EQ(err.rfind(c.expect, 0), 0u) << "got: " << err << "\nexpected: " << c.expect;
  }
}

// Rule R34: a pose's X and Y reach to just under 2^46 m (where doubles are still finer than
// the 1 cm cycle); at 2^46 m and beyond, in either sign, the field is refused with its line.
// THETA is any finite angle.
TEST(OdologReader, PoseCoordinatesReachTo2To46Metres) {
  const std::string h = kHeader;  // 9 lines
  const std::string under = "70368744177663.9";  // 2^46 - 0.1 m
  Odolog log;
  std::string err;
  ASSERT_TRUE(parseOdolog(h + "enc 0 0 0\ntruth 0 " + under + " -" + under + " 1e300\npose 0 -" + under + " " +
                              under + " 0 1 1 1\n",
                          "t.odolog", &log, &err))
      << err;
  EXPECT_LT(std::fabs(log.truth[0].x), kPoseReachM);
  const std::string at = "70368744177664";  // 2^46 m
  EXPECT_EQ(parseError(h + "truth 0 0 -" + at + " 0\n"),
            "t.odolog:10: truth y: -" + at +
                " m is beyond +-2^46 m (7.04e13 m), where doubles are coarser than the 1 cm travel cycle");
  EXPECT_EQ(parseError(h + "pose 0 " + at + " 0 0 1 1 1\n").rfind("t.odolog:10: pose x: " + at, 0), 0u);
  const std::string far_init = std::string(kHeader).replace(h.find("init 5.0"), 8, "init 1e20");
  EXPECT_EQ(parseError(far_init).rfind("t.odolog:9: init x: 1e20 m is beyond", 0), 0u);
}

// The plausibility rule (docs/odolog.md, "Plausibility"): the header's wheel makes 13,038
// ticks per metre; the records are 10 ms apart, so the interval is floored at 20 ms and at
// the default 5 m/s an increment may be 1,304 + 16 ticks.
TEST(OdologReader, AnImpossibleIncrementIsRejectedAndTheRestShifted) {
  Odolog log;
  std::string err;
  const std::string text = std::string(kHeader) +
                           "enc 0.00 0 0\nenc 0.01 100 100\nenc 0.02 1000100 200\nenc 0.03 1000200 300\n";
  ASSERT_TRUE(parseOdolog(text, "j.odolog", &log, &err)) << err;
  ASSERT_EQ(log.enc_rejected.size(), 1u);
  const OdologRejection& r = log.enc_rejected[0];
  EXPECT_EQ(r.line, 12);
  EXPECT_EQ(r.channel, 'A');
  EXPECT_DOUBLE_EQ(r.t, 0.02);
  EXPECT_DOUBLE_EQ(r.ticks, 1000000.0);
  EXPECT_NEAR(r.limit, 5.0 * 4096 / (2 * kPi<double> * 0.05) * 0.02 + 16, 1e-6);
  EXPECT_DOUBLE_EQ(log.enc_limits.dt_floor_s, 0.02);
  // channel A: the jump contributes nothing, the next increment (100) counts; B untouched
  EXPECT_EQ(log.enc[2].a, 100);
  EXPECT_EQ(log.enc[3].a, 200);
  EXPECT_EQ(log.enc[3].b, 300);
  EXPECT_EQ(log.enc_limits.max_speed_mps, kDefaultMaxSpeedMps);
  EXPECT_FALSE(log.enc_limits.speed_given);
  const std::string line = rejectionSummary(log);
  EXPECT_NE(line.find("1 encoder increment rejected"), std::string::npos) << line;
  EXPECT_NE(line.find("j.odolog:12"), std::string::npos) << line;
  // a log without a glitch: nothing rejected, nothing said
  ASSERT_TRUE(parseOdolog(std::string(kHeader) + "enc 0.00 0 0\nenc 0.01 600 -600\n", "ok.odolog", &log, &err));
  EXPECT_TRUE(log.enc_rejected.empty());
  EXPECT_EQ(rejectionSummary(log), "");
}

TEST(OdologReader, IncrementsAtTheIntegerLimitsAreRejectedWithoutOverflow) {
  Odolog log;
  std::string err;
  const std::string text = std::string(kHeader) +
                           "enc 0.00 0 0\n"
                           "enc 0.01 9223372036854775807 -9223372036854775808\n"
                           "enc 0.02 9223372036854775800 -9223372036854775800\n"
                           "enc 0.03 -9223372036854775808 9223372036854775807\n";
  ASSERT_TRUE(parseOdolog(text, "lim.odolog", &log, &err)) << err;
  ASSERT_EQ(log.enc_rejected.size(), 4u);  // both channels at lines 11 and 13
  EXPECT_EQ(log.enc_rejected[0].line, 11);
  EXPECT_EQ(log.enc_rejected[2].line, 13);
  // between lines 11 and 12 the counts moved -7 and +8: plausible, kept
  EXPECT_EQ(log.enc[2].a, -7);
  EXPECT_EQ(log.enc[2].b, 8);
  EXPECT_EQ(log.enc[3].a, -7);
  EXPECT_EQ(log.enc[3].b, 8);
}

TEST(OdologReader, TheHeaderSetsTheLimits) {
  Odolog log;
  std::string err;
  // 100 ticks in 10 ms (the floor: 20 ms) is 0.38 m/s: allowed at the default, not at
  // max_speed_mps 0.1 (42 ticks)
  const std::string enc = "enc 0.00 0 0\nenc 0.01 100 0\n";
  ASSERT_TRUE(parseOdolog(std::string(kHeader) + enc, "a.odolog", &log, &err)) << err;
  EXPECT_TRUE(log.enc_rejected.empty());
  ASSERT_TRUE(parseOdolog(std::string(kHeader) + "param max_speed_mps 0.1\n" + enc, "b.odolog", &log, &err)) << err;
  ASSERT_EQ(log.enc_rejected.size(), 1u);
  EXPECT_TRUE(log.enc_limits.speed_given);
  EXPECT_NEAR(log.enc_rejected[0].limit, 0.1 * 4096 / (2 * kPi<double> * 0.05) * 0.02 + 16, 1e-6);
  // sync: the steering channel's own limit (ticks_per_rad x max_steer_rate_radps)
  const std::string sync = "odolog 1\ndrive sync\nparam ticks_per_m 1000\nparam ticks_per_rad 1000\n"
                           "param max_steer_rate_radps 2\nenc 0.0 0 0\nenc 0.1 40 150\nenc 0.2 80 650\n";
  ASSERT_TRUE(parseOdolog(sync, "s.odolog", &log, &err)) << err;
  ASSERT_EQ(log.enc_rejected.size(), 1u);  // 500 steering ticks > 2 rad/s x 0.2 s (the floor) x 1000 + 16
  EXPECT_EQ(log.enc_rejected[0].channel, 'B');
  EXPECT_EQ(log.enc_rejected[0].line, 8);
  EXPECT_EQ(log.enc[2].b, 150);
}

// A log whose stamps do not measure time (`meta time_base order`, an importer's --time order):
// the log's own rule, 100 x the channel's median nonzero increment. 20,000 ticks per 0.1 s
// (15 m/s if the stamps were time) are its ordinary motion; a glitch of 10^7 is not.
TEST(OdologReader, SyntheticTimeUsesTheLogsOwnIncrements) {
  Odolog log;
  std::string err;
  const std::string data = "enc 0.0 0 0\nenc 0.1 20000 20000\nenc 0.2 40000 40000\nenc 0.3 60000 60000\n"
                           "enc 0.4 10060000 80000\n";
  ASSERT_TRUE(parseOdolog(std::string(kHeader) + data, "real.odolog", &log, &err)) << err;
  EXPECT_EQ(log.enc_rejected.size(), 8u) << "as time, every increment of both channels is too fast";
  ASSERT_TRUE(parseOdolog(std::string(kHeader) + "meta time_base order\n" + data, "syn.odolog",
                          &log, &err))
      << err;
  EXPECT_TRUE(log.enc_limits.synthetic_time);
  ASSERT_EQ(log.enc_rejected.size(), 1u);
  EXPECT_EQ(log.enc_rejected[0].line, 15);
  EXPECT_DOUBLE_EQ(log.enc_rejected[0].limit, 100 * 20000.0 + 16);
  EXPECT_EQ(log.enc[4].a, 60000);
  EXPECT_EQ(log.enc[4].b, 80000);
}

TEST(OdologReader, SimulatorOutputRoundTrips) {
  SimConfig cfg;
  cfg.steps = 200;
  FilterSetup setup;
  PaperSim<DiffDrive<double>> header_sim(cfg, 4);
  std::string text = odologHeader(header_sim, 4, 0.001, 0.002);
  std::vector<SimStep<DiffDrive<double>>> steps;
  (void)runDrive<double, DiffDrive>(cfg, 4, NonSysStart::kSmall, setup, 1000,
                                    [&](const SimStep<DiffDrive<double>>& s) {
                                      appendOdologStep(text, s, cfg.laser.beams);
                                      steps.push_back(s);
                                    });
  Odolog log;
  std::string err;
  ASSERT_TRUE(parseOdolog(text, "sim.odolog", &log, &err)) << err;
  EXPECT_EQ(log.walls.size(), 4u);
  ASSERT_EQ(log.enc.size(), 201u);
  ASSERT_EQ(log.scans.size(), 200u);
  EXPECT_EQ(log.enc.back().a, steps.back().counts.count_a);
  EXPECT_NEAR(log.truth.back().x, steps.back().truth.x, 1e-8);
  for (std::size_t i = 0; i < 36; ++i) {
    const double r = steps.back().ranges[i];
    if (std::isnan(r)) {
      EXPECT_TRUE(std::isnan(log.scans.back().ranges[i]));
    } else {
      EXPECT_NEAR(log.scans.back().ranges[i], r, 6e-6);
    }
  }
}

TEST(OdologReader, MissingFileIsAClearError) {
  Odolog log;
  std::string err;
  EXPECT_FALSE(readOdolog("/nonexistent/x.odolog", &log, &err));
  EXPECT_EQ(err.rfind("/nonexistent/x.odolog: cannot open", 0), 0u) << err;
}

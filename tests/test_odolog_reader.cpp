// The odolog v1 reader (docs/odolog.md): the simulator's own output round-trips, and rules
// are enforced with an error naming the line and the rule (every rule of the doc has a
// case in tests/odolog/, run through odoerr replay).
#include <gtest/gtest.h>

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
  };
  for (const Case& c : cases) {
    const std::string err = parseError(c.text);
    EXPECT_EQ(err.rfind(c.expect, 0), 0u) << "got: " << err << "\nexpected: " << c.expect;
  }
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

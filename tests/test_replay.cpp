// odoerr replay: a simulated drive written as odolog and replayed (one cycle per cm, scans
// at their stamps) recovers the simulated parameters, writes every innovation, and uses
// pose fixes; bad logs are refused with a clear message.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "odoerr/sim/odolog.hpp"
#include "odoerr/sim/odolog_writer.hpp"
#include "odoerr/sim/replay.hpp"
#include "odoerr/sim/runner.hpp"
#include "simulated_log.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

using test::simulatedLog;
using test::tempDir;

std::size_t lines(const std::string& path) {
  std::ifstream f(path);
  std::size_t n = 0;
  std::string l;
  while (std::getline(f, l)) ++n;
  return n;
}

}  // namespace

TEST(Replay, RecoversTheSimulatedParametersFromALog) {
  Odolog log;
  std::string err;
  ASSERT_TRUE(parseOdolog(simulatedLog(21, 3000), "sim.odolog", &log, &err)) << err;
  ReplayOptions opt;
  opt.out_dir = tempDir("replay");
  ReplaySummary sum;
  ASSERT_TRUE(replayOdolog(log, opt, &sum, &err)) << err;
  EXPECT_EQ(sum.scans, 3000u);
  EXPECT_GT(sum.cycles, 3000u) << "travel cycles between and at the scans";
  ASSERT_EQ(sum.params.size(), 4u);
  EXPECT_NEAR(sum.params[0].value, 1.1, 4 * sum.params[0].sigma);  // delta_R
  EXPECT_NEAR(sum.params[1].value, 0.9, 4 * sum.params[1].sigma);  // delta_L
  EXPECT_GT(sum.params[3].value, 2.5e-4 * 0.1) << "K_w must not collapse";
  EXPECT_GE(sum.pose_rmse_m, 0.0);
  EXPECT_LT(sum.pose_rmse_m, 0.02);
  // Every beam of every scan is in innovations.csv (header + 36 per scan).
  EXPECT_EQ(lines(opt.out_dir + "/innovations.csv"), 1 + 36 * 3000u);
  EXPECT_EQ(lines(opt.out_dir + "/trajectory.tum"), sum.cycles);
  EXPECT_TRUE(std::filesystem::exists(opt.out_dir + "/replay.json"));
}

TEST(Replay, PoseFixesAreFused) {
  // A short drive with no laser: only encoders and a few pose fixes. The fixes must pull the
  // estimate back to the truth.
  std::string text =
      "odolog 1\ndrive diff\nparam wheel_radius_m 0.05\nparam ticks_per_rev 4096\nparam wheelbase_m 0.5\n"
      "init 0 0 0 0.001 0.001 0.001\n";
  // Straight at 1 m/s; the encoders read 10 % short (delta = 1.1), truth x = 1.1 * encoder x.
  const double ticks_per_m = 4096 / (2 * kPi<double> * 0.05);
  for (int k = 0; k <= 200; ++k) {
    const double t = 0.01 * k;
    const long long ticks = std::llround(0.01 * k / 1.1 * ticks_per_m);
    text += "enc " + std::to_string(t) + " " + std::to_string(ticks) + " " + std::to_string(ticks) + "\n";
    if (k % 50 == 0 && k > 0) {
      text += "pose " + std::to_string(t) + " " + std::to_string(0.01 * k) + " 0 0 0.002 0.002 0.002\n";
    }
  }
  Odolog log;
  std::string err;
  ASSERT_TRUE(parseOdolog(text, "fix.odolog", &log, &err)) << err;
  ReplayOptions opt;
  opt.out_dir = tempDir("posefix");
  ReplaySummary sum;
  ASSERT_TRUE(replayOdolog(log, opt, &sum, &err)) << err;
  EXPECT_EQ(sum.poses, 4u);
  std::ifstream f(opt.out_dir + "/estimates.csv");
  std::string l, last;
  while (std::getline(f, l)) last = l;
  const double x = std::stod(last.substr(last.find(',') + 1));
  EXPECT_NEAR(x, 2.0, 0.01) << "the last fix (x = 2.0) is fused: " << last;
}

TEST(Replay, RefusesLogsItCannotRun) {
  Odolog log;
  std::string err;
  ASSERT_TRUE(parseOdolog("odolog 1\ndrive diff\nparam wheel_radius_m 0.05\nparam ticks_per_rev 4096\n"
                          "param wheelbase_m 0.5\nenc 0 0 0\nenc 0.01 10 10\n",
                          "noinit.odolog", &log, &err))
      << err;
  ReplayOptions opt;
  opt.out_dir = tempDir("refuse");
  ReplaySummary sum;
  EXPECT_FALSE(replayOdolog(log, opt, &sum, &err));
  EXPECT_EQ(err, "noinit.odolog: the replay needs an 'init' record (the prior on the initial pose)");
}

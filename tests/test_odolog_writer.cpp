// The simulator's odolog v1 output follows docs/odolog.md's lexical and ordering rules, and its
// data reproduce the simulated drive (cumulative counts, 36 ranges, truth).
#include <gtest/gtest.h>

#include <sstream>

#include "odoerr/sim/odolog_writer.hpp"
#include "odoerr/sim/runner.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {
template <template <typename> class DriveT>
void checkLog(const char* drive_name) {
  SimConfig cfg;
  cfg.steps = 120;
  FilterSetup setup;
  PaperSim<DriveT<double>> header_sim(cfg, 9);
  std::string text = odologHeader(header_sim, 9, 0.001, 0.002);
  std::vector<SimStep<DriveT<double>>> steps;
  (void)runDrive<double, DriveT>(cfg, 9, NonSysStart::kSmall, setup, 1000,
                                 [&](const SimStep<DriveT<double>>& s) {
                                   appendOdologStep(text, s, cfg.laser.beams);
                                   steps.push_back(s);
                                 });
  std::istringstream in(text);
  std::string line;
  int lineno = 0;
  bool data_started = false;
  double last_t = -1;
  int enc = 0, scans = 0, truths = 0, walls = 0;
  long long last_a = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::istringstream ls(line);
    std::string type;
    ls >> type;
    if (lineno == 1) {
      EXPECT_EQ(line, "odolog 1");
      continue;
    }
    const bool header = type == "drive" || type == "param" || type == "laser" || type == "wall" ||
                        type == "init" || type == "meta";
    const bool data = type == "enc" || type == "scan" || type == "truth" || type == "pose";
    ASSERT_TRUE(header || data) << "line " << lineno << ": unknown record " << type;
    if (header) {
      EXPECT_FALSE(data_started) << "line " << lineno << ": header after data";
      if (type == "drive") {
        std::string d;
        ls >> d;
        EXPECT_EQ(d, drive_name);
      }
      if (type == "wall") ++walls;
      continue;
    }
    data_started = true;
    double t;
    ASSERT_TRUE(ls >> t) << "line " << lineno;
    EXPECT_GE(t, last_t) << "line " << lineno << ": time goes backwards";
    last_t = t;
    if (type == "enc") {
      long long a, b;
      ASSERT_TRUE(ls >> a >> b) << "line " << lineno;
      if (enc > 0) {
        EXPECT_EQ(a, steps[enc - 1].counts.count_a);
      }
      EXPECT_GE(a, last_a) << "forward drive: counts grow";
      last_a = a;
      ++enc;
    } else if (type == "scan") {
      int n = 0;
      std::string tok;
      while (ls >> tok) ++n;
      EXPECT_EQ(n, 36) << "line " << lineno;
      ++scans;
    } else if (type == "truth") {
      double x, y, th;
      ASSERT_TRUE(ls >> x >> y >> th);
      if (truths > 0) {
        EXPECT_NEAR(x, steps[truths - 1].truth.x, 1e-6);
      }
      ++truths;
    }
  }
  EXPECT_EQ(walls, 4);
  EXPECT_EQ(enc, 121);  // t = 0 plus one per cycle
  EXPECT_EQ(scans, 120);
  EXPECT_EQ(truths, 121);
}
}  // namespace

TEST(OdologWriter, SyncDriveFollowsTheSpec) { checkLog<SyncDrive>("sync"); }
TEST(OdologWriter, DiffDriveFollowsTheSpec) { checkLog<DiffDrive>("diff"); }

// The firmware application (fw/app.hpp) running on the host over the HAL simulator: the
// real drivers parse the real wire bytes and wrapping counters. It must reach the same
// estimates as the core driven directly with the simulator's exact increments and scans,
// survive 1 % corrupted laser bytes within 2 sigma, count encoder glitches, publish valid
// telemetry frames, and restore its calibration at boot.
#include <gtest/gtest.h>

#include "odoerr/fw/app.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/hal/fake_param_store.hpp"
#include "odoerr/sim/hal_sim.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

using Store = hal::FakeParamStore<4096, 1024>;

template <template <typename> class DriveT>
struct FwResult {
  using Est = typename fw::PaperTypes<float, DriveT>::EstimatorT;
  Eigen::VectorXd x, sigma;  // firmware's final state and sigmas
  Eigen::VectorXd ref_x, ref_sigma;  // the core driven directly
  double pos_err = 0, pos_sigma = 0;
  fw::AppHealth health{};
  drivers::Lms2xxCounters lms{};
  std::uint32_t jumps = 0;
  std::vector<std::vector<std::uint8_t>> frames;
};

struct WorldFaults {
  double scan_dropout = 0.0;
  int stand_after_steps = -1;
};

template <template <typename> class DriveT>
FwResult<DriveT> runFirmware(std::uint64_t seed, const SerialFaults& faults, int glitches, Store* store,
                             int steps = 3000, const WorldFaults& wf = {}) {
  using D = DriveT<double>;
  using Est = typename fw::PaperTypes<float, DriveT>::EstimatorT;
  SimConfig cfg;
  // A circle that stays 50 cm clear of the walls: the paper's 5 m circle touches them,
  // and with scans lost to faults an estimate can cross a wall there, after which no beam
  // can be predicted (a single-hypothesis filter cannot relocalise; docs/paper-notes.md).
  cfg.radius = 4.5;
  typename HalSimDrive<D>::Options opt;
  opt.faults = faults;
  opt.scan_dropout_probability = wf.scan_dropout;
  opt.stand_after_steps = wf.stand_after_steps;
  HalSimDrive<D> world(cfg, seed, opt);
  fw::FilterSetup setup;
  // A calibrated start of K (as after restoring the stored calibration): with a scan every
  // 10 cycles the paper's OF from 100x below is too slow for a 30 m test drive (it reaches
  // about 0.3x, and the AKF is then over-confident); that regime is covered by the paper
  // experiment's tests, these are about the firmware's drivers and timing.
  const typename DriveT<float>::NonSysVec k0 = world.sim().trueNonSys().template cast<float>();
  Est est = fw::makePaperEstimator<float, DriveT>(setup, world.sim().initialEstimate(), k0);
  Est ref = est;  // the core driven directly
  SimTelemetrySink tm;
  fw::AppConfig ac;
  ac.ticks_per_unit_a = float(world.sim().ticksA());
  ac.ticks_per_unit_b = float(world.sim().ticksB());
  ac.drive_id = PaperSim<D>::kSync ? 0 : 1;
  drivers::EncoderConfig ec;
  ec.max_ticks_per_s = 60000;  // about 3 m/s
  drivers::Lms2xxConfig lc;
  lc.baud = opt.baud;
  fw::App<Est> app(world.encoderA(), world.encoderB(), world.laserPort(), world.clock(), *store, tm, est,
                   ac, ec, lc);
  world.advanceTo(0);
  EXPECT_EQ(app.boot(), hal::Status::kOk);
  const std::uint64_t end_us = std::uint64_t(steps) * opt.step_us;
  int glitch_at = glitches > 0 ? steps / (glitches + 1) : -1;
  for (std::uint64_t t = 1000; t <= end_us; t += 1000) {
    world.advanceTo(t);
    if (glitch_at > 0 && int(world.steps().size()) == glitch_at && t % opt.step_us == 5000) {
      // A one-read glitch of 30000 ticks on the right wheel's counter.
      world.encoderA().glitchNextRead(30000);
      glitch_at += steps / (glitches + 1);
    }
    app.poll();
  }
  // The core driven directly with the same steps, up to the firmware's filter time.
  // Steps completed by the firmware's filter time (step k ends at (k + 1) * step_us).
  const std::size_t done = std::size_t(app.filterTimeUs() / opt.step_us);
  std::size_t next_scan = 0;
  const auto& scans = world.scanSteps();
  for (std::size_t k = 0; k < done && k < world.steps().size(); ++k) {
    const auto& st = world.steps()[k];
    float r[kMaxBeams];
    const bool has_scan = next_scan < scans.size() && scans[next_scan] == k;
    if (has_scan) {
      ++next_scan;
      for (int i = 0; i < cfg.laser.beams; ++i) r[i] = float(st.ranges[i]);
    }
    const auto u = convertInput<typename DriveT<float>::Input>(st.input);
    (void)ref.cycle(u, has_scan ? r : nullptr);
  }
  FwResult<DriveT> res;
  const int n = Est::Model::kStates;
  res.x.resize(n);
  res.sigma.resize(n);
  res.ref_x.resize(n);
  res.ref_sigma.resize(n);
  for (int i = 0; i < n; ++i) {
    res.x[i] = static_cast<double>(est.akf().state()[i]);
    res.sigma[i] = std::sqrt(double(est.akf().covariance()(i, i)));
    res.ref_x[i] = static_cast<double>(ref.akf().state()[i]);
    res.ref_sigma[i] = std::sqrt(double(ref.akf().covariance()(i, i)));
  }
  const auto& truth = world.steps()[done > 0 ? done - 1 : 0].truth;
  res.pos_err = std::hypot(res.x[0] - truth.x, res.x[1] - truth.y);
  res.pos_sigma = std::hypot(res.sigma[0], res.sigma[1]);
  res.health = app.health();
  res.lms = app.parser().counters();
  res.jumps = app.encoderA().counters().jumps_rejected + app.encoderB().counters().jumps_rejected;
  res.frames = tm.frames;
  return res;
}

template <template <typename> class DriveT>
void expectSameEstimates(const FwResult<DriveT>& r, double tol_sigma, const char* what) {
  // Systematic parameters: the firmware over wire bytes and wrapping counters against the
  // core fed directly.
  for (int i = 3; i < r.x.size(); ++i) {
    EXPECT_NEAR(r.x[i], r.ref_x[i], tol_sigma * r.ref_sigma[i]) << what << " state " << i;
  }
  EXPECT_LT(r.pos_err, 3.0 * r.pos_sigma + 0.01) << what;
}

}  // namespace

TEST(FirmwareApp, DiffOverHalSimulatorMatchesTheCoreDrivenDirectly) {
  Store store;
  const auto r = runFirmware<DiffDrive>(3, {}, 0, &store);
  EXPECT_GT(r.health.scans_fused, 280u) << "a scan every 10 cm over 30 m";
  EXPECT_EQ(r.health.scans_late, 0u);
  EXPECT_EQ(r.lms.bad_crc, 0u);
  EXPECT_GT(r.health.cycles, 2500u);
  expectSameEstimates(r, 0.5, "clean diff");
}

TEST(FirmwareApp, SyncOverHalSimulatorMatchesTheCoreDrivenDirectly) {
  Store store;
  const auto r = runFirmware<SyncDrive>(4, {}, 0, &store);
  EXPECT_GT(r.health.scans_fused, 280u);
  expectSameEstimates(r, 0.5, "clean sync");
}

TEST(FirmwareApp, OnePercentCorruptedLaserBytesStayWithinTwoSigma) {
  Store s1, s2;
  const auto clean = runFirmware<DiffDrive>(5, {}, 0, &s1);
  SerialFaults f;
  f.corrupt_probability = 0.01;
  f.seed = 77;
  const auto dirty = runFirmware<DiffDrive>(5, f, 0, &s2);
  EXPECT_GT(dirty.lms.bad_crc + dirty.lms.wrong_length + dirty.lms.truncated, 50u)
      << "about half of the 82-byte telegrams carry a corrupted byte";
  EXPECT_LT(dirty.health.scans_fused, clean.health.scans_fused);
  // The corrupted run fuses fewer than half of the scans, so its own (larger) sigma is the
  // yardstick: its estimates must lie within 2 of its sigmas of the clean run's. (This is
  // stricter than the sigma of the difference, sqrt(sd^2 + sc^2).)
  for (int i = 0; i < clean.x.size(); ++i) {
    double d = dirty.x[i] - clean.x[i];
    if (i == 2) d = wrapAngle(d);
    EXPECT_LT(std::abs(d), 2.0 * dirty.sigma[i]) << "state " << i;
  }
}

TEST(FirmwareApp, EncoderGlitchesAreRejectedAndCounted) {
  Store store;
  const auto r = runFirmware<DiffDrive>(6, {}, 5, &store);
  EXPECT_GE(r.jumps, 5u);
  EXPECT_LT(r.pos_err, 3.0 * r.pos_sigma + 0.01);
}

TEST(FirmwareApp, TelemetryFramesAreValid) {
  Store store;
  const auto r = runFirmware<DiffDrive>(7, {}, 0, &store, 600);
  ASSERT_GT(r.frames.size(), 40u);
  std::uint32_t last_cycle = 0;
  for (const auto& f : r.frames) {
    ASSERT_GE(f.size(), 6u);
    EXPECT_EQ(f[0], fw::kTelemetrySync0);
    EXPECT_EQ(f[1], fw::kTelemetrySync1);
    EXPECT_EQ(f[2], fw::kTelemetryState);
    ASSERT_EQ(std::size_t(f[3]) + 6, f.size());
    const std::uint16_t crc = fw::crc16Ccitt(f.data() + 2, f.size() - 4);
    EXPECT_EQ(crc, std::uint16_t(f[f.size() - 2] | (f[f.size() - 1] << 8)));
    const std::uint32_t cycle = fw::getU32(f.data() + 12);
    EXPECT_GT(cycle, last_cycle);
    last_cycle = cycle;
  }
  // The CRC catches a flipped bit.
  auto bad = r.frames.front();
  bad[10] ^= 0x04;
  EXPECT_NE(fw::crc16Ccitt(bad.data() + 2, bad.size() - 4),
            std::uint16_t(bad[bad.size() - 2] | (bad[bad.size() - 1] << 8)));
}

TEST(FirmwareApp, CalibrationSurvivesAReset) {
  Store store;
  const auto first = runFirmware<DiffDrive>(8, {}, 0, &store, 3100);  // saves at cycle 3000
  ASSERT_GE(first.health.saves_ok, 1u);
  drivers::CalibrationStore cs(store);
  drivers::Calibration c{};
  ASSERT_EQ(cs.load(&c), drivers::LoadResult::kRestored);
  EXPECT_EQ(c.count, 4);
  EXPECT_NEAR(c.value[0], 1.1, 0.03);
  // A new boot on the same flash restores it: the drive starts from the saved parameters.
  const auto second = runFirmware<DiffDrive>(9, {}, 0, &store, 50);
  EXPECT_EQ(second.health.calibration_restored, 1u);
  EXPECT_NEAR(second.x[3], c.value[0], 0.01);
  EXPECT_NEAR(second.x[4], c.value[1], 0.01);
  EXPECT_LT(second.sigma[3], 0.05) << "restored with its variance, not the 0.2 prior";
}

TEST(FirmwareApp, DroppedBytesAndScanDropoutsAreSurvived) {
  Store s1, s2;
  const auto clean = runFirmware<DiffDrive>(10, {}, 0, &s1);
  SerialFaults f;
  f.drop_probability = 0.002;
  f.seed = 5;
  WorldFaults wf;
  wf.scan_dropout = 0.2;
  const auto r = runFirmware<DiffDrive>(10, f, 0, &s2, 3000, wf);
  EXPECT_LT(r.health.scans_fused, clean.health.scans_fused * 9 / 10) << "a fifth of the scans never sent";
  EXPECT_GT(r.lms.wrong_length + r.lms.bad_crc + r.lms.truncated, 0u) << "dropped bytes break frames";
  for (int i = 3; i < clean.x.size(); ++i) {
    EXPECT_LT(std::abs(r.x[i] - clean.x[i]), 2.0 * clean.sigma[i]) << "parameter " << i;
  }
  EXPECT_LT(r.pos_err, 3.0 * r.pos_sigma + 0.01);
}

TEST(FirmwareApp, AStandingRobotStillFusesScans) {
  Store store;
  WorldFaults wf;
  wf.stand_after_steps = 200;  // 2 m, then 8 s standing still
  const auto r = runFirmware<DiffDrive>(11, {}, 0, &store, 1000, wf);
  // Scans keep coming every 100 ms and are fused although nothing moves: about 100 scans
  // (20 while driving 2 m, 80 while standing 8 s).
  EXPECT_GT(r.health.scans_fused, 90u);
  // Travel cycles (all cycles but the scan fusions): about 2 m / 1 cm, none while standing.
  EXPECT_LT(r.health.cycles - r.health.scans_fused, 230u) << "no travel cycles while standing";
  EXPECT_LT(r.pos_err, 3.0 * r.pos_sigma + 0.005) << "standing still, the pose stays right";
  // While standing the position sigma shrinks with every scan (no process noise).
  EXPECT_LT(r.pos_sigma, 0.004);
}

TEST(FirmwareApp, AScanOfTheWrongSizeIsCountedNotFused) {
  // The simulator sends 36-value telegrams; a firmware configured for 18 beams must drop
  // every one of them and count it (never fuse a scan it cannot interpret).
  using Est = fw::PaperTypes<float, DiffDrive>::EstimatorT;
  SimConfig cfg;
  cfg.radius = 4.5;
  HalSimDrive<DiffDrive<double>> world(cfg, 12, {});
  fw::FilterSetup setup;
  setup.laser.beams = 18;
  setup.laser.angle_inc *= 2;
  const DiffDrive<float>::NonSysVec k0 = world.sim().trueNonSys().cast<float>();
  Est est = fw::makePaperEstimator<float, DiffDrive>(setup, world.sim().initialEstimate(), k0);
  Store store;
  SimTelemetrySink tm;
  fw::AppConfig ac;
  ac.ticks_per_unit_a = float(world.sim().ticksA());
  ac.ticks_per_unit_b = float(world.sim().ticksB());
  drivers::EncoderConfig ec;
  ec.max_ticks_per_s = 60000;
  fw::App<Est> app(world.encoderA(), world.encoderB(), world.laserPort(), world.clock(), store, tm, est, ac, ec, {});
  world.advanceTo(0);
  ASSERT_EQ(app.boot(), hal::Status::kOk);
  for (std::uint64_t t = 1000; t <= 5000000; t += 1000) {  // 5 s, 5 m
    world.advanceTo(t);
    app.poll();
  }
  EXPECT_EQ(app.health().scans_fused, 0u);
  EXPECT_GE(app.health().scans_wrong_size, 45u) << "a scan every 100 ms for 5 s: about 50";
  EXPECT_GT(app.health().cycles, 400u) << "odometry cycles go on";
}

// The firmware under faults, counted (issue 16, part 4; docs/reliability.md, "The firmware
// under faults"). Each test is one long simulated drive (tests/firmware_faults.hpp) with a
// fault injected at a known rate; it prints one row of injected / detected / recovered and
// fails when a fault is silently accepted, crashes the firmware (non-finite estimate) or is
// not recovered from.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <random>

#include "firmware_faults.hpp"

using namespace odoerr;
using namespace odoerr::faults;

namespace {

void row(const char* kind, const char* injected, const char* detected, const char* recovered) {
  std::printf("FAULTROW | %s | %s | %s | %s |\n", kind, injected, detected, recovered);
}

/// The estimate at the end of the drive is finite and within 3 sigma (+1 cm) of the truth.
void expectRecoveredEstimate(const FaultOutcome& o, const char* what) {
  EXPECT_TRUE(o.finite) << what;
  EXPECT_LT(o.pos_err, 3.0 * o.pos_sigma + 0.01) << what << ": position error " << o.pos_err << " m, sigma "
                                                  << o.pos_sigma;
}

void serialRun(bool drop, double rate, std::uint64_t seed) {
  FaultPlan plan;
  plan.seed = seed;
  plan.steps = 30000;  // 300 m, 3000 telegrams of 82 bytes
  (drop ? plan.serial.drop_probability : plan.serial.corrupt_probability) = rate;
  plan.serial.seed = seed * 7 + 1;
  const FaultOutcome o = runFaults(plan);
  const std::size_t spans = o.lms.bad_crc + o.lms.truncated + o.lms.wrong_length;
  char kind[64], inj[160], det[200], rec[200];
  std::snprintf(kind, sizeof kind, "laser line, %s %.0e/byte", drop ? "byte drops" : "bit errors", rate);
  std::snprintf(inj, sizeof inj, "%zu bytes in %zu of %zu telegrams", o.bytes_hit, o.telegrams_hit, o.telegrams);
  std::snprintf(det, sizeof det, "%zu of %zu refused by the parser (%zu rejected spans: %u CRC, %u truncated, "
                "%u length); %zu passed the CRC damaged: %zu beams off by >= 1 m (gated), %zu by <= 3 cm, %zu NaN",
                o.telegrams_hit - o.accepted_hit - o.accepted_unknown, o.telegrams_hit, spans, o.lms.bad_crc,
                o.lms.truncated, o.lms.wrong_length, o.accepted_unknown, o.escaped_beams_large,
                o.escaped_beams_small, o.escaped_beams_nan);
  std::snprintf(rec, sizeof rec, "next intact telegram accepted after %zu of %zu; intact telegrams lost: %zu; "
                "pose error %.1f mm (sigma %.1f)", o.hit_recovered, o.telegrams_hit - o.hit_last, o.clean_lost,
                1e3 * o.pos_err, 1e3 * o.pos_sigma);
  row(kind, inj, det, rec);
  EXPECT_GT(o.telegrams_hit, 0u) << "the fault was injected";
  EXPECT_EQ(o.accepted_hit, 0u) << "a damaged telegram was accepted";
  // The LMS2xx vendor CRC16 lets some two-byte errors through (at 1e-2, 3 of the about 600
  // telegrams with two or more damaged bytes). Nothing it lets through may be of a size the
  // filter could fuse unnoticed: a range off by >= 1 m is far beyond the NIS gate (5 sigma of
  // the innovation, under 0.2 m here) and is refused and counted there; one off by <= 3 cm is
  // within the range noise.
  EXPECT_EQ(o.escaped_beams_mid, 0u) << "a damaged range between 3 cm and 1 m passed the CRC";
  EXPECT_LT(o.accepted_unknown * 100, o.telegrams_hit + 100) << "CRC escapes well under 1 % of damaged telegrams";
  EXPECT_GE(spans, 1u);
  EXPECT_EQ(o.hit_recovered, o.telegrams_hit - o.hit_last) << "the parser resynchronises on the next intact telegram";
  EXPECT_EQ(o.clean_lost, 0u) << "an intact telegram was lost with a damaged one";
  expectRecoveredEstimate(o, kind);
}

}  // namespace

TEST(FirmwareFaults, NoFaultsNoAlarms) {
  FaultPlan plan;
  plan.seed = 3;
  const FaultOutcome o = runFaults(plan);
  row("none (10000 steps, 100 m)", "0", "0 alarms", "-");
  EXPECT_EQ(o.lms.bad_crc + o.lms.truncated + o.lms.wrong_length, 0u);
  EXPECT_EQ(o.enc_a.jumps_rejected + o.enc_b.jumps_rejected, 0u);
  EXPECT_EQ(o.health.laser_silences, 0u);
  EXPECT_EQ(o.health.clock_stalls, 0u);
  EXPECT_EQ(o.health.clock_backwards, 0u);
  EXPECT_GE(o.accepted + 1, o.telegrams) << "every telegram but the last (in flight at the end) accepted";
  EXPECT_EQ(o.fw_a, o.true_a) << "16-bit counters, wrapped " << o.wraps << " times, integrated exactly";
  EXPECT_EQ(o.fw_b, o.true_b);
  EXPECT_GT(o.wraps, 30);
  expectRecoveredEstimate(o, "no faults");
}

TEST(FirmwareFaults, LaserBitErrors1e4) { serialRun(false, 1e-4, 21); }
TEST(FirmwareFaults, LaserBitErrors1e3) { serialRun(false, 1e-3, 22); }
TEST(FirmwareFaults, LaserBitErrors1e2) { serialRun(false, 1e-2, 23); }
TEST(FirmwareFaults, LaserByteDrops1e4) { serialRun(true, 1e-4, 24); }
TEST(FirmwareFaults, LaserByteDrops1e3) { serialRun(true, 1e-3, 25); }
TEST(FirmwareFaults, LaserByteDrops1e2) { serialRun(true, 1e-2, 26); }

TEST(FirmwareFaults, EncoderGlitchesJumpsAndWraps) {
  FaultPlan plan;
  plan.seed = 31;
  plan.steps = 20000;  // 200 m
  for (int k = 1; k <= 20; ++k) plan.glitch_steps.push_back(k * 450);         // one-read, +/-30000 ticks
  for (int k = 1; k <= 20; ++k) plan.jump_steps.push_back(10000 + k * 450);   // lasting, +5000 ticks
  const FaultOutcome o = runFaults(plan);
  const std::uint32_t rejected = o.enc_a.jumps_rejected + o.enc_b.jumps_rejected;
  const std::int64_t lost = std::abs(o.true_a - o.fw_a) + std::abs(o.true_b - o.fw_b);
  char inj[160], det[160], rec[200];
  std::snprintf(inj, sizeof inj, "20 one-read glitches of +/-30000 ticks, 20 lasting jumps of +5000 ticks; "
                "%lld wraps of the 16-bit counters", static_cast<long long>(o.wraps));
  std::snprintf(det, sizeof det, "%u samples rejected (2 per glitch: out and back; 1 per jump)", rejected);
  std::snprintf(rec, sizeof rec, "ticks lost against the true count: %lld (the rejected samples' motion); "
                "pose error %.1f mm (sigma %.1f)", static_cast<long long>(lost), 1e3 * o.pos_err, 1e3 * o.pos_sigma);
  row("encoder jumps and wraps", inj, det, rec);
  EXPECT_EQ(rejected, 2u * 20u + 20u) << "every glitch and jump rejected";
  // The wheel moves about 13 ticks a 1 ms sample: what the rejected samples carried is lost.
  EXPECT_LE(lost, std::int64_t(rejected) * 20) << "nothing but the rejected samples' motion is lost";
  EXPECT_GT(o.wraps, 60);
  expectRecoveredEstimate(o, "encoder faults");
}

TEST(FirmwareFaults, LaserThatStops) {
  for (const int silent_steps : {100, 500, 2000}) {  // 1 s, 5 s, 20 s
    FaultPlan plan;
    plan.seed = 41 + std::uint64_t(silent_steps);
    plan.steps = 6000 + silent_steps;
    plan.laser_silent_from = 3000;
    plan.laser_silent_steps = silent_steps;
    plan.probe_step = 3000 + silent_steps;
    const FaultOutcome o = runFaults(plan);
    std::printf("silence %d: at its end pos err %.1f mm sigma %.1f, heading err %.2f deg sigma %.2f, K_w %.2f x truth\n",
                silent_steps, 1e3 * o.probe_err, 1e3 * o.probe_sigma, o.probe_head_err * 57.3,
                o.probe_head_sigma * 57.3, o.probe_k_ratio);
    char kind[80], inj[120], det[120], rec[160];
    std::snprintf(kind, sizeof kind, "laser stops for %.0f s", silent_steps / 100.0);
    std::snprintf(inj, sizeof inj, "1 silence (%d scans not sent)", silent_steps / 10);
    std::snprintf(det, sizeof det, "%u silence counted (after 0.5 s without a scan)", o.health.laser_silences);
    std::snprintf(rec, sizeof rec, "%u scans fused of %zu sent; pose error %.1f mm (sigma %.1f) 30 m after",
                  o.health.scans_fused, o.telegrams, 1e3 * o.pos_err, 1e3 * o.pos_sigma);
    row(kind, inj, det, rec);
    EXPECT_EQ(o.health.laser_silences, 1u) << kind;
    EXPECT_GE(o.health.scans_fused + 2, o.telegrams) << kind << ": the scans after the silence are fused";
    EXPECT_TRUE(o.finite) << kind;
    // After 1 s and 5 s the scans bring the estimate back. After 20 s of odometry alone the
    // error (1.5 m) is beyond what a single-hypothesis filter can re-acquire in this room: it
    // locks onto a wrong pose (docs/reliability.md); that row is reported, not asserted.
    if (silent_steps <= 500) expectRecoveredEstimate(o, kind);
  }
}

TEST(FirmwareFaults, ClockThatStalls) {
  FaultPlan plan;
  plan.seed = 51;
  plan.steps = 12000;
  // 20 ms, 100 ms, 1 s and 5 s, 20 s apart; the firmware's clock then jumps to the true time.
  const std::uint64_t len[] = {20000, 100000, 1000000, 5000000};
  std::uint64_t t = 20000000;
  for (const std::uint64_t l : len) {
    plan.stalls.push_back({t, t + l});
    t += 20000000;
  }
  const FaultOutcome o = runFaults(plan);
  char det[200], rec[200];
  std::snprintf(det, sizeof det, "%u stalls counted (clock unchanged over 10 polls); %u encoder samples "
                "dropped from the full queue", o.health.clock_stalls, o.health.samples_dropped);
  std::snprintf(rec, sizeof rec, "%u scans fused of %zu sent; ticks lost %lld; pose error %.1f mm (sigma %.1f)",
                o.health.scans_fused, o.telegrams,
                static_cast<long long>(std::abs(o.true_a - o.fw_a) + std::abs(o.true_b - o.fw_b)), 1e3 * o.pos_err,
                1e3 * o.pos_sigma);
  row("clock stalls", "4 stalls: 0.02, 0.1, 1 and 5 s", det, rec);
  EXPECT_EQ(o.health.clock_stalls, 4u);
  EXPECT_EQ(o.fw_a, o.true_a) << "no tick lost while the clock stood";
  EXPECT_EQ(o.fw_b, o.true_b);
  expectRecoveredEstimate(o, "clock stalls");
}

TEST(FirmwareFaults, PowerLossDuringCalibrationSave) {
  // 200 boots on one flash. Each boot drives 1 m with a save every 50 cycles; at every
  // other boot the power fails at a random byte-operation of its first save (the boot
  // ends there, as the MCU does). The next boot must restore the last record that was
  // completely written, bit for bit.
  Store store;
  std::mt19937_64 rng(61);
  drivers::CalibrationStore probe(store);  // reads only: what a boot would restore
  drivers::Calibration last_good{};
  bool have_good = false;
  int injected = 0, detected_at_save = 0, recovered = 0, boots_restored = 0, torn_seen = 0;
  for (int boot = 0; boot < 200; ++boot) {
    sim::SimConfig cfg;
    cfg.radius = 4.5;
    sim::HalSimDrive<D> world(cfg, 1000 + std::uint64_t(boot), {});
    fw::FilterSetup setup;
    const DiffDrive<float>::NonSysVec k0 = world.sim().trueNonSys().cast<float>();
    Est est = fw::makePaperEstimator<float, DiffDrive>(setup, world.sim().initialEstimate(), k0);
    sim::SimTelemetrySink tm;
    fw::AppConfig ac;
    ac.ticks_per_unit_a = float(world.sim().ticksA());
    ac.ticks_per_unit_b = float(world.sim().ticksB());
    ac.save_every = 50;
    drivers::EncoderConfig ec;
    ec.max_ticks_per_s = 60000;
    fw::App<Est> app(world.encoderA(), world.encoderB(), world.laserPort(), world.clock(), store, tm, est, ac, ec,
                     {});
    world.advanceTo(0);
    ASSERT_EQ(app.boot(), hal::Status::kOk);
    torn_seen += int(app.calibration().counters().slots_invalid_at_boot);
    if (have_good) {
      ++boots_restored;
      // What this boot restored is the last complete record.
      drivers::Calibration now{};
      ASSERT_EQ(probe.load(&now), drivers::LoadResult::kRestored) << "boot " << boot;
      EXPECT_EQ(app.health().calibration_restored, 1u) << "boot " << boot;
      if (std::memcmp(&now, &last_good, sizeof now) == 0) ++recovered;
    }
    const bool cut = boot % 2 == 1;
    if (cut) {
      std::uniform_int_distribution<std::size_t> k(0, 81);  // an erase + 81 programmed bytes
      store.powerLossAfter(k(rng));
      ++injected;
    }
    for (std::uint64_t t = 1000; t <= 1000000 && app.health().saves_failed == 0; t += 1000) {
      world.advanceTo(t);
      app.poll();
    }
    if (cut) {
      detected_at_save += int(app.health().saves_failed);
      store.powerOn();  // the reboot
    }
    drivers::Calibration c{};
    if (app.health().saves_ok > 0 && probe.load(&c) == drivers::LoadResult::kRestored) {
      // the newest complete record (a cut save leaves the previous one, or completed)
      last_good = c;
      have_good = true;
    }
  }
  char inj[80], det[160], rec[160];
  std::snprintf(inj, sizeof inj, "%d power losses, at a random byte of a save", injected);
  std::snprintf(det, sizeof det, "%d saves failed (counted saves_failed); %d torn slots counted at the next boots",
                detected_at_save, torn_seen);
  std::snprintf(rec, sizeof rec, "%d of %d boots restored the last complete record bit for bit", recovered,
                boots_restored);
  row("power loss during a calibration save", inj, det, rec);
  EXPECT_EQ(injected, 100);
  EXPECT_EQ(detected_at_save, injected) << "every cut save reported failed";
  EXPECT_EQ(recovered, boots_restored);
  EXPECT_GT(torn_seen, 0) << "some cuts leave a torn slot, which the boot counts";
}

TEST(FirmwareFaults, ClockSetBackIsHeldAndCounted) {
  FaultPlan plan;
  plan.seed = 71;
  plan.steps = 3000;
  plan.setback_at_us = 10000000;
  plan.setback_by_us = 50000;  // 50 ms back at 10 s: 50 polls read less than before
  const FaultOutcome o = runFaults(plan);
  char det[120];
  std::snprintf(det, sizeof det, "%u polls counted (clock_backwards), their time held at the last reading",
                o.health.clock_backwards);
  row("clock set back", "once, by 50 ms", det, o.pos_err < 3 * o.pos_sigma + 0.01 ? "yes" : "no");
  EXPECT_GE(o.health.clock_backwards, 49u);
  EXPECT_LE(o.health.clock_backwards, 50u);
  EXPECT_EQ(o.fw_a, o.true_a) << "no tick lost";
  expectRecoveredEstimate(o, "clock set back");
}

TEST(FirmwareFaults, CalibrationOfAnotherDriveIsCountedNotUsed) {
  drivers::Calibration sync_cal{};
  sync_cal.drive = 0;  // a sync drive's record in a diff drive's flash
  sync_cal.count = 4;
  for (int i = 0; i < 4; ++i) {
    sync_cal.value[i] = 1.0f;
    sync_cal.variance[i] = 0.01f;
  }
  FaultPlan plan;
  plan.seed = 72;
  plan.steps = 200;
  plan.stored = &sync_cal;
  const FaultOutcome o = runFaults(plan);
  row("a stored calibration of another drive", "1 record (drive 0 in a diff drive)",
      o.health.calibration_foreign == 1 ? "1 counted (calibration_foreign)" : "not counted", "the priors kept");
  EXPECT_EQ(o.health.calibration_foreign, 1u);
  EXPECT_EQ(o.health.calibration_restored, 0u);
}

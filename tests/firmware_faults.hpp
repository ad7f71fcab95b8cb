// The firmware application (fw/app.hpp) over the HAL simulator with faults injected at
// known rates (issue 16, part 4): one long drive per fault kind, and the figures of what
// was injected, what the firmware counted and whether it recovered. The table in
// docs/reliability.md ("The firmware under faults") is this run's output.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <vector>

#include "odoerr/fw/app.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/hal/fake_param_store.hpp"
#include "odoerr/sim/hal_sim.hpp"

namespace odoerr::faults {

using Store = hal::FakeParamStore<4096, 1024>;
using Est = fw::PaperTypes<float, DiffDrive>::EstimatorT;
using D = DiffDrive<double>;

/// The laser's port as the firmware reads it, every byte it read recorded in read order.
class TapPort final : public hal::SerialPort {
 public:
  explicit TapPort(hal::SerialPort& inner) : inner_(inner) {}
  std::vector<std::vector<std::uint8_t>> chunks;

 private:
  hal::Status DoRead(std::uint8_t* buf, std::size_t capacity, std::size_t* n_read) override {
    const hal::Status s = inner_.read(buf, capacity, n_read);
    if (*n_read > 0) chunks.emplace_back(buf, buf + *n_read);
    return s;
  }
  hal::Status DoWrite(const std::uint8_t* d, std::size_t n, std::size_t* w) override { return inner_.write(d, n, w); }
  hal::SerialPort& inner_;
};

struct FaultPlan {
  std::uint64_t seed = 1;
  int steps = 10000;                    ///< 1 cm each, 10 ms each: 100 m, 100 s
  sim::SerialFaults serial{};
  std::vector<int> glitch_steps;        ///< one-read glitches (+/- glitch_ticks) at these steps
  std::int64_t glitch_ticks = 30000;
  std::vector<int> jump_steps;          ///< lasting jumps of jump_ticks at these steps
  std::int64_t jump_ticks = 5000;
  int laser_silent_from = -1, laser_silent_steps = 0;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> stalls;  ///< clock stalls [from, until) us
  int probe_step = -1;                  ///< >= 0: the estimate's error is also taken there
  std::uint64_t setback_at_us = 0, setback_by_us = 0;  ///< the clock set back once
  const drivers::Calibration* stored = nullptr;        ///< saved in the flash before boot
};

struct FaultOutcome {
  fw::AppHealth health{};
  drivers::Lms2xxCounters lms{};
  drivers::EncoderCounters enc_a{}, enc_b{};
  // serial line, per telegram
  std::size_t telegrams = 0, telegrams_hit = 0, bytes_hit = 0;
  std::size_t accepted = 0, accepted_hit = 0;  ///< accepted_hit: a damaged telegram decoded as sent
  std::size_t accepted_unknown = 0;     ///< scans no telegram sent: damage the CRC let through
  // their beams that differ from the nearest telegram sent, by the size of the damage:
  std::size_t escaped_beams_nan = 0;    ///< became "no return" (counted by the filter)
  std::size_t escaped_beams_large = 0;  ///< off by >= 1 m: far beyond the NIS gate (5 sigma, < 0.2 m)
  std::size_t escaped_beams_small = 0;  ///< off by <= 3 cm (one range sigma): within the noise
  std::size_t escaped_beams_mid = 0;    ///< in between: could be fused unnoticed
  std::size_t clean_lost = 0;          ///< intact telegrams the parser did not accept (collateral)
  std::size_t hit_recovered = 0;       ///< hit telegrams whose next intact telegram was accepted
  std::size_t hit_last = 0;            ///< hit telegrams with no intact telegram after them
  // encoders
  std::int64_t true_a = 0, true_b = 0, fw_a = 0, fw_b = 0;  ///< cumulative ticks at the end
  std::int64_t wraps = 0;              ///< 16-bit counter wraps over the drive (both wheels)
  // estimate at the end (and at the probe step)
  double pos_err = 0, pos_sigma = 0;
  double probe_err = 0, probe_sigma = 0, probe_head_err = 0, probe_head_sigma = 0;
  double probe_k_ratio = 0;             ///< the OF's K_w over the truth at the probe
  bool finite = true;
};

inline std::vector<float> decodeRanges(drivers::Lms2xxParser& p) {
  float r[drivers::Lms2xxParser::kMaxValues];
  drivers::Lms2xxScanInfo info;
  if (!hal::ok(p.takeScan(r, drivers::Lms2xxParser::kMaxValues, &info))) return {};
  return std::vector<float>(r, r + info.count);
}

inline FaultOutcome runFaults(const FaultPlan& plan) {
  sim::SimConfig cfg;
  cfg.radius = 4.5;  // 50 cm clear of the walls (as tests/test_firmware_app.cpp)
  sim::HalSimDrive<D>::Options opt;
  opt.faults = plan.serial;
  opt.laser_silent_from_step = plan.laser_silent_from;
  opt.laser_silent_steps = plan.laser_silent_steps;
  sim::HalSimDrive<D> world(cfg, plan.seed, opt);
  sim::StallingClock clock(world.clock());
  for (const auto& s : plan.stalls) clock.addStall(s.first, s.second);
  if (plan.setback_by_us > 0) clock.setBack(plan.setback_at_us, plan.setback_by_us);
  TapPort port(world.laserPort());
  fw::FilterSetup setup;
  const DiffDrive<float>::NonSysVec k0 = world.sim().trueNonSys().cast<float>();
  Est est = fw::makePaperEstimator<float, DiffDrive>(setup, world.sim().initialEstimate(), k0);
  Store store;
  if (plan.stored != nullptr) {
    drivers::CalibrationStore cs(store);
    (void)cs.save(*plan.stored);
  }
  sim::SimTelemetrySink tm;
  fw::AppConfig ac;
  ac.ticks_per_unit_a = float(world.sim().ticksA());
  ac.ticks_per_unit_b = float(world.sim().ticksB());
  drivers::EncoderConfig ec;
  ec.max_ticks_per_s = 60000;  // about 3 m/s
  drivers::Lms2xxConfig lc;
  lc.baud = opt.baud;
  fw::App<Est> app(world.encoderA(), world.encoderB(), port, clock, store, tm, est, ac, ec, lc);
  world.advanceTo(0);
  (void)app.boot();
  std::size_t next_glitch = 0, next_jump = 0;
  int sign = 1;
  double probe[5] = {0, 0, 0, 0, 0};
  const std::uint64_t end_us = std::uint64_t(plan.steps) * opt.step_us;
  for (std::uint64_t t = 1000; t <= end_us; t += 1000) {
    world.advanceTo(t);
    const int step = int(world.steps().size());
    if (next_glitch < plan.glitch_steps.size() && step >= plan.glitch_steps[next_glitch] && t % opt.step_us == 5000) {
      ((next_glitch % 2) ? world.encoderB() : world.encoderA()).glitchNextRead(sign * plan.glitch_ticks);
      sign = -sign;
      ++next_glitch;
    }
    if (next_jump < plan.jump_steps.size() && step >= plan.jump_steps[next_jump] && t % opt.step_us == 5000) {
      ((next_jump % 2) ? world.encoderB() : world.encoderA()).jump(plan.jump_ticks);
      ++next_jump;
    }
    app.poll();
    if (plan.probe_step >= 0 && step == plan.probe_step && t % opt.step_us == 0) {
      const std::size_t done = std::size_t(app.filterTimeUs() / opt.step_us);
      const auto& tr = world.steps()[done > 0 ? done - 1 : 0].truth;
      const auto& x = est.akf().state();
      const auto& p = est.akf().covariance();
      probe[0] = std::hypot(double(x[0]) - tr.x, double(x[1]) - tr.y);
      probe[1] = std::sqrt(double(p(0, 0) + p(1, 1)));
      probe[2] = std::abs(wrapAngle(double(x[2]) - tr.theta));
      probe[3] = std::sqrt(double(p(2, 2)));
      probe[4] = double(est.of().estimate()[0]) / world.sim().trueNonSys()[0];
    }
  }
  FaultOutcome o;
  o.probe_err = probe[0];
  o.probe_sigma = probe[1];
  o.probe_head_err = probe[2];
  o.probe_head_sigma = probe[3];
  o.probe_k_ratio = probe[4];
  o.health = app.health();
  o.lms = app.parser().counters();
  o.enc_a = app.encoderA().counters();
  o.enc_b = app.encoderB().counters();

  // The telegrams sent, decoded clean, against what a parser accepts from the bytes the
  // firmware read (the same parser, so the same decisions as the firmware's own).
  std::map<std::vector<float>, std::size_t> index;  // clean ranges -> telegram
  const auto& scans = world.scanSteps();
  const auto& hits = world.scanFaults();
  drivers::Lms2xxParser ref(lc);
  for (std::size_t i = 0; i < scans.size(); ++i) {
    std::uint8_t frame[1024];
    const std::size_t n =
        sim::encodeLms2xxScan(world.steps()[scans[i]].ranges.data(), cfg.laser.beams, false, frame, sizeof frame);
    ref.feed(frame, n, 0);
    index.emplace(decodeRanges(ref), i);
    o.telegrams_hit += hits[i] > 0 ? 1 : 0;
    o.bytes_hit += hits[i];
  }
  o.telegrams = scans.size();
  std::set<std::size_t> accepted;
  drivers::Lms2xxParser tap(lc);
  for (const auto& c : port.chunks) {
    tap.feed(c.data(), c.size(), 0);
    if (!tap.scanAvailable()) continue;
    const auto r = decodeRanges(tap);
    ++o.accepted;
    const auto it = index.find(r);
    if (it == index.end()) {
      ++o.accepted_unknown;
      // The nearest telegram sent, and how far the damaged beams are from it.
      const std::vector<float>* nearest = nullptr;
      double best = 1e300;
      for (const auto& kv : index) {
        double d = 0;
        for (std::size_t q = 0; q < r.size() && q < kv.first.size(); ++q) {
          const bool na = std::isnan(r[q]), nb = std::isnan(kv.first[q]);
          d += na != nb ? 100.0 : (na ? 0.0 : std::abs(double(r[q]) - double(kv.first[q])));
        }
        if (d < best) {
          best = d;
          nearest = &kv.first;
        }
      }
      for (std::size_t q = 0; nearest != nullptr && q < r.size() && q < nearest->size(); ++q) {
        const double a = static_cast<double>(r[q]), b = static_cast<double>((*nearest)[q]);
        if (a == b || (std::isnan(a) && std::isnan(b))) continue;
        const double e = std::isnan(a) || std::isnan(b) ? 0.0 : std::abs(a - b);
        if (std::isnan(a)) {
          ++o.escaped_beams_nan;
        } else if (std::isnan(b) || e >= 1.0) {
          ++o.escaped_beams_large;
        } else if (e <= 0.03) {
          ++o.escaped_beams_small;
        } else {
          ++o.escaped_beams_mid;
        }
      }
    } else {
      accepted.insert(it->second);
      if (hits[it->second] > 0) ++o.accepted_hit;
    }
  }
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (hits[i] == 0) {
      if (accepted.count(i) == 0 && i + 1 < scans.size()) ++o.clean_lost;  // the last may be in flight
      continue;
    }
    std::size_t j = i + 1;
    while (j < scans.size() && hits[j] > 0) ++j;
    if (j + 1 >= scans.size()) {
      ++o.hit_last;
    } else if (accepted.count(j) > 0) {
      ++o.hit_recovered;
    }
  }

  // Encoders: the firmware's integrated ticks against the truth at the last sample.
  o.true_a = world.encoderA().trueCount();
  o.true_b = world.encoderB().trueCount();
  o.fw_a = app.countA();
  o.fw_b = app.countB();
  o.wraps = std::abs(o.true_a) / 65536 + std::abs(o.true_b) / 65536;
  // (a clock set back leaves the firmware's time that much behind the world's)
  const std::size_t done = std::size_t((app.filterTimeUs() + plan.setback_by_us) / opt.step_us);
  const auto& truth = world.steps()[done > 0 ? done - 1 : 0].truth;
  const auto& x = est.akf().state();
  const auto& p = est.akf().covariance();
  o.finite = x.allFinite() && p.allFinite();
  o.pos_err = std::hypot(double(x[0]) - truth.x, double(x[1]) - truth.y);
  o.pos_sigma = std::sqrt(double(p(0, 0) + p(1, 1)));
  return o;
}

}  // namespace odoerr::faults

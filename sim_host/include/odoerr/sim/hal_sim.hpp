// sim_host: the HAL simulator. Every HAL interface implemented over the simulated truth of
// the paper's drive, so that the production firmware (fw/app.hpp) and its drivers run
// unchanged on the host:
//  - SimEncoderCounter: the hardware count of a 16- or 32-bit counter (wraps), moving
//    continuously within a simulator step; one-read glitches and lasting jumps can be
//    injected;
//  - SimSerialPort: the laser's real wire bytes (SICK LMS2xx 0xB0 telegrams) arriving at
//    the baud rate after the scan, with corrupted or dropped bytes injectable;
//  - HalSimDrive: the drive itself, with scan dropouts, a robot that stops and a laser
//    that falls silent injectable; it records which telegrams the line corrupted;
//  - SimClock, StallingClock (a clock that stops, then catches up), SimTelemetrySink;
//    the parameter store is hal::FakeParamStore.
// Host-only (uses the heap for queues); the firmware under test does not.
#pragma once

#include <cstdint>
#include <deque>
#include <random>
#include <utility>
#include <vector>

#include "odoerr/hal/clock.hpp"
#include "odoerr/hal/encoder_counter.hpp"
#include "odoerr/hal/serial_port.hpp"
#include "odoerr/hal/telemetry_sink.hpp"
#include "odoerr/sim/lms2xx_writer.hpp"
#include "odoerr/sim/paper_sim.hpp"
#include "odoerr/sim/random.hpp"

namespace odoerr::sim {

class SimClock final : public hal::Clock {
 public:
  void set(std::uint64_t us) { now_ = us; }

 private:
  std::uint64_t DoNowUs() const override { return now_; }
  std::uint64_t now_ = 0;
};

/// The firmware's view of a clock that stalls: the world's time, except that during each
/// stall [from_us, until_us) it stays at from_us; afterwards it jumps to the world's time.
class StallingClock final : public hal::Clock {
 public:
  explicit StallingClock(const hal::Clock& world) : world_(world) {}
  void addStall(std::uint64_t from_us, std::uint64_t until_us) { stalls_.push_back({from_us, until_us}); }
  /// From at_us on the clock reads by_us less (a clock set back).
  void setBack(std::uint64_t at_us, std::uint64_t by_us) {
    back_at_ = at_us;
    back_by_ = by_us;
  }

 private:
  std::uint64_t DoNowUs() const override {
    std::uint64_t t = world_.nowUs();
    for (const auto& s : stalls_) {
      if (t >= s.first && t < s.second) t = s.first;
    }
    return back_by_ > 0 && t >= back_at_ ? t - back_by_ : t;
  }
  const hal::Clock& world_;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> stalls_;
  std::uint64_t back_at_ = 0;
  std::uint64_t back_by_ = 0;
};

class SimEncoderCounter final : public hal::EncoderCounter {
 public:
  explicit SimEncoderCounter(std::uint8_t bits) : bits_(bits) {}
  /// The true cumulative count (unwrapped).
  void set(std::int64_t count) { count_ = count; }
  /// The next read returns garbage offset by `ticks` (a one-read glitch).
  void glitchNextRead(std::int64_t ticks) { glitch_ = ticks; }
  /// From now on every read is offset by `ticks` more (a counter that skipped or was reset).
  void jump(std::int64_t ticks) { offset_ += ticks; }
  /// The true cumulative count (no glitch, no jump).
  std::int64_t trueCount() const { return count_; }

 private:
  hal::Status DoRead(std::uint32_t* c) override {
    const std::uint64_t raw = static_cast<std::uint64_t>(count_ + offset_ + glitch_);
    glitch_ = 0;
    *c = static_cast<std::uint32_t>(bits_ >= 32 ? raw : (raw & ((1ull << bits_) - 1)));
    return hal::Status::kOk;
  }
  std::uint8_t DoBits() const override { return bits_; }
  std::uint8_t bits_;
  std::int64_t count_ = 0;
  std::int64_t glitch_ = 0;
  std::int64_t offset_ = 0;
};

struct SerialFaults {
  double corrupt_probability = 0.0;  ///< per byte: one random bit flipped
  double drop_probability = 0.0;     ///< per byte: lost on the line
  std::uint64_t seed = 99;
};

class SimSerialPort final : public hal::SerialPort {
 public:
  SimSerialPort(const SimClock& clock, std::uint32_t baud, const SerialFaults& faults)
      : clock_(clock), baud_(baud), faults_(faults), rng_(faults.seed) {}

  /// Sends bytes that start leaving the device at t_us, back to back at the baud rate.
  /// Returns the number of bytes the line dropped or corrupted.
  std::size_t transmit(const std::uint8_t* data, std::size_t n, std::uint64_t t_us) {
    const std::uint64_t before = dropped_ + corrupted_;
    odoerr::sim::UniformDist<double> u(0.0, 1.0);
    std::uniform_int_distribution<int> bit(0, 7);
    std::uint64_t t = std::max(t_us, line_free_us_);
    for (std::size_t i = 0; i < n; ++i) {
      t += byteTimeUs();
      std::uint8_t b = data[i];
      if (u(rng_) < faults_.drop_probability) {
        ++dropped_;
        continue;
      }
      if (u(rng_) < faults_.corrupt_probability) {
        b = static_cast<std::uint8_t>(b ^ (1u << bit(rng_)));
        ++corrupted_;
      }
      rx_.push_back({t, b});
    }
    line_free_us_ = t;
    return static_cast<std::size_t>(dropped_ + corrupted_ - before);
  }
  std::uint64_t byteTimeUs() const { return (10ull * 1000000ull + baud_ - 1) / baud_; }
  std::uint64_t corrupted() const { return corrupted_; }
  std::uint64_t dropped() const { return dropped_; }

 private:
  struct Byte {
    std::uint64_t t;
    std::uint8_t b;
  };
  hal::Status DoRead(std::uint8_t* buf, std::size_t capacity, std::size_t* n_read) override {
    const std::uint64_t now = clock_.nowUs();
    while (*n_read < capacity && !rx_.empty() && rx_.front().t <= now) {
      buf[(*n_read)++] = rx_.front().b;
      rx_.pop_front();
    }
    return hal::Status::kOk;
  }
  hal::Status DoWrite(const std::uint8_t*, std::size_t n, std::size_t* n_written) override {
    *n_written = n;  // commands to the scanner are not modelled
    return hal::Status::kOk;
  }
  const SimClock& clock_;
  std::uint32_t baud_;
  SerialFaults faults_;
  std::mt19937_64 rng_;
  std::deque<Byte> rx_;
  std::uint64_t line_free_us_ = 0;
  std::uint64_t corrupted_ = 0;
  std::uint64_t dropped_ = 0;
};

class SimTelemetrySink final : public hal::TelemetrySink {
 public:
  std::vector<std::vector<std::uint8_t>> frames;

 private:
  hal::Status DoSend(const std::uint8_t* f, std::size_t n) override {
    frames.emplace_back(f, f + n);
    return hal::Status::kOk;
  }
};

/// The paper's drive as HAL devices: call advanceTo(t) with increasing times; the truth
/// moves one 1 cm step every step_us, and a scan is taken at the end of every
/// scan_every-th step and sent on the serial port.
template <typename Drive>
class HalSimDrive {
 public:
  struct Options {
    std::uint8_t counter_bits = 16;
    std::uint32_t baud = 38400;
    int scan_every = 10;             ///< steps between scans (10 Hz at 100 steps/s)
    std::uint64_t step_us = 10000;   ///< 1 cm per 10 ms = 1 m/s
    SerialFaults faults{};
    double scan_dropout_probability = 0.0;  ///< a scan is not sent at all
    int stand_after_steps = -1;             ///< >= 0: the robot stops there; scans go on
    int laser_silent_from_step = -1;        ///< >= 0: the laser sends nothing from there ...
    int laser_silent_steps = 0;             ///< ... for this many steps
  };

  HalSimDrive(const SimConfig& cfg, std::uint64_t seed, const Options& opt)
      : sim_(cfg, seed), opt_(opt), enc_a_(opt.counter_bits), enc_b_(opt.counter_bits),
        port_(clock_, opt.baud, opt.faults), dropout_rng_(seed ^ 0x5CA11u) {}

  PaperSim<Drive>& sim() { return sim_; }
  SimClock& clock() { return clock_; }
  SimEncoderCounter& encoderA() { return enc_a_; }
  SimEncoderCounter& encoderB() { return enc_b_; }
  SimSerialPort& laserPort() { return port_; }
  const std::vector<SimStep<Drive>>& steps() const { return steps_; }
  /// Indices (into steps()) of the steps at which a scan was taken.
  const std::vector<std::size_t>& scanSteps() const { return scan_steps_; }
  /// For each scan sent (as scanSteps()): the bytes of its telegram the line dropped or
  /// corrupted (0: it arrived intact).
  const std::vector<std::size_t>& scanFaults() const { return scan_faults_; }
  /// Scans not sent because the laser was silent.
  std::size_t scansSilenced() const { return scans_silenced_; }

  /// Moves the world to time t_us (monotonic). Step k moves the robot during
  /// [k, k+1) * step_us; the counters move linearly through it, as real counters do, and
  /// the step's scan is taken at its end.
  void advanceTo(std::uint64_t t_us) {
    while (t_us >= next_start_us_) {
      prev_a_ = cur_a_;
      prev_b_ = cur_b_;
      // The robot follows the circle on the truth (a perfect guidance system): the test
      // is about the firmware's estimates, not about the controller.
      const bool standing = opt_.stand_after_steps >= 0 && int(steps_.size()) >= opt_.stand_after_steps;
      SimStep<Drive> st;
      if (standing) {  // no motion: same counts, same truth, a fresh scan
        st = steps_.back();
        sim_.scan(st.truth, st.ranges.data());
        st.input = {};
      } else {
        st = sim_.step(sim_.truth(), sim_.trueParams());
      }
      cur_a_ = st.counts.count_a;
      cur_b_ = st.counts.count_b;
      seg_start_us_ = next_start_us_;
      next_start_us_ += opt_.step_us;
      steps_.push_back(st);
      odoerr::sim::UniformDist<double> u01(0.0, 1.0);
      const int k = int(steps_.size()) - 1;
      const bool silent = opt_.laser_silent_from_step >= 0 && k >= opt_.laser_silent_from_step &&
                          k < opt_.laser_silent_from_step + opt_.laser_silent_steps;
      if (steps_.size() % static_cast<std::size_t>(opt_.scan_every) == 0 &&
          !(u01(dropout_rng_) < opt_.scan_dropout_probability)) {
        if (silent) {
          ++scans_silenced_;
        } else {
          std::uint8_t frame[1024];
          const std::size_t n = encodeLms2xxScan(st.ranges.data(), sim_.config().laser.beams, false,
                                                 frame, sizeof frame);
          // taken at the end of the step
          scan_faults_.push_back(port_.transmit(frame, n, next_start_us_));
          scan_steps_.push_back(steps_.size() - 1);
        }
      }
    }
    const double frac = steps_.empty() ? 0.0 : double(t_us - seg_start_us_) / double(opt_.step_us);
    enc_a_.set(prev_a_ + std::llround(frac * double(cur_a_ - prev_a_)));
    enc_b_.set(prev_b_ + std::llround(frac * double(cur_b_ - prev_b_)));
    clock_.set(t_us);
  }

 private:
  PaperSim<Drive> sim_;
  Options opt_;
  SimClock clock_;
  SimEncoderCounter enc_a_;
  SimEncoderCounter enc_b_;
  SimSerialPort port_;
  std::vector<SimStep<Drive>> steps_;
  std::vector<std::size_t> scan_steps_;
  std::vector<std::size_t> scan_faults_;
  std::size_t scans_silenced_ = 0;
  std::mt19937_64 dropout_rng_;
  std::int64_t prev_a_ = 0, prev_b_ = 0, cur_a_ = 0, cur_b_ = 0;
  std::uint64_t seg_start_us_ = 0;
  std::uint64_t next_start_us_ = 0;
};

}  // namespace odoerr::sim

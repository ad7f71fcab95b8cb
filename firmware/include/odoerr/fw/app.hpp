// The firmware application: one source for the host (over the HAL simulator) and the
// target. No heap, no exceptions; all devices injected by reference.
//
// Each poll():
//  1. reads the laser's serial bytes into the LMS2xx parser (scans are stamped with the time
//     they were taken, from the arrival time and the baud rate);
//  2. samples both encoder counters (wrap-safe; impossible jumps rejected and counted) and
//     queues the cumulative counts with the sample time;
//  3. processes the queue up to now - horizon (a fixed fusion delay, as in PX4's EKF2, so a
//     scan that arrives after its own time stamp is still fused in order): a scan is fused
//     at its stamp, with the encoder counts interpolated to that instant (a standing robot
//     still fuses its scans); otherwise one cycle per cycle_distance of travel;
//  4. after each cycle steps the OF (inside the estimator), publishes telemetry every
//     telemetry_every cycles, and saves the calibration every save_every cycles or on
//     request.
// The published pose is the estimate at the filter time (now - horizon).
#pragma once

#include <cstdint>

#include "odoerr/drivers/calibration_store.hpp"
#include "odoerr/drivers/encoder.hpp"
#include "odoerr/drivers/lms2xx.hpp"
#include "odoerr/estimator.hpp"
#include "odoerr/fw/telemetry.hpp"
#include "odoerr/hal/clock.hpp"
#include "odoerr/hal/telemetry_sink.hpp"

namespace odoerr::fw {

struct AppConfig {
  float ticks_per_unit_a = 1.0f;  ///< diff: right wheel ticks per metre; sync: ticks per metre
  float ticks_per_unit_b = 1.0f;  ///< diff: left wheel ticks per metre; sync: ticks per radian
  float cycle_distance_m = 0.01f;
  std::uint32_t horizon_us = 40000;  ///< fusion delay: > scan transmission time + latency
  std::uint32_t telemetry_every = 10;
  std::uint32_t save_every = 3000;
  std::uint8_t drive_id = 1;  ///< stored with the calibration (0 sync, 1 diff)
  /// No usable scan for this long: the laser is counted silent (once per silence).
  std::uint32_t laser_timeout_us = 500000;
  /// The clock unchanged over this many consecutive polls: counted as stalled (once per
  /// stall). The main loop polls every 1 ms, so 10 polls is 10 ms of a frozen clock.
  std::uint32_t clock_stall_polls = 10;
};

/// Health counters published in telemetry (order = kNames).
struct AppHealth {
  std::uint32_t cycles = 0;
  std::uint32_t scans_fused = 0;
  std::uint32_t scans_late = 0;        ///< stamp older than the filter time: dropped
  std::uint32_t scans_overwritten = 0; ///< a newer scan replaced one not yet fused
  std::uint32_t scans_wrong_size = 0;  ///< beam count differs from the laser set-up: dropped
  std::uint32_t samples_dropped = 0;   ///< encoder queue full
  std::uint32_t encoder_errors = 0;    ///< read errors + rejected jumps
  std::uint32_t telemetry_dropped = 0;
  std::uint32_t saves_ok = 0;
  std::uint32_t saves_failed = 0;
  std::uint32_t calibration_restored = 0;
  std::uint32_t calibration_foreign = 0;  ///< a valid stored record of another drive: not used
  std::uint32_t laser_silences = 0;       ///< no usable scan for laser_timeout_us (episodes)
  std::uint32_t clock_stalls = 0;         ///< clock frozen for clock_stall_polls polls (episodes)
  std::uint32_t clock_backwards = 0;      ///< polls whose clock read less than the last (held)
};

template <typename EstimatorT>
class App {
 public:
  using S = typename EstimatorT::S;
  using Model = typename EstimatorT::Model;
  using Drive = typename Model::Drive;
  using Input = typename Model::Input;
  static constexpr int kP = Drive::kParams;
  static constexpr int kM = Drive::kNonSys;
  static constexpr int kQueue = 64;
  static constexpr int kMaxBeams = 64;

  App(hal::EncoderCounter& enc_a, hal::EncoderCounter& enc_b, hal::SerialPort& laser,
      const hal::Clock& clock, hal::ParamStore& store, hal::TelemetrySink& telemetry,
      EstimatorT& est, const AppConfig& cfg, const drivers::EncoderConfig& enc_cfg,
      const drivers::Lms2xxConfig& lms_cfg)
      : enc_a_(enc_a, enc_cfg),
        enc_b_(enc_b, enc_cfg),
        laser_(laser),
        clock_(clock),
        calib_(store),
        telemetry_(telemetry),
        est_(est),
        cfg_(cfg),
        parser_(lms_cfg) {}

  /// Starts the encoders and restores the newest valid calibration (if any).
  hal::Status boot() {
    const std::uint64_t now = clock_.nowUs();
    const hal::Status a = enc_a_.start(now);
    const hal::Status b = enc_b_.start(now);
    if (!hal::ok(a)) return a;
    if (!hal::ok(b)) return b;
    t_f_ = now;
    t_p_ = now;
    last_now_ = now;
    last_scan_us_ = now;
    restoreCalibration();
    return hal::Status::kOk;
  }

  /// One main-loop iteration.
  void poll() {
    const std::uint64_t now = checkedNow();
    (void)parser_.poll(laser_, now);  // data loss is counted by the parser
    if (parser_.scanAvailable()) takeScan();
    if (!laser_silent_ && now - last_scan_us_ > cfg_.laser_timeout_us) {
      laser_silent_ = true;  // the filter goes on with odometry alone, and says so
      ++health_.laser_silences;
    }
    sampleEncoders(now);
    process(now > cfg_.horizon_us ? now - cfg_.horizon_us : 0);
  }

  void requestSave() { save_requested_ = true; }

  const AppHealth& health() const { return health_; }
  const drivers::Lms2xxParser& parser() const { return parser_; }
  const drivers::EncoderDriver& encoderA() const { return enc_a_; }
  const drivers::EncoderDriver& encoderB() const { return enc_b_; }
  const drivers::CalibrationStore& calibration() const { return calib_; }
  std::uint64_t filterTimeUs() const { return t_f_; }
  /// Cumulative ticks integrated from each counter (rejected jumps contribute nothing).
  std::int64_t countA() const { return count_a_; }
  std::int64_t countB() const { return count_b_; }

 private:
  struct Sample {
    std::uint64_t t;
    std::int64_t a;
    std::int64_t b;
  };

  /// The clock, held monotonic (a reading below the last is counted and replaced by the
  /// last), with a frozen clock counted once per stall.
  std::uint64_t checkedNow() {
    std::uint64_t now = clock_.nowUs();
    if (now < last_now_) {
      ++health_.clock_backwards;
      now = last_now_;
    }
    if (now == last_now_) {
      if (++same_time_polls_ == cfg_.clock_stall_polls) ++health_.clock_stalls;
    } else {
      same_time_polls_ = 0;
    }
    last_now_ = now;
    return now;
  }

  void takeScan() {
    drivers::Lms2xxScanInfo info;
    float r[kMaxBeams];
    if (!hal::ok(parser_.takeScan(r, kMaxBeams, &info))) return;
    if (info.count != est_.laser().beams()) {  // a scan of another set-up: dropped, counted
      ++health_.scans_wrong_size;
      return;
    }
    if (scan_pending_) ++health_.scans_overwritten;
    last_scan_us_ = last_now_;
    laser_silent_ = false;
    for (int i = 0; i < info.count; ++i) scan_[i] = S(r[i]);
    scan_stamp_ = info.stamp_us;
    scan_pending_ = true;
  }

  void sampleEncoders(std::uint64_t now) {
    std::int32_t da = 0;
    std::int32_t db = 0;
    const hal::Status sa = enc_a_.sample(now, &da);
    const hal::Status sb = enc_b_.sample(now, &db);
    if (!hal::ok(sa)) ++health_.encoder_errors;
    if (!hal::ok(sb)) ++health_.encoder_errors;
    count_a_ += da;  // a rejected jump contributes 0 (and is counted by the driver)
    count_b_ += db;
    if (queued_ == kQueue) {
      ++health_.samples_dropped;  // never expected with a sane horizon; oldest kept
      return;
    }
    queue_[(head_ + queued_) % kQueue] = {now, count_a_, count_b_};
    ++queued_;
  }

  /// Processes queued samples whose time is at most `until`.
  void process(std::uint64_t until) {
    while (queued_ > 0 && queue_[head_].t <= until) {
      const Sample s = queue_[head_];
      if (scan_pending_ && scan_stamp_ <= t_f_) {
        ++health_.scans_late;
        scan_pending_ = false;
      }
      if (scan_pending_ && scan_stamp_ <= s.t) {
        // Counts at the scan's instant: linear between the bracketing samples.
        fuseScanAt(s);
        continue;  // the same sample may still complete a travel cycle
      }
      head_ = (head_ + 1) % kQueue;
      --queued_;
      t_p_ = s.t;
      pa_ = s.a;
      pb_ = s.b;
      const Input u = inputFrom(S(pa_ - fa_whole_) - fa_frac_, S(pb_ - fb_whole_) - fb_frac_);
      if (Drive::pathLength(u) >= S(cfg_.cycle_distance_m)) {
        cycle(u, nullptr);
        setFilterCounts(t_p_, pa_, S(0), pb_, S(0));
      }
    }
  }

  void fuseScanAt(const Sample& s) {
    // Counts at the scan's instant, linear between the bracketing points: the filter point
    // (t_f_) or the last processed sample (t_p_) below, the last processed sample or s above.
    struct Point {
      std::uint64_t t;
      std::int64_t a;
      S fa;
      std::int64_t b;
      S fb;
    };
    const Point filt{t_f_, fa_whole_, fa_frac_, fb_whole_, fb_frac_};
    const Point last{t_p_, pa_, S(0), pb_, S(0)};
    const Point next{s.t, s.a, S(0), s.b, S(0)};
    const bool in_last = scan_stamp_ < t_p_;
    const Point& lo = in_last ? filt : last;
    const Point& hi = in_last ? last : next;
    const S w = hi.t > lo.t ? S(float(scan_stamp_ - lo.t) / float(hi.t - lo.t)) : S(1);
    // Whole ticks plus a fraction: a single float keeps only 24 bits, too few for long drives.
    const S add_a = lo.fa + w * (S(hi.a - lo.a) + hi.fa - lo.fa);
    const S add_b = lo.fb + w * (S(hi.b - lo.b) + hi.fb - lo.fb);
    const std::int64_t ia = lo.a + static_cast<std::int64_t>(add_a);
    const std::int64_t ib = lo.b + static_cast<std::int64_t>(add_b);
    const S fa = add_a - S(static_cast<std::int64_t>(add_a));
    const S fb = add_b - S(static_cast<std::int64_t>(add_b));
    const Input u = inputFrom(S(ia - fa_whole_) + fa - fa_frac_, S(ib - fb_whole_) + fb - fb_frac_);
    cycle(u, scan_);
    ++health_.scans_fused;
    scan_pending_ = false;
    setFilterCounts(scan_stamp_, ia, fa, ib, fb);
  }

  void setFilterCounts(std::uint64_t t, std::int64_t a, S fa, std::int64_t b, S fb) {
    t_f_ = t;
    fa_whole_ = a;
    fa_frac_ = fa;
    fb_whole_ = b;
    fb_frac_ = fb;
  }

  /// Channel A and B ticks to the drive's input (m; sync channel B in rad).
  Input inputFrom(S ticks_a, S ticks_b) const {
    return Input{ticks_a / S(cfg_.ticks_per_unit_a), ticks_b / S(cfg_.ticks_per_unit_b)};
  }

  void cycle(const Input& u, const S* ranges) {
    (void)est_.cycle(u, ranges);
    ++health_.cycles;
    if (cfg_.telemetry_every > 0 && health_.cycles % cfg_.telemetry_every == 0) publish();
    if ((cfg_.save_every > 0 && health_.cycles % cfg_.save_every == 0) || save_requested_) {
      save_requested_ = false;
      save();
    }
  }

  void publish() {
    const auto& x = est_.akf().state();
    const auto& p = est_.akf().covariance();
    FrameWriter f(kTelemetryState);
    f.u64(t_f_);
    f.u32(health_.cycles);
    for (int i = 0; i < 3; ++i) f.f32(float(x[i]));
    for (int i = 0; i < 3; ++i) f.f32(float(std::sqrt(p(i, i))));
    f.u8(kP);
    for (int i = 0; i < kP; ++i) f.f32(float(x[Model::kDriveOffset + i]));
    for (int i = 0; i < kP; ++i) f.f32(float(std::sqrt(p(Model::kDriveOffset + i, Model::kDriveOffset + i))));
    f.u8(kM);
    for (int i = 0; i < kM; ++i) f.f32(float(est_.of().estimate()[i]));
    for (int i = 0; i < kM; ++i) f.f32(float(std::sqrt(est_.of().covariance()(i, i))));
    const auto& ac = est_.akf().counters();
    const auto& lc = parser_.counters();
    const std::uint32_t counters[] = {
        ac.beams_used, ac.gated, ac.grazing + ac.too_close + ac.no_return + ac.no_map_hit,
        ac.bad_inputs + ac.bad_predictions + ac.bad_innovation + ac.bad_covariance,
        est_.of().counters().updates, est_.of().counters().rejected,
        enc_a_.counters().jumps_rejected + enc_b_.counters().jumps_rejected,
        lc.frames_ok, lc.bad_crc, lc.truncated, lc.wrong_length,
        health_.scans_fused, health_.scans_late, health_.scans_overwritten, health_.scans_wrong_size,
        health_.telemetry_dropped, health_.saves_ok, health_.saves_failed};
    f.u8(static_cast<std::uint8_t>(sizeof counters / sizeof counters[0]));
    for (std::uint32_t c : counters) f.u32(c);
    const std::size_t n = f.finish();
    if (n == 0 || !hal::ok(telemetry_.send(f.data(), n))) ++health_.telemetry_dropped;
  }

  void save() {
    drivers::Calibration c{};
    c.drive = cfg_.drive_id;
    c.count = static_cast<std::uint8_t>(kP + kM);
    const auto& x = est_.akf().state();
    const auto& p = est_.akf().covariance();
    for (int i = 0; i < kP; ++i) {
      c.value[i] = float(x[Model::kDriveOffset + i]);
      c.variance[i] = float(p(Model::kDriveOffset + i, Model::kDriveOffset + i));
    }
    for (int i = 0; i < kM; ++i) {
      c.value[kP + i] = float(est_.of().estimate()[i]);
      c.variance[kP + i] = float(est_.of().covariance()(i, i));
    }
    if (hal::ok(calib_.save(c))) {
      ++health_.saves_ok;
    } else {
      ++health_.saves_failed;
    }
  }

  void restoreCalibration() {
    drivers::Calibration c{};
    if (calib_.load(&c) != drivers::LoadResult::kRestored) return;
    if (c.drive != cfg_.drive_id || c.count != kP + kM) {  // another robot's record
      ++health_.calibration_foreign;
      return;
    }
    typename Model::StateVec x = est_.akf().state();
    typename Model::StateMat p = est_.akf().covariance();
    for (int i = 0; i < kP; ++i) {
      const int k = Model::kDriveOffset + i;
      x[k] = S(c.value[i]);
      p.row(k).setZero();
      p.col(k).setZero();
      p(k, k) = S(c.variance[i]);
    }
    typename EstimatorT::OfT::KVec kv;
    typename EstimatorT::OfT::KMat kp = EstimatorT::OfT::KMat::Zero();
    for (int i = 0; i < kM; ++i) {
      kv[i] = S(c.value[kP + i]);
      kp(i, i) = S(c.variance[kP + i]);
    }
    est_.init(x, p, kv, kp);
    ++health_.calibration_restored;
  }

  drivers::EncoderDriver enc_a_;
  drivers::EncoderDriver enc_b_;
  hal::SerialPort& laser_;
  const hal::Clock& clock_;
  drivers::CalibrationStore calib_;
  hal::TelemetrySink& telemetry_;
  EstimatorT& est_;
  AppConfig cfg_;
  drivers::Lms2xxParser parser_;
  AppHealth health_{};

  Sample queue_[kQueue]{};
  int head_ = 0;
  int queued_ = 0;
  std::int64_t count_a_ = 0;
  std::int64_t count_b_ = 0;
  // last processed sample
  std::uint64_t t_p_ = 0;
  std::int64_t pa_ = 0;
  std::int64_t pb_ = 0;
  // the filter's time and the (interpolated) counts it has integrated up to
  std::uint64_t t_f_ = 0;
  std::int64_t fa_whole_ = 0;
  S fa_frac_ = S(0);
  std::int64_t fb_whole_ = 0;
  S fb_frac_ = S(0);

  S scan_[kMaxBeams]{};
  std::uint64_t scan_stamp_ = 0;
  bool scan_pending_ = false;
  bool save_requested_ = false;
  std::uint64_t last_now_ = 0;      // the last clock reading (held monotonic)
  std::uint32_t same_time_polls_ = 0;
  std::uint64_t last_scan_us_ = 0;  // when the last usable scan was taken
  bool laser_silent_ = false;
};

}  // namespace odoerr::fw

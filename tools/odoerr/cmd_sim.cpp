// odoerr tool: the simulators' commands. `sim` writes a drive as odolog v1 (the paper's
// circle, an exciting drive with effects, or a drive along a path through any map);
// `tape` and `hal-tape` record drives for the firmware images' tests.
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cli.hpp"
#include "commands.hpp"
#include "odoerr/fw/hal_tape.hpp"
#include "odoerr/fw/tape.hpp"
#include "odoerr/sim/effect_sim.hpp"
#include "odoerr/sim/hal_sim.hpp"
#include "odoerr/sim/map_drive.hpp"
#include "odoerr/sim/map_io.hpp"
#include "odoerr/sim/odolog_writer.hpp"
#include "odoerr/sim/paper_experiment.hpp"
#include "odoerr/sim/random.hpp"

namespace fs = std::filesystem;

namespace odoerr {
namespace {

using namespace odoerr::sim;
using cli::writeFile;
using fw::FilterSetup;

template <template <typename> class DriveT>
int writeSimLog(const std::string& out, std::uint64_t seed, int steps, const std::string& start) {
  SimConfig cfg;
  cfg.steps = steps;
  FilterSetup setup;
  PaperSim<DriveT<double>> header_sim(cfg, seed);  // same seed: same initial draw as the run
  std::string text = odologHeader(header_sim, seed, setup.sigma_pose_xy, setup.sigma_pose_theta);
  const int beams = cfg.laser.beams;
  StepSink<DriveT<double>> sink = [&text, beams](const SimStep<DriveT<double>>& st) {
    appendOdologStep(text, st, beams);
  };
  (void)runDrive<double, DriveT>(cfg, seed, start == "large" ? NonSysStart::kLarge : NonSysStart::kSmall,
                                 setup, steps, sink);
  std::string err;
  const fs::path path(out);
  if (path.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
  }
  if (!writeFile(path, text, &err)) {
    std::fprintf(stderr, "odoerr sim: %s\n", err.c_str());
    return 1;
  }
  std::fprintf(stderr, "odoerr sim: wrote %d cycles to %s\n", steps, out.c_str());
  return 0;
}

/// Records one closed-loop drive as a core-replay tape (firmware/include/odoerr/fw/tape.hpp).
/// Faults written into a tape's ranges (`odoerr tape --faults`): what the target's soak
/// replays (docs/reliability.md, "Float32 soak"). The drive itself is recorded clean. Not
/// the host soak's injector (tests/soak/soak.cpp), on purpose: that one drops a scan by not
/// offering it, gives four forms of no return and bursts over 2-8 adjacent beams for 10-50
/// cycles with an outlier margin, and checks every beam's outcome; here a dropped scan is
/// offered with every range NaN, and the two draw different random streams.
struct TapeFaults {
  double drop_scan = 0.10;      ///< a whole scan lost: every range NaN
  double no_return = 0.01;      ///< one beam without a return: NaN
  double burst_start = 0.002;   ///< per cycle: an outlier burst begins (10 cycles)
  double burst_beam = 0.3;      ///< within a burst, a beam reads short (something in front)
  long dropped_scans = 0, no_return_beams = 0, outlier_beams = 0;
};

template <template <typename> class DriveT>
int writeTape(const std::string& out, std::uint64_t seed, int steps, int record_every, bool faults) {
  SimConfig cfg;
  cfg.steps = steps;
  FilterSetup setup;
  PaperSim<DriveT<double>> sim(cfg, seed);
  fw::TapeHeader h;
  h.drive = PaperSim<DriveT<double>>::kSync ? 0 : 1;
  h.cycles = static_cast<std::uint32_t>(steps);
  h.beams = static_cast<std::uint32_t>(cfg.laser.beams);
  h.x0 = float(sim.initialEstimate().x);
  h.y0 = float(sim.initialEstimate().y);
  h.theta0 = float(sim.initialEstimate().theta);
  const typename DriveT<double>::NonSysVec k0 = sim.trueNonSys() * setup.nonsys_factor_small;
  for (int i = 0; i < k0.size(); ++i) h.k0[i] = float(k0[i]);
  h.record_every = static_cast<std::uint32_t>(record_every);
  h.angle_min = float(cfg.laser.angle_min);
  h.angle_inc = float(cfg.laser.angle_inc);
  h.range_max = float(cfg.laser.range_max);
  h.sigma = float(cfg.laser.sigma);
  std::string bytes(fw::kTapeHeaderBytes, '\0');
  fw::encodeHeader(h, reinterpret_cast<std::uint8_t*>(bytes.data()));
  TapeFaults tf;
  std::mt19937_64 frng(seed ^ 0x5eedfa17ULL);
  odoerr::sim::UniformDist<double> unif(0.0, 1.0);
  int burst_left = 0;
  StepSink<DriveT<double>> sink = [&](const SimStep<DriveT<double>>& st) {
    std::uint8_t b[4 * (2 + kMaxBeams)];
    const auto& [a, bb] = st.input;  // channels A and B
    fw::putF32(b, float(a));
    fw::putF32(b + 4, float(bb));
    double r[kMaxBeams];
    for (int i = 0; i < cfg.laser.beams; ++i) r[i] = st.ranges[i];
    if (faults) {
      if (burst_left == 0 && unif(frng) < tf.burst_start) burst_left = 10;
      const bool drop = unif(frng) < tf.drop_scan;
      tf.dropped_scans += drop;
      for (int i = 0; i < cfg.laser.beams; ++i) {
        if (drop) {
          r[i] = std::numeric_limits<double>::quiet_NaN();
        } else if (unif(frng) < tf.no_return) {
          r[i] = std::numeric_limits<double>::quiet_NaN();
          ++tf.no_return_beams;
        } else if (burst_left > 0 && unif(frng) < tf.burst_beam) {
          r[i] = (0.05 + 0.85 * unif(frng)) * r[i];
          ++tf.outlier_beams;
        }
      }
      if (burst_left > 0) --burst_left;
    }
    for (int i = 0; i < cfg.laser.beams; ++i) fw::putF32(b + 8 + 4 * i, float(r[i]));
    bytes.append(reinterpret_cast<const char*>(b), 4 * (2 + cfg.laser.beams));
  };
  (void)runDrive<double, DriveT>(cfg, seed, NonSysStart::kSmall, setup, steps, sink);
  std::string err;
  if (!writeFile(out, bytes, &err)) {
    std::fprintf(stderr, "odoerr tape: %s\n", err.c_str());
    return 1;
  }
  std::fprintf(stderr, "odoerr tape: wrote %d cycles to %s\n", steps, out.c_str());
  if (faults) {
    std::fprintf(stderr, "odoerr tape: faults injected: %ld scans dropped (%ld beams), %ld beams without a return, "
                 "%ld outlier beams\n", tf.dropped_scans, tf.dropped_scans * cfg.laser.beams, tf.no_return_beams,
                 tf.outlier_beams);
  }
  return 0;
}

/// Faults a HAL tape records: the laser line's (per byte) and the encoders'.
struct HalTapeFaults {
  double corrupt = 0.0;   ///< probability that a laser byte has a bit flipped
  double drop = 0.0;      ///< probability that a laser byte is lost on the line
  double drop_scans = 0.0;  ///< probability that a scan's telegram is not sent at all
  int encoder_faults = 0; ///< this many one-read glitches (+/-30,000 ticks) and as many lasting jumps (+5,000)
};

/// Records what the HAL devices show the firmware at each 1 ms poll of a simulated drive
/// (counters, laser bytes), for the firmware image's replay (firmware/apps/fw_replay).
template <template <typename> class DriveT>
int writeHalTape(const std::string& out, std::uint64_t seed, int steps, const HalTapeFaults& faults) {
  using D = DriveT<double>;
  SimConfig cfg;
  cfg.radius = 4.5;  // clear of the walls (see tests/test_firmware_app.cpp)
  typename HalSimDrive<D>::Options opt;
  opt.faults.corrupt_probability = faults.corrupt;
  opt.faults.drop_probability = faults.drop;
  opt.scan_dropout_probability = faults.drop_scans;
  HalSimDrive<D> world(cfg, seed, opt);
  fw::HalTapeHeader h;
  h.drive = PaperSim<D>::kSync ? 0 : 1;
  h.counter_bits = opt.counter_bits;
  h.ticks_a = float(world.sim().ticksA());
  h.ticks_b = float(world.sim().ticksB());
  h.x0 = float(world.sim().initialEstimate().x);
  h.y0 = float(world.sim().initialEstimate().y);
  h.theta0 = float(world.sim().initialEstimate().theta);
  // The firmware starts from a calibrated K (as after restoring its stored calibration);
  // the paper's OF from 100x below is exercised by the paper experiment instead.
  const typename D::NonSysVec k0 = world.sim().trueNonSys();
  for (int i = 0; i < k0.size(); ++i) h.k0[i] = float(k0[i]);
  h.baud = opt.baud;
  std::string bytes(fw::kHalTapeHeaderBytes, '\0');
  std::uint32_t polls = 0;
  const std::uint64_t end_us = std::uint64_t(steps) * opt.step_us;
  // The encoder faults at evenly spaced polls after the first second, wheel A and B in turn:
  // fault i is a glitch when i is even, a lasting jump when it is odd.
  const int n_enc = 2 * faults.encoder_faults;
  const std::uint64_t enc_every_ms = n_enc > 0 ? (end_us / 1000 - 1000) / std::uint64_t(n_enc + 1) : 0;
  int enc_done = 0;
  for (std::uint64_t t = 0; t <= end_us; t += 1000) {
    world.advanceTo(t);
    if (enc_done < n_enc && t / 1000 == 1000 + enc_every_ms * std::uint64_t(enc_done + 1)) {
      SimEncoderCounter& e = (enc_done / 2) % 2 == 0 ? world.encoderA() : world.encoderB();
      if (enc_done % 2 == 0) {
        e.glitchNextRead((enc_done / 2) % 2 == 0 ? 30000 : -30000);
      } else {
        e.jump(5000);
      }
      ++enc_done;
    }
    std::uint32_t ra = 0;
    std::uint32_t rb = 0;
    (void)world.encoderA().read(&ra);
    (void)world.encoderB().read(&rb);
    std::uint8_t serial[1024];
    std::size_t n = 0;
    (void)world.laserPort().read(serial, sizeof serial, &n);
    std::uint8_t rec[fw::kHalTapePollBytes];
    fw::putU32(rec, static_cast<std::uint32_t>(t));
    fw::putU32(rec + 4, static_cast<std::uint32_t>(t >> 32));
    fw::putU32(rec + 8, ra);
    fw::putU32(rec + 12, rb);
    rec[16] = static_cast<std::uint8_t>(n);
    rec[17] = static_cast<std::uint8_t>(n >> 8);
    bytes.append(reinterpret_cast<const char*>(rec), sizeof rec);
    bytes.append(reinterpret_cast<const char*>(serial), n);
    ++polls;
  }
  h.polls = polls;
  fw::encodeHalTapeHeader(h, reinterpret_cast<std::uint8_t*>(bytes.data()));
  std::string err;
  if (!writeFile(out, bytes, &err)) {
    std::fprintf(stderr, "odoerr hal-tape: %s\n", err.c_str());
    return 1;
  }
  std::fprintf(stderr, "odoerr hal-tape: wrote %u polls (%d cycles of travel) to %s\n", polls, steps,
               out.c_str());
  std::fprintf(stderr,
               "odoerr hal-tape: faults: %zu scans not sent, %llu laser bytes lost, %llu corrupted, %d encoder "
               "glitches, %d encoder jumps\n",
               world.steps().size() / std::size_t(opt.scan_every) - world.scanSteps().size(),
               static_cast<unsigned long long>(world.laserPort().dropped()),
               static_cast<unsigned long long>(world.laserPort().corrupted()), (enc_done + 1) / 2, enc_done / 2);
  return 0;
}


/// A drive along a path through a map (MapDrive), ready to record: the map's walls, the
/// tables, the configuration. False with a message on stderr naming the problem.
struct MapDriveInput {
  std::vector<OdologWall> walls;
  MapDriveConfig cfg;
  std::string map_name;
};

bool loadMapDrive(const char* who, const std::string& map_path, const std::string& path_path, int steps, bool loop,
                  MapDriveInput* in) {
  std::string err;
  if (!readMapWalls(map_path, &in->walls, &err) || !readPath(path_path, &in->cfg.path, &err)) {
    std::fprintf(stderr, "%s: %s\n", who, err.c_str());
    return false;
  }
  in->cfg.steps = steps;
  in->cfg.loop = loop;
  in->map_name = fs::path(map_path).filename().string();
  return true;
}

int writeMapSimLog(const MapDriveInput& in, std::uint64_t seed, const std::string& out) {
  std::string text, err;
  if (!mapDriveOdolog(in.cfg, in.walls, seed, in.map_name, &text, &err) || !writeFile(out, text, &err)) {
    std::fprintf(stderr, "odoerr sim: %s\n", err.c_str());
    return 1;
  }
  std::fprintf(stderr, "odoerr sim: wrote %d cycles in %s (%zu walls) to %s\n", in.cfg.steps, in.map_name.c_str(),
               in.walls.size(), out.c_str());
  return 0;
}

/// A map drive as a core-replay tape for the map images (firmware/apps/map_replay).
int writeMapTape(const MapDriveInput& in, std::uint64_t seed, int beams_used, int record_every, const std::string& out) {
  HostMap<double> map;
  std::string err;
  if (!map.build(in.walls, -1, &err)) {
    std::fprintf(stderr, "odoerr tape: %s\n", err.c_str());
    return 1;
  }
  MapDrive drive(in.cfg, map, seed);
  if (!drive.ok(&err)) {
    std::fprintf(stderr, "odoerr tape: %s\n", err.c_str());
    return 1;
  }
  FilterSetup setup;
  const auto& l = in.cfg.laser;
  fw::TapeHeader h;
  h.drive = 1;
  h.cycles = static_cast<std::uint32_t>(in.cfg.steps);
  h.beams = static_cast<std::uint32_t>(l.beams);
  h.beams_used = static_cast<std::uint32_t>(beams_used);
  h.x0 = float(drive.initialEstimate().x);
  h.y0 = float(drive.initialEstimate().y);
  h.theta0 = float(drive.initialEstimate().theta);
  h.k0[0] = float(drive.trueNonSys()[0] * setup.nonsys_factor_small);
  h.record_every = static_cast<std::uint32_t>(record_every);
  h.angle_min = float(l.angle_min);
  h.angle_inc = float(l.angle_inc);
  h.range_max = float(l.range_max);
  h.sigma = float(l.sigma);
  std::string bytes(fw::kTapeHeaderBytes, '\0');
  fw::encodeHeader(h, reinterpret_cast<std::uint8_t*>(bytes.data()));
  std::vector<std::uint8_t> b(4 * (2 + std::size_t(l.beams)));
  for (int k = 0; k < in.cfg.steps; ++k) {
    const MapDriveStep st = drive.step();
    if (!drive.ok(&err)) {
      std::fprintf(stderr, "odoerr tape: %s\n", err.c_str());
      return 1;
    }
    fw::putF32(b.data(), float(st.input.right));
    fw::putF32(b.data() + 4, float(st.input.left));
    for (int i = 0; i < l.beams; ++i) fw::putF32(b.data() + 8 + 4 * i, float(st.ranges[std::size_t(i)]));
    bytes.append(reinterpret_cast<const char*>(b.data()), b.size());
  }
  if (!writeFile(out, bytes, &err)) {
    std::fprintf(stderr, "odoerr tape: %s\n", err.c_str());
    return 1;
  }
  std::fprintf(stderr, "odoerr tape: wrote %d cycles in %s (%d of %d beams per scan) to %s\n", in.cfg.steps,
               in.map_name.c_str(), beams_used > 0 ? beams_used : l.beams, l.beams, out.c_str());
  return 0;
}

}  // namespace

void registerSimCommands(CLI::App& app, cli::Commands& cmds) {
  struct SimOpts {
    std::string drive = "sync", out, start = "small", scenario = "paper", map, path;
    std::uint64_t seed = 1;
    int steps = 3000;
    std::vector<std::string> effects;
    double minutes = 4.0;
    bool loop = false;
  };
  auto so = std::make_shared<SimOpts>();
  auto* sim = app.add_subcommand("sim", "simulate one drive and write it as odolog v1");
  sim->add_option("--drive", so->drive, "sync or diff")->check(CLI::IsMember({"sync", "diff"}));
  sim->add_option("--out", so->out, "odolog file to write")->required();
  sim->add_option("--seed", so->seed, "random seed (the same seed as run r of `paper` when seed+r)");
  sim->add_option("--steps", so->steps, "cycles (1 cm each)")->check(CLI::Range(1, 10000000));
  sim->add_option("--start", so->start, "initial non-systematic estimate: small or large")
      ->check(CLI::IsMember({"small", "large"}));
  sim->add_option("--scenario", so->scenario,
                  "paper (the Section 5 circle) or excite (figure-eights at three speeds, reversals; "
                  "implied by --effect)")
      ->check(CLI::IsMember({"paper", "excite"}));
  sim->add_option("--effect", so->effects,
                  "inject a catalogue effect: NAME=V1[,V2...], or a feature term: feature:FEATURE@TARGET=C (repeatable)");
  sim->add_option("--minutes", so->minutes, "length of an excite drive")->check(CLI::Range(0.05, 600.0));
  auto* sim_map = sim->add_option("--map", so->map,
                                  "drive through this map (.odomap, or an odolog's walls): a diff drive along --path "
                                  "with a 181-beam laser");
  sim->add_option("--path", so->path, "the path of a --map drive: 'X Y' lines, or an odolog (its truth)")
      ->needs(sim_map);
  sim->add_flag("--loop", so->loop, "a --map drive starts the path again at its end");
  cmds.add(sim, [so]() {
    if (!so->map.empty()) {
      if (so->path.empty()) {
        std::fprintf(stderr, "odoerr sim: a --map drive needs --path\n");
        return 2;
      }
      if (!so->effects.empty()) {  // the map drive simulates no effect: refused, never dropped
        std::fprintf(stderr,
                     "odoerr sim: --effect does not apply to a --map drive (it simulates the nominal robot); use "
                     "the effect drive (without --map) or tools/pysim/odosim.py\n");
        return 2;
      }
      MapDriveInput in;
      if (!loadMapDrive("odoerr sim", so->map, so->path, so->steps, so->loop, &in)) return 1;
      return writeMapSimLog(in, so->seed, so->out);
    }
    if (so->scenario == "excite" || !so->effects.empty()) {
      EffectSimConfig ec;
      ec.drive = so->drive;
      ec.seed = so->seed;
      ec.minutes = so->minutes;
      std::string err;
      for (const auto& e : so->effects) {
        if (!parseEffectArg(e, &ec, &err)) {
          std::fprintf(stderr, "odoerr sim: %s\n", err.c_str());
          return 2;
        }
      }
      std::string text;
      if (!simulateEffectDrive(ec, &text, &err) || !writeFile(so->out, text, &err)) {
        std::fprintf(stderr, "odoerr sim: %s\n", err.c_str());
        return 1;
      }
      std::fprintf(stderr, "odoerr sim: wrote a %.1f-minute %s drive to %s\n", so->minutes, so->drive.c_str(),
                   so->out.c_str());
      return 0;
    }
    return so->drive == "sync" ? writeSimLog<SyncDrive>(so->out, so->seed, so->steps, so->start)
                               : writeSimLog<DiffDrive>(so->out, so->seed, so->steps, so->start);
  });

  struct TapeOpts {
    std::string drive = "diff", out, map, path;
    std::uint64_t seed = 1;
    int steps = 3000, every = 100, beams_used = 0;
    bool loop = false, faults = false;
  };
  auto to = std::make_shared<TapeOpts>();
  auto* tape = app.add_subcommand("tape", "record one drive as a core-replay tape (firmware tests)");
  tape->add_option("--drive", to->drive, "sync or diff")->check(CLI::IsMember({"sync", "diff"}));
  tape->add_option("--out", to->out, "tape file to write")->required();
  tape->add_option("--seed", to->seed, "random seed");
  tape->add_option("--steps", to->steps, "cycles (1 cm each)")->check(CLI::Range(1, 10000000));
  tape->add_option("--record-every", to->every, "replay output interval (cycles)")->check(CLI::Range(1, 1000000));
  auto* tape_map = tape->add_option("--map", to->map, "a diff drive through this map along --path (map images)");
  tape->add_option("--path", to->path, "the path of a --map drive")->needs(tape_map);
  tape->add_flag("--loop", to->loop, "a --map drive starts the path again at its end");
  tape->add_flag("--faults", to->faults,
                 "write faults into the ranges: 10 % of scans dropped, 1 % of beams without a return, "
                 "bursts of short outlier ranges (the target's soak; not with --map)");
  tape->add_option("--beams-used", to->beams_used, "beams the filter fuses per scan (0: all)")
      ->check(CLI::Range(0, 4095));
  cmds.add(tape, [to]() {
    if (!to->map.empty()) {
      if (to->faults) {
        std::fprintf(stderr, "odoerr tape: --faults applies to the paper's drives, not to a --map drive\n");
        return 2;
      }
      if (to->path.empty()) {
        std::fprintf(stderr, "odoerr tape: a --map drive needs --path\n");
        return 2;
      }
      MapDriveInput in;
      if (!loadMapDrive("odoerr tape", to->map, to->path, to->steps, to->loop, &in)) return 1;
      return writeMapTape(in, to->seed, to->beams_used, to->every, to->out);
    }
    return to->drive == "sync" ? writeTape<SyncDrive>(to->out, to->seed, to->steps, to->every, to->faults)
                               : writeTape<DiffDrive>(to->out, to->seed, to->steps, to->every, to->faults);
  });

  struct HalOpts {
    std::string drive = "diff", out;
    std::uint64_t seed = 1;
    int steps = 3000;
    HalTapeFaults faults;
  };
  auto ho = std::make_shared<HalOpts>();
  auto* haltape = app.add_subcommand("hal-tape", "record the HAL devices of a simulated drive (firmware image tests)");
  haltape->add_option("--drive", ho->drive, "sync or diff")->check(CLI::IsMember({"sync", "diff"}));
  haltape->add_option("--out", ho->out, "tape file to write")->required();
  haltape->add_option("--seed", ho->seed, "random seed");
  haltape->add_option("--steps", ho->steps, "cm of travel")->check(CLI::Range(1, 1000000));
  haltape->add_option("--corrupt", ho->faults.corrupt, "probability that a laser byte is corrupted")
      ->check(CLI::Range(0.0, 1.0));
  haltape->add_option("--drop", ho->faults.drop, "probability that a laser byte is lost on the line")
      ->check(CLI::Range(0.0, 1.0));
  haltape->add_option("--drop-scans", ho->faults.drop_scans, "probability that a scan's telegram is not sent")
      ->check(CLI::Range(0.0, 1.0));
  haltape->add_option("--encoder-faults", ho->faults.encoder_faults,
                      "N one-read glitches of +/-30000 ticks and N lasting jumps of +5000 ticks")
      ->check(CLI::Range(0, 100));
  cmds.add(haltape, [ho]() {
    return ho->drive == "sync" ? writeHalTape<SyncDrive>(ho->out, ho->seed, ho->steps, ho->faults)
                               : writeHalTape<DiffDrive>(ho->out, ho->seed, ho->steps, ho->faults);
  });
}

}  // namespace odoerr

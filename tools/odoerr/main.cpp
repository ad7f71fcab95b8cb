// odoerr: the command-line tool.
//   odoerr paper --drive sync|diff --runs 100 --out DIR   the Monte Carlo of Section 5
//   odoerr sim   --drive sync|diff --seed 7 --out FILE    one simulated drive as odolog v1
//                [--effect NAME=V,...]... [--minutes M]     an exciting drive with effects injected
//   odoerr replay LOG --out DIR                            the estimator over a recorded drive
//   odoerr diagnose LOG --json OUT [--with E1,E2|auto] [--out DIR] [--suggest DIR]   model against measurements
//   odoerr report LOG --out DIR [--with E1,E2]             diagnose + a self-contained HTML page
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

#include "cli.hpp"
#include "commands.hpp"
#include "odoerr/fw/hal_tape.hpp"
#include "odoerr/fw/tape.hpp"
#include "odoerr/sim/diagnose.hpp"
#include "odoerr/sim/effect_sim.hpp"
#include "odoerr/sim/hal_sim.hpp"
#include "odoerr/sim/odolog.hpp"
#include "odoerr/sim/odolog_writer.hpp"
#include "odoerr/sim/replay.hpp"
#include "odoerr/sim/paper_experiment.hpp"

namespace fs = std::filesystem;
using namespace odoerr;
using namespace odoerr::sim;

namespace {

using cli::prepareOutDir;
using cli::ProgressBar;
using cli::pythonInterpreter;
using cli::shellQuote;
using cli::writeFile;

std::string plotScript() { return cli::scriptPath("ODOERR_PLOT_SCRIPT", ODOERR_PLOT_SCRIPT); }
std::string reportScript() { return cli::scriptPath("ODOERR_REPORT_SCRIPT", ODOERR_REPORT_SCRIPT); }

int runDiagnose(const std::string& log_path, const std::string& json_path, DiagnoseOptions opt, bool quiet) {
  const char* who = quiet ? "odoerr report" : "odoerr diagnose";
  Odolog log;
  std::string err;
  if (!readOdolog(log_path, &log, &err)) {
    std::fprintf(stderr, "%s: %s\n", who, err.c_str());
    return 1;
  }
  if (!opt.out_dir.empty() && !prepareOutDir(opt.out_dir, &err)) {
    std::fprintf(stderr, "%s: %s\n", who, err.c_str());
    return 1;
  }
  const auto t0 = std::chrono::steady_clock::now();
  nlohmann::ordered_json result;
  if (!diagnoseOdolog(log, opt, &result, &err)) {
    std::fprintf(stderr, "%s: %s\n", who, err.c_str());
    return 1;
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result["seconds"] = secs;
  if (!writeFile(json_path, result.dump(2) + "\n", &err)) {
    std::fprintf(stderr, "%s: %s\n", who, err.c_str());
    return 1;
  }
  std::string named;
  for (const auto& r : result["ranking"])
    if (r["significant"].get<bool>()) named += (named.empty() ? "" : ", ") + r["effect"].get<std::string>();
  std::fprintf(stderr, "%s: %s; verdict %s; effects named: %s (%.1f s)\n", who, log_path.c_str(),
               result["verdict"].get<std::string>().c_str(), named.empty() ? "none" : named.c_str(), secs);
  return 0;
}

int runPaper(const std::string& drive, int runs, const std::string& out, std::uint64_t seed,
             int threads, bool plots, const std::string& pose_term, int window) {
  std::string err;
  const fs::path dir(out);
  if (!prepareOutDir(dir, &err)) {
    std::fprintf(stderr, "odoerr paper: %s\n", err.c_str());
    return 1;
  }
  PaperOptions opt;
  opt.drive = drive == "sync" ? DriveKind::kSync : DriveKind::kDiff;
  opt.runs = runs;
  opt.seed = seed;
  opt.threads = threads;
  opt.setup.of.window = window;
  opt.setup.of.pose_term = pose_term == "literal" ? PoseErrorTerm::kLiteral : PoseErrorTerm::kExpected;
  ProgressBar bar(std::string("paper ") + drive);
  opt.progress = [&bar](int d, int t) { bar(d, t); };
  PaperResult res;
  try {
    res = runPaperExperiment(opt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "odoerr paper: %s\n", e.what());
    return 1;
  }
  const std::string csv_name = std::string("paper_") + drive + ".csv";
  if (!writeFile(dir / "summary.json", summaryJson(res), &err) ||
      !writeFile(dir / csv_name, paperCsv(res), &err) ||
      !writeFile(dir / "health.json", healthJson(res), &err)) {
    std::fprintf(stderr, "odoerr paper: %s\n", err.c_str());
    return 1;
  }
  std::fprintf(stderr, "odoerr paper: %s drive, %d runs x 2 starts in %.1f s; wrote %s\n",
               drive.c_str(), runs, res.wall_time_s, (dir / "summary.json").c_str());
  if (plots) {
    const std::string cmd = shellQuote(pythonInterpreter()) + " " + shellQuote(plotScript()) +
                            " --csv " + shellQuote((dir / csv_name).string()) + " --drive " +
                            drive + " --runs " + std::to_string(runs) + " --out " +
                            shellQuote(dir.string());
    const int rc = std::system(cmd.c_str());
    if (rc != 0) {
      std::fprintf(stderr,
                   "odoerr paper: plotting failed (exit %d) running: %s\n"
                   "  (the numbers are written; install python3-matplotlib or pass --no-plots)\n",
                   rc, cmd.c_str());
      return 1;
    }
  }
  return 0;
}

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
template <template <typename> class DriveT>
int writeTape(const std::string& out, std::uint64_t seed, int steps, int record_every) {
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
  std::string bytes(fw::kTapeHeaderBytes, '\0');
  fw::encodeHeader(h, reinterpret_cast<std::uint8_t*>(bytes.data()));
  StepSink<DriveT<double>> sink = [&bytes, &cfg](const SimStep<DriveT<double>>& st) {
    std::uint8_t b[4 * (2 + kMaxBeams)];
    const auto& [a, bb] = st.input;  // channels A and B
    fw::putF32(b, float(a));
    fw::putF32(b + 4, float(bb));
    for (int i = 0; i < cfg.laser.beams; ++i) fw::putF32(b + 8 + 4 * i, float(st.ranges[i]));
    bytes.append(reinterpret_cast<const char*>(b), 4 * (2 + cfg.laser.beams));
  };
  (void)runDrive<double, DriveT>(cfg, seed, NonSysStart::kSmall, setup, steps, sink);
  std::string err;
  if (!writeFile(out, bytes, &err)) {
    std::fprintf(stderr, "odoerr tape: %s\n", err.c_str());
    return 1;
  }
  std::fprintf(stderr, "odoerr tape: wrote %d cycles to %s\n", steps, out.c_str());
  return 0;
}

/// Records what the HAL devices show the firmware at each 1 ms poll of a simulated drive
/// (counters, laser bytes), for the firmware image's replay (firmware/apps/fw_replay).
template <template <typename> class DriveT>
int writeHalTape(const std::string& out, std::uint64_t seed, int steps, double corrupt) {
  using D = DriveT<double>;
  SimConfig cfg;
  cfg.radius = 4.5;  // clear of the walls (see tests/test_firmware_app.cpp)
  typename HalSimDrive<D>::Options opt;
  opt.faults.corrupt_probability = corrupt;
  HalSimDrive<D> world(cfg, seed, opt);
  FilterSetup setup;
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
  for (std::uint64_t t = 0; t <= end_us; t += 1000) {
    world.advanceTo(t);
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
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"odoerr: estimate the odometry error of a mobile robot during navigation"};
  app.require_subcommand(1);

  auto* paper = app.add_subcommand("paper", "Monte Carlo of the paper's experiment (Section 5)");
  std::string drive = "sync";
  int runs = 100;
  std::string out;
  std::uint64_t seed = 1;
  int threads = 2;
  bool no_plots = false;
  std::string pose_term = "expected";
  int window = 1;
  paper->add_option("--drive", drive, "sync or diff")->check(CLI::IsMember({"sync", "diff"}));
  paper->add_option("--runs", runs, "Monte Carlo runs per start (> 0)")
      ->check(CLI::PositiveNumber);
  paper->add_option("--out", out, "output directory")->required();
  paper->add_option("--seed", seed, "seed of run 0 (run r uses seed + r)");
  paper->add_option("--threads", threads, "worker threads")->check(CLI::Range(1, 64));
  paper->add_option("--window", window, "OF window j in cycles (1..16)")->check(CLI::Range(1, 16));
  paper->add_option("--pose-term", pose_term,
                    "OF pose-error term: expected (default) or literal (the paper read literally)")
      ->check(CLI::IsMember({"expected", "literal"}));
  paper->add_flag("--no-plots", no_plots, "skip the PNG figures");

  auto* sim = app.add_subcommand("sim", "simulate one closed-loop drive and write it as odolog v1");
  std::string sim_drive = "sync";
  std::string sim_out;
  std::uint64_t sim_seed = 1;
  int steps = 3000;
  std::string start = "small";
  sim->add_option("--drive", sim_drive, "sync or diff")->check(CLI::IsMember({"sync", "diff"}));
  sim->add_option("--out", sim_out, "odolog file to write")->required();
  sim->add_option("--seed", sim_seed, "random seed (the same seed as run r of `paper` when seed+r)");
  sim->add_option("--steps", steps, "cycles (1 cm each)")->check(CLI::Range(1, 10000000));
  sim->add_option("--start", start, "initial non-systematic estimate: small or large")
      ->check(CLI::IsMember({"small", "large"}));
  std::string scenario = "paper";
  std::vector<std::string> sim_effects;
  double minutes = 4.0;
  sim->add_option("--scenario", scenario,
                  "paper (the Section 5 circle) or excite (figure-eights at three speeds, reversals; "
                  "implied by --effect)")
      ->check(CLI::IsMember({"paper", "excite"}));
  sim->add_option("--effect", sim_effects, "inject a catalogue effect: NAME=V1[,V2...] (repeatable)");
  sim->add_option("--minutes", minutes, "length of an excite drive")->check(CLI::Range(0.05, 600.0));

  auto* diag = app.add_subcommand("diagnose", "does the model explain the measurements; which effect is missing");
  std::string dg_log, dg_json;
  DiagnoseOptions dg;
  diag->add_option("LOG", dg_log, "odolog v1 file")->required();
  diag->add_option("--json", dg_json, "result file (the contract in docs/diagnostics.md)")->required();
  diag->add_option("--with", dg.with,
                   "effects to add and compare on held-out data (comma separated): catalogue names, "
                   "feature:NAME@TARGET or feature:BEAM_FEATURE (the feature effects), or auto")
      ->delimiter(',');
  diag->add_option("--out", dg.out_dir, "also write scans.csv, beams.csv, trajectory.csv (and heldout_*.csv) here");
  diag->add_option("--map-cell", dg.map_cell_m, "grid cell of the residuals at the beams' hit points (m)")
      ->check(CLI::Range(0.02, 5.0));
  std::string map_beams = "exclude";
  diag->add_option("--map-beams", map_beams,
                   "beams ending where the map is wrong: exclude (from the ranking, the default) or keep")
      ->check(CLI::IsMember({"exclude", "keep"}));
  diag->add_option("--suggest", dg.suggest_dir,
                   "write DIR/discovered_effect.hpp, a C++ effect skeleton of the features discovery found");
  diag->add_option("--threads", dg.threads, "worker threads")->check(CLI::Range(1, 64));
  diag->add_option("--folds", dg.folds, "held-out comparison: cross-validation folds")->check(CLI::Range(1, 50));
  diag->add_option("--block-s", dg.block_s, "held-out comparison: block length (s)")->check(CLI::Range(0.5, 600.0));
  diag->add_option("--gap-s", dg.gap_s, "held-out comparison: data this close to a held-out block is not fitted (s)")
      ->check(CLI::Range(0.0, 60.0));

  auto* report = app.add_subcommand("report", "diagnose a drive and write a self-contained HTML report");
  std::string rp2_log, rp2_out;
  std::vector<std::string> rp2_with;
  report->add_option("LOG", rp2_log, "odolog v1 file")->required();
  report->add_option("--out", rp2_out, "output directory (report.html and its data)")->required();
  report->add_option("--with", rp2_with, "effects to add and compare on held-out data")->delimiter(',');

  auto* tape = app.add_subcommand("tape", "record one closed-loop drive as a core-replay tape (firmware tests)");
  std::string tape_drive = "diff";
  std::string tape_out;
  std::uint64_t tape_seed = 1;
  int tape_steps = 3000;
  int tape_every = 100;
  tape->add_option("--drive", tape_drive, "sync or diff")->check(CLI::IsMember({"sync", "diff"}));
  tape->add_option("--out", tape_out, "tape file to write")->required();
  tape->add_option("--seed", tape_seed, "random seed");
  tape->add_option("--steps", tape_steps, "cycles (1 cm each)")->check(CLI::Range(1, 10000000));
  tape->add_option("--record-every", tape_every, "replay output interval (cycles)")->check(CLI::Range(1, 1000000));

  auto* haltape = app.add_subcommand("hal-tape", "record the HAL devices of a simulated drive (firmware image tests)");
  std::string ht_drive = "diff";
  std::string ht_out;
  std::uint64_t ht_seed = 1;
  int ht_steps = 3000;
  double ht_corrupt = 0.0;
  haltape->add_option("--drive", ht_drive, "sync or diff")->check(CLI::IsMember({"sync", "diff"}));
  haltape->add_option("--out", ht_out, "tape file to write")->required();
  haltape->add_option("--seed", ht_seed, "random seed");
  haltape->add_option("--steps", ht_steps, "cm of travel")->check(CLI::Range(1, 1000000));
  haltape->add_option("--corrupt", ht_corrupt, "probability that a laser byte is corrupted")
      ->check(CLI::Range(0.0, 1.0));

  auto* replay = app.add_subcommand("replay", "run the estimator over an odolog drive");
  std::string rp_log;
  std::string rp_out;
  replay->add_option("LOG", rp_log, "odolog v1 file")->required();
  replay->add_option("--out", rp_out, "output directory")->required();
  double rp_cycle = 0.01;
  replay->add_option("--cycle-m", rp_cycle, "encoder travel per filter cycle (m)")->check(CLI::PositiveNumber);

  cli::Commands commands;
  registerCommands(app, commands);

  CLI11_PARSE(app, argc, argv);

  if (const int rc = commands.runParsed(); rc >= 0) return rc;

  if (paper->parsed()) {
    return runPaper(drive, runs, out, seed, threads, !no_plots, pose_term, window);
  }
  if (replay->parsed()) {
    Odolog log;
    std::string err;
    if (!readOdolog(rp_log, &log, &err)) {
      std::fprintf(stderr, "odoerr replay: %s\n", err.c_str());
      return 1;
    }
    if (!prepareOutDir(rp_out, &err)) {
      std::fprintf(stderr, "odoerr replay: %s\n", err.c_str());
      return 1;
    }
    ReplayOptions ro;
    ro.out_dir = rp_out;
    ro.cycle_m = rp_cycle;
    ReplaySummary sum;
    if (!replayOdolog(log, ro, &sum, &err)) {
      std::fprintf(stderr, "odoerr replay: %s\n", err.c_str());
      return 1;
    }
    std::fprintf(stderr, "odoerr replay: %zu cycles, %zu scans, %zu beams used (%zu gated), mean NIS %.3f",
                 sum.cycles, sum.scans, sum.beams_used, sum.beams_gated, sum.nis_mean);
    if (sum.pose_rmse_m >= 0) std::fprintf(stderr, ", pose RMSE %.4f m", sum.pose_rmse_m);
    std::fprintf(stderr, "; wrote %s/\n", rp_out.c_str());
    for (const auto& p : sum.params) std::printf("%-10s %.6g +- %.3g\n", p.name.c_str(), p.value, p.sigma);
    return 0;
  }
  if (haltape->parsed()) {
    return ht_drive == "sync" ? writeHalTape<SyncDrive>(ht_out, ht_seed, ht_steps, ht_corrupt)
                              : writeHalTape<DiffDrive>(ht_out, ht_seed, ht_steps, ht_corrupt);
  }
  if (tape->parsed()) {
    return tape_drive == "sync" ? writeTape<SyncDrive>(tape_out, tape_seed, tape_steps, tape_every)
                                : writeTape<DiffDrive>(tape_out, tape_seed, tape_steps, tape_every);
  }
  if (diag->parsed()) {
    dg.map_exclude = map_beams == "exclude";
    return runDiagnose(dg_log, dg_json, dg, false);
  }
  if (report->parsed()) {
    DiagnoseOptions rp;
    rp.out_dir = rp2_out;
    rp.with = rp2_with;
    const int rc = runDiagnose(rp2_log, (fs::path(rp2_out) / "diagnose.json").string(), rp, true);
    if (rc != 0) return rc;
    const std::string cmd = shellQuote(pythonInterpreter()) + " " + shellQuote(reportScript()) + " " + shellQuote(rp2_out);
    if (std::system(cmd.c_str()) != 0) {
      std::fprintf(stderr, "odoerr report: the page could not be made (%s)\n", cmd.c_str());
      return 1;
    }
    std::fprintf(stderr, "odoerr report: wrote %s/report.html\n", rp2_out.c_str());
    return 0;
  }
  if (sim->parsed() && (scenario == "excite" || !sim_effects.empty())) {
    EffectSimConfig ec;
    ec.drive = sim_drive;
    ec.seed = sim_seed;
    ec.minutes = minutes;
    std::string err;
    for (const auto& e : sim_effects) {
      if (!parseEffectArg(e, &ec, &err)) {
        std::fprintf(stderr, "odoerr sim: %s\n", err.c_str());
        return 2;
      }
    }
    std::string text;
    if (!simulateEffectDrive(ec, &text, &err) || !writeFile(sim_out, text, &err)) {
      std::fprintf(stderr, "odoerr sim: %s\n", err.c_str());
      return 1;
    }
    std::fprintf(stderr, "odoerr sim: wrote a %.1f-minute %s drive to %s\n", minutes, sim_drive.c_str(), sim_out.c_str());
    return 0;
  }
  if (sim->parsed()) {
    return sim_drive == "sync" ? writeSimLog<SyncDrive>(sim_out, sim_seed, steps, start)
                               : writeSimLog<DiffDrive>(sim_out, sim_seed, steps, start);
  }
  return 2;
}

// odoerr: the command-line tool.
//   odoerr paper --drive sync|diff --runs 100 --out DIR   the Monte Carlo of Section 5
//   odoerr sim   --drive sync|diff --seed 7 --out FILE    one simulated drive as odolog v1
//                [--effect NAME=V,...]... [--minutes M]     an exciting drive with effects injected
//   odoerr replay LOG --out DIR                            the estimator over a recorded drive
//   odoerr diagnose LOG --json OUT [--with E1,E2|auto] [--out DIR] [--suggest DIR]   model against measurements
//   odoerr report LOG --out DIR [--with E1,E2]             diagnose + a self-contained HTML page
#include <cerrno>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "cli.hpp"
#include "commands.hpp"
#include "odoerr/fw/hal_tape.hpp"
#include "odoerr/fw/tape.hpp"
#include "odoerr/sim/diagnose.hpp"
#include "odoerr/sim/effect_sim.hpp"
#include "odoerr/sim/hal_sim.hpp"
#include "odoerr/sim/odolog.hpp"
#include "odoerr/sim/odolog_writer.hpp"
#include "odoerr/sim/map_io.hpp"
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

int runDiagnose(const std::string& log_path, const std::string& json_path, DiagnoseOptions opt, bool quiet,
                const std::string& map_path = "", const cli::TuningArgs& tuning = {}) {
  const char* who = quiet ? "odoerr report" : "odoerr diagnose";
  Odolog log;
  std::string err;
  opt.tuning = tuning.tuning;
  if (!readOdolog(log_path, &log, &err) || (!map_path.empty() && !readMapWalls(map_path, &log.walls, &err)) ||
      !cli::applyK0(tuning, log.drive, &opt.k0_w, &opt.k0_rho, &opt.k0_theta, &err)) {
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
             int threads, bool plots, const std::string& pose_term, int window, const std::string& of, const KMlConfig<double>& ml,
             const std::string& path, double radius) {
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
  opt.of = of == "ml" ? OfKind::kMl : OfKind::kPaper;
  opt.ml = ml;
  if (path == "eight") {
    opt.sim.figure_eight = true;
    opt.sim.radius = 2.0;  // two 2 m lobes centred 2 m above and below the room's centre
  }
  if (radius > 0) {
    const double max_r = path == "eight" ? 2.5 : 5.0;  // inside the 10 m room
    if (radius > max_r) {
      std::fprintf(stderr, "odoerr paper: --radius %g is outside the room (at most %g m for --path %s)\n", radius,
                   max_r, path.c_str());
      return 1;
    }
    opt.sim.radius = radius;
  }
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
      !writeFile(dir / ("runs_" + drive + ".csv"), runsCsv(res, seed), &err) ||
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
  std::string of_kind = "paper";
  int ml_every = KMlConfig<double>{}.every;
  std::string path = "circle";
  double radius = 0;
  double ml_reset = KMlConfig<double>{}.reset_log;
  double ml_inflate = KMlConfig<double>{}.inflate;
  double ml_inflate_held = KMlConfig<double>{}.inflate_held;
  std::string ml_form = "pose";
  bool ml_no_discount = false;
  bool ml_no_credit = false;
  bool ml_line_shift = false;
  bool ml_no_deflate = false;
  bool ml_no_heading_scale = false;
  double ml_reset_keep = KMlConfig<double>{}.reset_keep;
  double ml_discount_above = KMlConfig<double>{}.discount_above;
  double ml_inflate_cap = std::round(std::exp(KMlConfig<double>{}.max_inflate_log));
  double ml_start_inflate_cap = std::round(std::exp(KMlConfig<double>{}.max_start_inflate_log));
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
  paper->add_option("--of", of_kind,
                    "non-systematic estimator: paper (the Observable Filter) or ml (recursive maximum "
                    "likelihood of K from the AKF's innovations; docs/nonsystematic.md)")
      ->check(CLI::IsMember({"paper", "ml"}));
  paper->add_option("--path", path,
                    "circle (the paper's 5 m circle) or eight (a figure-eight of two 2 m lobes, turning both "
                    "ways: excites delta_d)")
      ->check(CLI::IsMember({"circle", "eight"}));
  paper->add_option("--radius", radius,
                    "the circle's radius or the eight's lobe radius in m (default 5 or 2; the 5 m circle "
                    "touches the walls' midpoints)")
      ->check(CLI::Range(0.5, 5.0));
  int ml_solve_iters = KMlConfig<double>{}.solve_iters;
  paper->add_option("--ml-solve-iters", ml_solve_iters,
                    "ml, synchronous drive: iterations of each K step's solve (1: one Gauss-Newton step; "
                    "1..20)")
      ->capture_default_str()
      ->check(CLI::Range(1, 20));
  paper->add_option("--ml-every", ml_every, "ml: cycles between K steps (1..100)")->capture_default_str()->check(CLI::Range(1, 100));
  paper->add_option("--ml-reset", ml_reset,
                    "ml: restart the information and sensitivities when log K has moved this far (0: never)")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  paper->add_option("--ml-inflate", ml_inflate,
                    "ml: run the AKF with K exp(C sigma_logK - 0.3) while K is uncertain (0: off)")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  paper->add_option("--ml-inflate-held", ml_inflate_held,
                    "ml, diff drive with the heading noise's scale: the same C, on K_w's sigma with the "
                    "scale held (--ml-inflate 0 turns both off)")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  paper->add_option("--ml-inflate-cap", ml_inflate_cap, "ml: the inflation's cap, a factor on K (1..1000)")
      ->check(CLI::Range(1.0, 1000.0))
      ->capture_default_str();
  paper->add_option("--ml-start-inflate-cap", ml_start_inflate_cap,
                    "ml: the inflation's cap before the first K step, a factor on K (1..1000; 30 lost the pose "
                    "of a figure-eight from above)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1000.0));
  paper->add_flag("--ml-no-discount", ml_no_discount,
                  "ml: keep what the AKF knew of the systematic parameters when the K it predicts with "
                  "rises (by default it is discounted by the same factor, up to the prior)");
  paper->add_flag("--ml-no-credit", ml_no_credit,
                  "ml, sync drive from above: keep P's systematic block when K falls while inflated (by "
                  "default what the AKF gathered since its prior is credited by the fall)");
  paper->add_option("--ml-discount-above", ml_discount_above,
                    "ml: discount only when K has risen this many times above the smallest K the AKF "
                    "predicted with since the last discount")
      ->check(CLI::Range(1.0, 100.0))
      ->capture_default_str();
  paper->add_flag("--ml-line-shift", ml_line_shift,
                  "ml: carry the score from the inflated K to K along the Gauss-Newton line alone (by "
                  "default the smaller of the line and the variance-scale model)");
  paper->add_flag("--ml-no-deflate", ml_no_deflate,
                  "ml, diff drive: keep each step's information on K_w whole (by default it is deflated "
                  "by delta_d's uncertainty; only with --ml-no-heading-scale)");
  paper->add_flag("--ml-no-heading-scale", ml_no_heading_scale,
                  "ml, diff drive: estimate K_w alone, read through the AKF's delta_d (by default the "
                  "heading noise's scale, 1/delta_d^2 as the noise sees it, is estimated beside K_w with "
                  "the AKF's delta_d as its prior)");
  paper->add_option("--ml-reset-keep", ml_reset_keep, "ml: the share of the information a restart keeps (0..1)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  paper->add_option("--ml-form", ml_form,
                    "ml: each fused scan whole with the pose's sensitivities (pose, the default: the "
                    "firmware's form), each fused scan whole with every state's (scan), or each fused "
                    "beam (beam: the reference, a second ray cast a beam)")
      ->check(CLI::IsMember(std::vector<std::string>(std::begin(kKMlFormNames), std::end(kKMlFormNames))))
      ->capture_default_str();
  paper->add_flag("--no-plots", no_plots, "skip the PNG figures");

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
  std::string dg_map;
  diag->add_option("--map", dg_map, "the map to use instead of the log's walls (.odomap, or an odolog's walls)");
  diag->add_option("--map-cell", dg.map_cell_m, "grid cell of the residuals at the beams' hit points (m)")
      ->check(CLI::Range(0.02, 5.0));
  std::string map_beams = "exclude";
  diag->add_option("--map-beams", map_beams,
                   "beams ending where the map is wrong: exclude (from the ranking, the default) or keep")
      ->check(CLI::IsMember({"exclude", "keep"}));
  diag->add_option("--suggest", dg.suggest_dir,
                   "write DIR/discovered_effect.hpp, a C++ effect skeleton of the features discovery found");
  diag->add_option("--threads", dg.threads, "worker threads")->check(CLI::Range(1, 64));
  cli::TuningArgs dg_tuning;
  cli::addTuningOptions(diag, &dg_tuning);
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

  auto* replay = app.add_subcommand("replay", "run the estimator over an odolog drive");
  std::string rp_log;
  std::string rp_out;
  replay->add_option("LOG", rp_log, "odolog v1 file")->required();
  replay->add_option("--out", rp_out, "output directory")->required();
  double rp_cycle = 0.01;
  replay->add_option("--cycle-m", rp_cycle, "encoder travel per filter cycle (m)")->check(CLI::PositiveNumber);
  std::string rp_map;
  int rp_beams = 0;
  double rp_map_cell = -1;
  replay->add_option("--map", rp_map, "the map to use instead of the log's walls (.odomap, or an odolog's walls)");
  replay->add_option("--beams-used", rp_beams, "beams fused per scan, spread evenly (0: all)")->check(CLI::Range(0, 4095));
  replay->add_option("--map-index-cell", rp_map_cell, "grid cell of the map's ray-cast index (m; 0: none)")
      ->check(CLI::Range(0.0, 100.0));
  cli::TuningArgs rp_tuning;
  cli::addTuningOptions(replay, &rp_tuning);

  cli::Commands commands;
  registerCommands(app, commands);

  CLI11_PARSE(app, argc, argv);

  if (const int rc = commands.runParsed(); rc >= 0) return rc;

  if (paper->parsed()) {
    KMlConfig<double> mlc;
    mlc.every = ml_every;
    mlc.solve_iters = ml_solve_iters;
    mlc.reset_log = ml_reset;
    mlc.inflate = ml_inflate;
    mlc.inflate_held = ml_inflate_held;
    mlc.max_inflate_log = std::log(ml_inflate_cap);
    mlc.max_start_inflate_log = std::log(ml_start_inflate_cap);
    mlc.discount = !ml_no_discount;
    mlc.credit = !ml_no_credit;
    mlc.reset_keep = ml_reset_keep;
    mlc.discount_above = ml_discount_above;
    (void)parseKMlForm(ml_form, &mlc.form);  // CLI11 has checked the name
    mlc.scale_shift = !ml_line_shift;
    mlc.deflate = !ml_no_deflate;
    mlc.heading_scale = !ml_no_heading_scale;
    return runPaper(drive, runs, out, seed, threads, !no_plots, pose_term, window, of_kind, mlc, path, radius);
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
    if (!rp_map.empty() && !readMapWalls(rp_map, &log.walls, &err)) {
      std::fprintf(stderr, "odoerr replay: %s\n", err.c_str());
      return 1;
    }
    ReplayOptions ro;
    ro.out_dir = rp_out;
    ro.cycle_m = rp_cycle;
    ro.beams_used = rp_beams;
    ro.map_cell_m = rp_map_cell;
    if (!cli::applyK0(rp_tuning, log.drive, &ro.k0_w, &ro.k0_rho, &ro.k0_theta, &err)) {
      std::fprintf(stderr, "odoerr replay: %s\n", err.c_str());
      return 1;
    }
    ro.tuning = rp_tuning.tuning;
    ReplaySummary sum;
    if (!replayOdolog(log, ro, &sum, &err)) {
      std::fprintf(stderr, "odoerr replay: %s\n", err.c_str());
      return 1;
    }
    std::fprintf(stderr, "odoerr replay: %zu cycles, %zu scans, %zu beams used (%zu gated), mean NIS %.3f",
                 sum.cycles, sum.scans, sum.beams_used, sum.beams_gated, sum.nis_mean);
    if (sum.pose_rmse_m >= 0) std::fprintf(stderr, ", pose RMSE %.4f m", sum.pose_rmse_m);
    if (sum.pose_rmse_at_records_m >= 0) {
      std::fprintf(stderr, " (%.4f m at the %zu truth records)", sum.pose_rmse_at_records_m, sum.truth_records_scored);
    }
    std::fprintf(stderr, "; wrote %s/\n", rp_out.c_str());
    for (const auto& p : sum.params) std::printf("%-10s %.6g +- %.3g\n", p.name.c_str(), p.value, p.sigma);
    return 0;
  }
  if (diag->parsed()) {
    dg.map_exclude = map_beams == "exclude";
    return runDiagnose(dg_log, dg_json, dg, false, dg_map, dg_tuning);
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
  return 2;
}

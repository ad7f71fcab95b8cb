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

namespace fs = std::filesystem;
using namespace odoerr;
using namespace odoerr::sim;

namespace {

using cli::prepareOutDir;
using cli::ProgressBar;
using cli::pythonInterpreter;
using cli::shellQuote;
using cli::writeFile;

std::string reportScript() { return cli::scriptPath("ODOERR_REPORT_SCRIPT", ODOERR_REPORT_SCRIPT); }

/// The held-out comparison of `with` in one line: the pose error before and after, and the
/// paired z over the blocks (diagnose's JSON "heldout" or an "auto" step's).
void printHeldout(const char* what, const nlohmann::ordered_json& h) {
  const auto& b = h["before"]["pose_rmse_m"];
  const auto& a = h["after"]["pose_rmse_m"];
  if (!b.is_number() || !a.is_number()) return;
  std::fprintf(stderr, "  %s: held-out pose error %.1f -> %.1f mm", what, 1e3 * b.get<double>(), 1e3 * a.get<double>());
  if (h.contains("paired") && h["paired"]["pose_err_m"].is_object() && h["paired"]["pose_err_m"]["change_z"].is_number())
    std::fprintf(stderr, " (paired z %.1f over %d blocks)", h["paired"]["pose_err_m"]["change_z"].get<double>(),
                 h["paired"]["pose_err_m"]["blocks"].get<int>());
  std::fprintf(stderr, "\n");
}

/// What diagnose found beyond the verdict line: each effect `--with auto` kept, or the
/// held-out comparison of `--with`, and the regions where the map is wrong.
void printDiagnoseFindings(const nlohmann::ordered_json& r) {
  if (r.contains("auto") && r["auto"].is_object()) {
    for (const auto& st : r["auto"]["steps"]) {
      nlohmann::ordered_json h = st["heldout"];
      h["paired"] = st["paired"];
      std::string what = "added " + st["added"].get<std::string>();
      if (st.contains("estimate") && st["estimate"].is_object() && st["estimate"].contains(st["added"].get<std::string>())) {
        std::string est;
        for (const auto& v : st["estimate"][st["added"].get<std::string>()])
          if (v.is_number()) est += (est.empty() ? "" : ", ") + std::to_string(v.get<double>()).substr(0, 8);
        if (!est.empty()) what += " (" + est + ")";
      }
      printHeldout(what.c_str(), h);
    }
    if (r["auto"]["steps"].empty()) std::fprintf(stderr, "  --with auto: no step lowered the held-out error\n");
    if (r["auto"]["steps"].size() > 1 && r["auto"]["overall"].is_object())
      printHeldout("overall, against the model as it was", r["auto"]["overall"]);
  } else if (r.contains("heldout") && r["heldout"].is_object()) {
    std::string with;
    for (const auto& w : r["heldout"]["with"]) with += (with.empty() ? "" : ",") + w.get<std::string>();
    printHeldout(("with " + with).c_str(), r["heldout"]);
  }
  // Effects the ranking found significant and then took back, and why.
  if (r.contains("ranking") && r["ranking"].is_array())
    for (const auto& row : r["ranking"])
      if (row.contains("not_named_because"))
        std::fprintf(stderr, "  not named: %s: %s\n", row["effect"].get<std::string>().c_str(),
                     row["not_named_because"].get<std::string>().c_str());
  // The non-parametric step: what the misfit of the model as it was depends on.
  if (r.contains("dependence") && r["dependence"].is_object()) {
    const auto& d = r["dependence"]["baseline"];
    if (d.is_object() && d["found"].is_array())
      for (const auto& f : d["found"]) {
        std::string forms;
        for (const auto& s : f["selected_forms"]) forms += (forms.empty() ? "" : ", ") + s.get<std::string>();
        std::fprintf(stderr, "  the %s misfit depends on %s (%s): %.0f %% of it, p %.3f; %s\n",
                     f["component"].get<std::string>().c_str(), f["variable"].get<std::string>().c_str(),
                     f["variable_unit"].get<std::string>().c_str(), 100 * f["explained"].get<double>(),
                     f["p_adjusted"].get<double>(),
                     forms.empty() ? "no form of the library in it was selected" : ("selected: " + forms).c_str());
      }
    if (d.is_object() && d["follows_misfit"].is_array())
      for (const auto& f : d["follows_misfit"])
        std::fprintf(stderr, "  the %s misfit goes with %s, which follows it (the next segment's %s explains %.0f %%, "
                     "its own %.0f %%: a controller answering the error?): not a lead\n",
                     f["component"].get<std::string>().c_str(), f["variable"].get<std::string>().c_str(),
                     f["variable"].get<std::string>().c_str(), 100 * f["explained_next"].get<double>(),
                     100 * f["explained"].get<double>());
  }
  if (r.contains("map_misfit") && r["map_misfit"].is_object() && r["map_misfit"]["regions"].is_array() &&
      !r["map_misfit"]["regions"].empty()) {
    const auto& regs = r["map_misfit"]["regions"];
    std::fprintf(stderr, "  the map is wrong in %zu region(s); the strongest at (%.2f, %.2f) m, ranges %s than the map says\n",
                 regs.size(), regs[0]["x"].get<double>(), regs[0]["y"].get<double>(),
                 regs[0]["sign"].get<std::string>() == "short" ? "shorter" : "longer");
  }
}

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
  if (result.contains("verdict_detail"))
    std::fprintf(stderr, "%s: %s\n", who, result["verdict_detail"].get<std::string>().c_str());
  for (const auto& c : result["verdict_caveats"]) std::fprintf(stderr, "%s: but: %s\n", who, c.get<std::string>().c_str());
  if (result.contains("verdict_missing")) {
    for (const auto& m : result["verdict_missing"]) std::fprintf(stderr, "%s: missing: %s\n", who, m.get<std::string>().c_str());
    // No verdict: exit 3 for diagnose (docs/diagnostics.md, "Exit status"); the report still
    // draws its page, which says so.
    return quiet ? 0 : 3;
  }
  if (!quiet) printDiagnoseFindings(result);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"odoerr: estimate the odometry error of a mobile robot during navigation"};
  app.require_subcommand(1);

  cli::Commands commands;
  registerPaperCommand(app, commands);  // first in --help, as the first job

  auto* diag = app.add_subcommand("diagnose", "does the model explain the measurements; which effect is missing");
  std::string dg_log, dg_json;
  DiagnoseOptions dg;
  diag->add_option("LOG", dg_log, "odolog v1 file")->required();
  diag->add_option("--json", dg_json, "result file (the contract in docs/diagnostics.md)")->required();
  diag->add_option("--with", dg.with,
                   "effects to add and compare on held-out data (comma separated): catalogue names, "
                   "feature:NAME@TARGET or feature:BEAM_FEATURE (the feature effects), or auto")
      ->delimiter(',');
  diag->add_option("--change-at", dg.change_at_s,
                   "the time t_c (s, the log's clock) of the step features in --with (feature:ds_R_after@wheel_R, "
                   "ds_L_after, ds_after, dth_after): a change point's time");
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
  std::string rp2_map;
  report->add_option("--map", rp2_map, "the map to use instead of the log's walls (.odomap, or an odolog's walls)");
  cli::TuningArgs rp2_tuning;
  cli::addTuningOptions(report, &rp2_tuning);

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
  bool rp_reloc = false;
  replay->add_flag("--relocalise", rp_reloc,
                   "check every scan's fit to the map, declare a lost track and find the robot again "
                   "(tracking.csv, replay.json 'tracking'; docs/calibrate.md, \"Lost and found\")");
  bool rp_stop_lost = false;
  replay->add_flag("--stop-when-lost", rp_stop_lost,
                   "with --relocalise: a declared loss ends the replay (no search; to score settings by "
                   "whether they keep the track)");

  registerCommands(app, commands);

  CLI11_PARSE(app, argc, argv);

  if (const int rc = commands.runParsed(); rc >= 0) return rc;

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
    ro.relocalise = rp_reloc;
    ro.stop_when_lost = rp_stop_lost;
    if (rp_stop_lost && !rp_reloc) {
      std::fprintf(stderr, "odoerr replay: --stop-when-lost needs --relocalise (it ends the replay at a declared loss)\n");
      return 2;
    }
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
    if (!log.enc_rejected.empty()) std::fprintf(stderr, "odoerr replay: %s\n", rejectionSummary(log).c_str());
    if (rp_reloc) {
      std::size_t rec = 0;
      for (const auto& e : sum.episodes) rec += e.t_recovered >= 0;
      std::fprintf(stderr, "odoerr replay: tracking: median fit %.2f over %zu scans; %zu lost, %zu recovered%s\n",
                   sum.fit_median, sum.scans_checked, sum.episodes.size(), rec,
                   sum.lost_at_end ? "; LOST at the end: the parameters are those from before the loss" : "");
    }
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
    const int rc = runDiagnose(rp2_log, (fs::path(rp2_out) / "diagnose.json").string(), rp, true, rp2_map, rp2_tuning);
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

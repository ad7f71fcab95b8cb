// odoerr tool: `odoerr paper` (and the stand-alone `odoerr-paper`, the main job's binary) —
// the Monte Carlo of the paper's experiment (Section 5), both estimators of K.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "cli.hpp"
#include "commands.hpp"
#include "odoerr/sim/paper_experiment.hpp"

namespace fs = std::filesystem;

namespace odoerr {
namespace {

using namespace odoerr::sim;
using cli::prepareOutDir;
using cli::ProgressBar;
using cli::pythonInterpreter;
using cli::shellQuote;
using cli::writeFile;

std::string plotScript() { return cli::scriptPath("ODOERR_PLOT_SCRIPT", ODOERR_PLOT_SCRIPT); }

struct PaperArgs {
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
  int ml_solve_iters = KMlConfig<double>{}.solve_iters;
};

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

std::function<int()> addPaperOptions(CLI::App* sub) {
  auto a = std::make_shared<PaperArgs>();
  sub->add_option("--drive", a->drive, "sync or diff")->check(CLI::IsMember({"sync", "diff"}));
  sub->add_option("--runs", a->runs, "Monte Carlo runs per start (> 0)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--out", a->out, "output directory")->required();
  sub->add_option("--seed", a->seed, "seed of run 0 (run r uses seed + r)");
  sub->add_option("--threads", a->threads, "worker threads")->check(CLI::Range(1, 64));
  sub->add_option("--window", a->window, "OF window j in cycles (1..16)")->check(CLI::Range(1, 16));
  sub->add_option("--pose-term", a->pose_term,
                    "OF pose-error term: expected (default) or literal (the paper read literally)")
      ->check(CLI::IsMember({"expected", "literal"}));
  sub->add_option("--of", a->of_kind,
                    "non-systematic estimator: paper (the Observable Filter) or ml (recursive maximum "
                    "likelihood of K from the AKF's innovations; docs/nonsystematic.md)")
      ->check(CLI::IsMember({"paper", "ml"}));
  sub->add_option("--path", a->path,
                    "circle (the paper's 5 m circle) or eight (a figure-eight of two 2 m lobes, turning both "
                    "ways: excites delta_d)")
      ->check(CLI::IsMember({"circle", "eight"}));
  sub->add_option("--radius", a->radius,
                    "the circle's radius or the eight's lobe radius in m (default 5 or 2; the 5 m circle "
                    "touches the walls' midpoints)")
      ->check(CLI::Range(0.5, 5.0));
  sub->add_option("--ml-solve-iters", a->ml_solve_iters,
                    "ml, synchronous drive: iterations of each K step's solve (1: one Gauss-Newton step; "
                    "1..20)")
      ->capture_default_str()
      ->check(CLI::Range(1, 20));
  sub->add_option("--ml-every", a->ml_every, "ml: cycles between K steps (1..100)")->capture_default_str()->check(CLI::Range(1, 100));
  sub->add_option("--ml-reset", a->ml_reset,
                    "ml: restart the information and sensitivities when log K has moved this far (0: never)")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  sub->add_option("--ml-inflate", a->ml_inflate,
                    "ml: run the AKF with K exp(C sigma_logK - 0.3) while K is uncertain (0: off)")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  sub->add_option("--ml-inflate-held", a->ml_inflate_held,
                    "ml, diff drive with the heading noise's scale: the same C, on K_w's sigma with the "
                    "scale held (--ml-inflate 0 turns both off)")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  sub->add_option("--ml-inflate-cap", a->ml_inflate_cap, "ml: the inflation's cap, a factor on K (1..1000)")
      ->check(CLI::Range(1.0, 1000.0))
      ->capture_default_str();
  sub->add_option("--ml-start-inflate-cap", a->ml_start_inflate_cap,
                    "ml: the inflation's cap before the first K step, a factor on K (1..1000; 30 lost the pose "
                    "of a figure-eight from above)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1000.0));
  sub->add_flag("--ml-no-discount", a->ml_no_discount,
                  "ml: keep what the AKF knew of the systematic parameters when the K it predicts with "
                  "rises (by default it is discounted by the same factor, up to the prior)");
  sub->add_flag("--ml-no-credit", a->ml_no_credit,
                  "ml, sync drive from above: keep P's systematic block when K falls while inflated (by "
                  "default what the AKF gathered since its prior is credited by the fall)");
  sub->add_option("--ml-discount-above", a->ml_discount_above,
                    "ml: discount only when K has risen this many times above the smallest K the AKF "
                    "predicted with since the last discount")
      ->check(CLI::Range(1.0, 100.0))
      ->capture_default_str();
  sub->add_flag("--ml-line-shift", a->ml_line_shift,
                  "ml: carry the score from the inflated K to K along the Gauss-Newton line alone (by "
                  "default the smaller of the line and the variance-scale model)");
  sub->add_flag("--ml-no-deflate", a->ml_no_deflate,
                  "ml, diff drive: keep each step's information on K_w whole (by default it is deflated "
                  "by delta_d's uncertainty; only with --ml-no-heading-scale)");
  sub->add_flag("--ml-no-heading-scale", a->ml_no_heading_scale,
                  "ml, diff drive: estimate K_w alone, read through the AKF's delta_d (by default the "
                  "heading noise's scale, 1/delta_d^2 as the noise sees it, is estimated beside K_w with "
                  "the AKF's delta_d as its prior)");
  sub->add_option("--ml-reset-keep", a->ml_reset_keep, "ml: the share of the information a restart keeps (0..1)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  sub->add_option("--ml-form", a->ml_form,
                    "ml: each fused scan whole with the pose's sensitivities (pose, the default: the "
                    "firmware's form), each fused scan whole with every state's (scan), or each fused "
                    "beam (beam: the reference, a second ray cast a beam)")
      ->check(CLI::IsMember(std::vector<std::string>(std::begin(kKMlFormNames), std::end(kKMlFormNames))))
      ->capture_default_str();
  sub->add_flag("--no-plots", a->no_plots, "skip the PNG figures");
  return [a]() {
    KMlConfig<double> mlc;
    mlc.every = a->ml_every;
    mlc.solve_iters = a->ml_solve_iters;
    mlc.reset_log = a->ml_reset;
    mlc.inflate = a->ml_inflate;
    mlc.inflate_held = a->ml_inflate_held;
    mlc.max_inflate_log = std::log(a->ml_inflate_cap);
    mlc.max_start_inflate_log = std::log(a->ml_start_inflate_cap);
    mlc.discount = !a->ml_no_discount;
    mlc.credit = !a->ml_no_credit;
    mlc.reset_keep = a->ml_reset_keep;
    mlc.discount_above = a->ml_discount_above;
    (void)parseKMlForm(a->ml_form, &mlc.form);  // CLI11 has checked the name
    mlc.scale_shift = !a->ml_line_shift;
    mlc.deflate = !a->ml_no_deflate;
    mlc.heading_scale = !a->ml_no_heading_scale;
    return runPaper(a->drive, a->runs, a->out, a->seed, a->threads, !a->no_plots, a->pose_term, a->window,
                    a->of_kind, mlc, a->path, a->radius);
  };
}

void registerPaperCommand(CLI::App& app, cli::Commands& cmds) {
  CLI::App* sub = app.add_subcommand("paper", "Monte Carlo of the paper's experiment (Section 5)");
  cmds.add(sub, addPaperOptions(sub));
}

}  // namespace odoerr

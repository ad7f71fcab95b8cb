// odoerr tool: `odoerr bound` — the Cramér-Rao bound of every estimated quantity along a
// drive: a simulated drive of the paper's experiment, or an odolog file with truth
// (sim_host/include/odoerr/sim/bound.hpp; docs/nonsystematic.md).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli.hpp"
#include "commands.hpp"
#include "odoerr/sim/bound.hpp"
#include "odoerr/sim/odolog.hpp"

namespace odoerr {
namespace {

struct BoundArgs {
  std::string log;
  std::string json;
  std::string drive = "sync";
  std::uint64_t seed = 1;
  int steps = 3000;
  double every_m = 1.0;
  double cycle_m = 0.01;
  std::vector<std::string> truth;
  std::string dump;
  std::string path = "circle";
  double systematic_prior_scale = 1.0;
};

int runBound(const BoundArgs& a, bool drive_given, bool sim_only_given) {
  using namespace odoerr::sim;
  BoundOptions opt;
  opt.every_m = a.every_m;
  opt.dump_path = a.dump;
  opt.systematic_prior_scale = a.systematic_prior_scale;
  BoundResult res;
  std::string err;
  if (a.log.empty()) {
    if (!a.truth.empty()) {
      std::fprintf(stderr, "odoerr bound: --truth applies to a log; a simulated drive knows its truth\n");
      return 1;
    }
    SimConfig cfg;
    cfg.steps = a.steps;
    if (a.path == "eight") {  // as odoerr paper --path eight
      cfg.figure_eight = true;
      cfg.radius = 2.0;
    }
    if (!boundOfSimulatedDrive(a.drive == "sync" ? DriveKind::kSync : DriveKind::kDiff, cfg, a.seed, FilterSetup{},
                               opt, &res, &err)) {
      std::fprintf(stderr, "odoerr bound: %s\n", err.c_str());
      return 1;
    }
  } else {
    if (drive_given || sim_only_given) {
      std::fprintf(stderr, "odoerr bound: --drive, --seed, --steps and --path describe a simulated drive; a log gives its own\n");
      return 1;
    }
    Odolog log;
    std::vector<std::pair<std::string, double>> truth;
    if (!readOdolog(a.log, &log, &err) || !truthOfOdolog(log, a.truth, &truth, &err) ||
        !boundOfOdolog(log, truth, a.cycle_m, opt, &res, &err)) {
      std::fprintf(stderr, "odoerr bound: %s\n", err.c_str());
      return 1;
    }
  }
  if (!cli::writeFile(a.json, boundJson(res).dump(2) + "\n", &err)) {
    std::fprintf(stderr, "odoerr bound: %s\n", err.c_str());
    return 1;
  }
  const BoundPoint& f = res.final_point;
  std::fprintf(stderr, "odoerr bound: %s %s, %.2f m, %d cycles, %llu beams in %.2f s; wrote %s\n", res.source.c_str(),
               res.drive.c_str(), f.distance_m, res.cycles, static_cast<unsigned long long>(res.beams), res.seconds,
               a.json.c_str());
  std::printf("position  sigma %.4g m, heading sigma %.4g rad\n", f.position_sigma_m, f.heading_sigma_rad);
  auto line = [](const BoundValue& v) {
    if (v.sigma < 0) {
      std::printf("%-10s true %.6g  bound undefined (no information yet)\n", v.name.c_str(), v.truth);
    } else if (v.bound_pct < 0) {
      std::printf("%-10s true %.6g  sigma %.4g\n", v.name.c_str(), v.truth, v.sigma);
    } else {
      std::printf("%-10s true %.6g  sigma %.4g  bound %.3g %%\n", v.name.c_str(), v.truth, v.sigma, v.bound_pct);
    }
  };
  for (const auto& v : f.systematic) line(v);
  for (const auto& v : f.nonsystematic) line(v);
  std::printf("with the systematic parameters unknown (joint information of K and delta):\n");
  for (const auto& v : f.nonsystematic_delta_unknown) line(v);
  return 0;
}

}  // namespace

void registerBoundCommand(CLI::App& app, cli::Commands& cmds) {
  auto a = std::make_shared<BoundArgs>();
  CLI::App* sub = app.add_subcommand(
      "bound", "the Cramér-Rao bound of the pose, systematic and non-systematic parameters along a drive");
  sub->add_option("LOG", a->log, "odolog v1 file with truth records (default: a simulated drive of the paper's experiment)");
  sub->add_option("--json", a->json, "result file (schema in docs/nonsystematic.md)")->required();
  auto* drive = sub->add_option("--drive", a->drive, "simulated drive: sync or diff")->check(CLI::IsMember({"sync", "diff"}));
  auto* seed = sub->add_option("--seed", a->seed, "simulated drive: the experiment's run with this seed");
  auto* steps = sub->add_option("--steps", a->steps, "simulated drive: cycles (1 cm each; 3000 = 30 m)")
                    ->check(CLI::PositiveNumber);
  sub->add_option("--every-m", a->every_m, "spacing of the along-path records (m)")->check(CLI::Range(0.001, 1e6));
  sub->add_option("--cycle-m", a->cycle_m, "log: encoder travel per filter cycle (m), as in replay")
      ->check(CLI::PositiveNumber);
  sub->add_option("--truth", a->truth, "log: true values NAME=V (overrides the log's 'meta truth')")->delimiter(',');
  sub->add_option("--dump-linearisation", a->dump,
                  "write the per-cycle F, G, dQ/dK and beam rows H as JSON (for an independent check)");
  auto* path = sub->add_option("--path", a->path, "simulated drive: circle (the paper's) or eight (as odoerr paper --path eight)")
                   ->check(CLI::IsMember({"circle", "eight"}));
  sub->add_option("--systematic-prior-scale", a->systematic_prior_scale,
                  "scale the prior sigma of the systematic parameters (1: the filter's; small: delta known)")
      ->check(CLI::Range(1e-12, 1e6));
  cmds.add(sub, [a, drive, seed, steps, path]() {
    return runBound(*a, drive->count() > 0, seed->count() > 0 || steps->count() > 0 || path->count() > 0);
  });
}

}  // namespace odoerr

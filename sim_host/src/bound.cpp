// sim_host: `odoerr bound` on a simulated drive of the paper's experiment (the true path
// handed to the recursions of bound_engine.hpp), and the JSON of any bound. A logged drive's
// is in bound_log.cpp, so that the experiment (odoerr::paper) links without the log reader.
#include "odoerr/sim/bound.hpp"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "bound_engine.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/sim/host_map.hpp"
#include "odoerr/sim/runner.hpp"

namespace odoerr::sim {

namespace {

using bound_detail::PathCycle;
using bound_detail::Problem;
using bound_detail::priorCovariance;

template <template <typename> class DriveT>
bool simBound(const SimConfig& cfg, std::uint64_t seed, const FilterSetup& setup, const BoundOptions& opt,
              BoundResult* out, std::string* error) {
  using D = DriveT<double>;
  using ModelT = Model<D>;
  PaperSim<D> sim(cfg, seed);
  std::vector<PathCycle<typename D::Input>> path;
  path.reserve(std::size_t(cfg.steps));
  Pose<double> before = sim.truth();
  const int beams = cfg.laser.beams;
  StepSink<D> sink = [&](const SimStep<D>& st) {
    PathCycle<typename D::Input> c;
    c.u = st.input;
    c.before = before;
    c.after = st.truth;
    c.scan = true;
    for (int i = 0; i < beams; ++i)
      if (std::isfinite(st.ranges[i])) c.beams.push_back(i);
    before = st.truth;
    path.push_back(std::move(c));
  };
  // The drive as the experiment's run `seed` makes it (closed loop on its estimate).
  (void)runDrive<double, DriveT>(cfg, seed, NonSysStart::kSmall, setup, cfg.steps, sink);

  D drive;
  if constexpr (!PaperSim<D>::kSync) drive.wheelbase = cfg.wheelbase_m;
  Problem<ModelT> pb{ModelT(drive), ModelT::StateVec::Zero(), sim.trueNonSys(), {}, 0};
  pb.truth_params.template segment<D::kParams>(ModelT::kDriveOffset) = sim.trueParams();
  pb.p0 = priorCovariance<ModelT>(setup, setup.sigma_pose_xy, setup.sigma_pose_xy, setup.sigma_pose_theta);
  pb.min_cos_incidence = std::cos(setup.akf.max_incidence_rad);
  LaserGeometry<double, kMaxBeams> laser;
  if (!laser.init(cfg.laser)) {
    *error = "the simulated laser set-up is not usable";
    return false;
  }
  out->source = "sim";
  out->drive = PaperSim<D>::kSync ? "sync" : "diff";
  return bound_detail::runBound(pb, bound_detail::beamPredictor<ModelT>(sim.map(), laser, pb.min_cos_incidence),
                                laser.config().sigma, path, opt, out, error);
}

}  // namespace

// The recursion of both drives, for the simulated drive here and the logged one
// (bound_log.cpp).
namespace bound_detail {
template bool runBound<Model<SyncDrive<double>>>(const Problem<Model<SyncDrive<double>>>&, const BeamPredictor&, double,
                                                 const std::vector<PathCycle<SyncDrive<double>::Input>>&,
                                                 const BoundOptions&, BoundResult*, std::string*);
template bool runBound<Model<DiffDrive<double>>>(const Problem<Model<DiffDrive<double>>>&, const BeamPredictor&, double,
                                                 const std::vector<PathCycle<DiffDrive<double>::Input>>&,
                                                 const BoundOptions&, BoundResult*, std::string*);
}  // namespace bound_detail

bool boundOfSimulatedDrive(DriveKind drive, const SimConfig& cfg, std::uint64_t seed, const FilterSetup& setup,
                           const BoundOptions& opt, BoundResult* out, std::string* error) {
  if (!(opt.every_m > 0)) {
    *error = "the record spacing must be positive";
    return false;
  }
  if (cfg.steps <= 0) {
    *error = "the drive needs at least one cycle";
    return false;
  }
  *out = BoundResult{};
  const auto t0 = std::chrono::steady_clock::now();
  const bool ok = drive == DriveKind::kSync ? simBound<SyncDrive>(cfg, seed, setup, opt, out, error)
                                            : simBound<DiffDrive>(cfg, seed, setup, opt, out, error);
  out->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return ok;
}

namespace {
using json = nlohmann::ordered_json;

json orNull(double v) { return v >= 0 ? json(v) : json(nullptr); }

json values(const std::vector<BoundValue>& vs) {
  json j = json::object();
  for (const BoundValue& v : vs) j[v.name] = {{"true", v.truth}, {"sigma", orNull(v.sigma)}, {"bound_pct", orNull(v.bound_pct)}};
  return j;
}

json point(const BoundPoint& p) {
  json j;
  j["distance_m"] = p.distance_m;
  j["cycles"] = p.cycles;
  j["pose"] = {{"x_sigma_m", p.x_sigma_m},
               {"y_sigma_m", p.y_sigma_m},
               {"position_sigma_m", p.position_sigma_m},
               {"heading_sigma_rad", p.heading_sigma_rad}};
  j["systematic"] = values(p.systematic);
  j["nonsystematic"] = values(p.nonsystematic);
  j["nonsystematic_covariance_term_only"] = values(p.nonsystematic_cov_term);
  j["fisher_K"] = p.fisher;
  j["fisher_K_covariance_term"] = p.fisher_cov_term;
  j["nonsystematic_delta_unknown"] = values(p.nonsystematic_delta_unknown);
  j["nonsystematic_delta_given_pose_model"] = values(p.nonsystematic_delta_given);
  j["systematic_joint"] = values(p.systematic_joint);
  j["fisher_K_delta"] = p.fisher_joint;
  return j;
}
}  // namespace

nlohmann::ordered_json boundJson(const BoundResult& r) {
  json j;
  j["source"] = r.source;
  j["drive"] = r.drive;
  j["cycles"] = r.cycles;
  j["scans"] = r.scans;
  j["beams"] = r.beams;
  j["beams_not_predictable_at_truth"] = r.beams_skipped;
  j["self_check_max_rel_cov_mismatch"] = r.max_cov_mismatch;
  j["seconds"] = r.seconds;
  j["final"] = point(r.final_point);
  json along = json::array();
  for (const BoundPoint& p : r.along) along.push_back(point(p));
  j["along_path"] = along;
  return j;
}

}  // namespace odoerr::sim

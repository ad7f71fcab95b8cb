#include "excitation.hpp"

#include <cmath>

namespace odoerr::sim::diag {

namespace {
using json = nlohmann::ordered_json;
}  // namespace

const char* adviceFor(const std::string& name) {
  if (name == "delta_d" || name == "delta_R" || name == "delta_L")
    return "drive turns of different radii in both directions (a figure-eight), not one constant circle";
  if (name == "delta_rho") return "drive straight segments of a few metres towards and away from walls";
  if (name == "E_theta") return "drive longer distances between turns; the bound falls as 1/sqrt(distance)";
  if (name == "turn_slip") return "turn at several speeds (v*w must vary), both ways";
  if (name == "rotation_slip") return "turn at several turn rates, both ways";
  if (name == "speed_scale") return "drive the same paths at clearly different speeds";
  if (name == "wheel_eccentricity") return "drive several wheel revolutions in straight lines between scans";
  if (name == "backlash") return "reverse the direction of travel many times";
  if (name == "region_scale") return "drive through every part of the room";
  if (name == "radius_drift") return "drive longer (the effect grows with distance)";
  if (name == "turn_noise") return "turn more, and also drive straight, so turning noise separates from wheel noise";
  if (name == "range_bias" || name == "range_scale")
    return "drive close to and far from the walls (ranges must vary), in a map whose size is certain";
  if (name == "laser_mount_xy" || name == "laser_mount_yaw") return "turn in place and along curves near walls";
  if (name == "scan_latency") return "turn and drive at higher speed (latency shows only while moving)";
  if (name == "wall_offset") return "see every wall from several distances and angles";
  if (name == "wheel_speed_scale")
    return "turn at several speeds both ways and turn in place, so each wheel runs at several speeds (differential drive only)";
  if (name == "wheel_backlash")
    return "reverse each wheel many times: turns in place both ways and tight turns while driving, not only straight "
           "reversals (differential drive only)";
  return "vary the motion";
}

template <template <typename> class DriveT>
json excitationReport(const Engine<DriveT>& en, const typename Engine<DriveT>::RunOut& base_free,
                      const std::vector<Candidate>& cand, bool has_laser) {
  using En = Engine<DriveT>;
  using Drive = typename En::Drive;
  constexpr int kD = En::kD;
  constexpr bool kSync = En::kSync;
  const auto& fx = en.effects();
  const int ne = static_cast<int>(fx.size());
  json ex_params = json::array();
  json warnings = json::array();
  fw::FilterSetup setup;
  for (int i = 0; i < Drive::kParams; ++i) {
    const int k = kD + i;
    const double prior = (kSync && i == 1) ? setup.sigma_e_theta : setup.sigma_scale;
    const double s = std::sqrt(base_free.p(k, k));
    ex_params.push_back({{"name", Drive::kParamNames[i]}, {"sigma_achievable", s}, {"prior_sigma", prior},
                         {"determined", s < 0.25 * prior}});
  }
  for (int i = 0; i < Drive::kParams; ++i) {
    for (int j = i + 1; j < Drive::kParams; ++j) {
      const int a = kD + i, b = kD + j;
      // with the others marginalised: solve for the combination that the drive cannot fix
      const double c = base_free.p(a, b) / std::sqrt(base_free.p(a, a) * base_free.p(b, b));
      if (std::abs(c) > 0.95) {
        warnings.push_back(std::string("This drive cannot separate ") + Drive::kParamNames[i] + " from " +
                           Drive::kParamNames[j] + " (correlation " + std::to_string(c).substr(0, 5) + "): " +
                           adviceFor(Drive::kParamNames[j]) + ".");
      }
    }
  }
  for (int i = 0; i < Drive::kParams; ++i) {
    const double prior = (kSync && i == 1) ? setup.sigma_e_theta : setup.sigma_scale;
    const double s = std::sqrt(base_free.p(kD + i, kD + i));
    if (!(s < 0.25 * prior)) {
      warnings.push_back(std::string("This drive leaves ") + Drive::kParamNames[i] + " poorly determined (sigma " +
                         std::to_string(s) + "): " + adviceFor(Drive::kParamNames[i]) + ".");
    }
  }
  for (int e = 0; e < ne; ++e) {
    const EffectInfo& f = fx[e];
    bool det = false;
    for (int i = 0; i < f.n; ++i) {
      const double s = cand[e].sig[i];
      ex_params.push_back({{"name", f.name + "." + f.pnames[i]}, {"sigma_achievable", s},
                           {"prior_sigma", f.prior[i]}, {"reference_size", f.ref[i]},
                           {"determined", cand[e].informed[i] && s < f.ref[i] / 3}});
      det = det || (cand[e].informed[i] && s < f.ref[i] / 3);
    }
    // A measurement effect needs the laser: without one, no drive could show it.
    if (!det && f.kind == EffectKind::kMeasurement && !has_laser) {
      for (int i = 0; i < f.n; ++i) ex_params[ex_params.size() - 1 - i]["note"] = "needs a laser; the log has none";
      continue;
    }
    if (!det) {
      warnings.push_back("This drive cannot detect " + f.name + " of a typical size (" + std::to_string(f.ref[0]) +
                         "): " + adviceFor(f.name) + ".");
    }
  }
  return {{"parameters", ex_params}, {"warnings", warnings}};
}

template json excitationReport<SyncDrive>(const Engine<SyncDrive>&, const Engine<SyncDrive>::RunOut&,
                                          const std::vector<Candidate>&, bool);
template json excitationReport<DiffDrive>(const Engine<DiffDrive>&, const Engine<DiffDrive>::RunOut&,
                                          const std::vector<Candidate>&, bool);

}  // namespace odoerr::sim::diag

#include "odoerr/sim/stats.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/non_central_chi_squared.hpp>

namespace odoerr::sim {

using json = nlohmann::ordered_json;

const char* statusName(Status s) {
  switch (s) {
    case Status::kOk: return "used";
    case Status::kBadInput: return "bad_input";
    case Status::kNoReturn: return "no_return";
    case Status::kNoMapHit: return "no_map_hit";
    case Status::kGrazing: return "grazing";
    case Status::kTooClose: return "too_close";
    case Status::kGated: return "gated";
    case Status::kBadInnovation: return "bad_innovation";
    case Status::kBadCovariance: return "bad_covariance";
  }
  return "?";
}

namespace {

// The laser statistics report 0 for an empty mean or t (their callers guard what matters).
double orZero(const std::optional<double>& v) { return v.value_or(0.0); }
using Acc = Moments;

/// Pose correction of a scan update in the robot frame: along, cross, heading.
void correction(const ScanRec& r, double* along, double* cross, double* head) {
  const double dx = r.x1 - r.x, dy = r.y1 - r.y;
  const double c = std::cos(r.th), s = std::sin(r.th);
  *along = c * dx + s * dy;
  *cross = -s * dx + c * dy;
  *head = wrapAngle(r.th1 - r.th);
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = q * double(v.size() - 1);
  const std::size_t i = static_cast<std::size_t>(pos);
  const double f = pos - double(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

}  // namespace

json ljungBox(const std::vector<double>& series) {
  const int ns = static_cast<int>(series.size());
  if (ns < 2) return nullptr;
  const int lags = std::max(1, std::min(20, ns / 5));
  double mean = 0;
  for (double v : series) mean += v;
  mean /= ns;
  double c0 = 0;
  for (double v : series) c0 += (v - mean) * (v - mean);
  if (!(c0 > 0)) return nullptr;
  double q = 0;
  json acf = json::array();
  for (int k = 1; k <= lags && k < ns; ++k) {
    double ck = 0;
    for (int i = k; i < ns; ++i) ck += (series[i] - mean) * (series[i - k] - mean);
    const double rho = ck / c0;
    acf.push_back(rho);
    q += rho * rho / double(ns - k);
  }
  q *= double(ns) * double(ns + 2);
  return {{"lags", lags}, {"q", q}, {"p_value", chiSquareSf(q, lags)}, {"acf", acf}};
}

double chiSquareSf(double x, double k) {
  if (!(x > 0)) return 1.0;
  const boost::math::chi_squared_distribution<double> d(k);
  return boost::math::cdf(boost::math::complement(d, x));
}

double chiSquareQuantile(double p, double k) {
  const boost::math::chi_squared_distribution<double> d(k);
  return boost::math::quantile(d, p);
}

double noncentralityForPower(double k, double threshold, double power) {
  // The CDF at the threshold is 1 - power.
  return boost::math::non_central_chi_squared_distribution<double>::find_non_centrality(k, threshold, 1.0 - power);
}

std::array<double, 2> ChiSquareBand95::operator()(int dof) {
  auto it = cache_.find(dof);
  if (it == cache_.end())
    it = cache_.emplace(dof, std::array<double, 2>{chiSquareQuantile(0.025, dof), chiSquareQuantile(0.975, dof)}).first;
  return it->second;
}

DriveStats computeStats(const std::vector<ScanRec>& scans, const std::vector<BeamRec>& beams,
                        const std::vector<std::array<double, 2>>& obs, double wheel_radius) {
  DriveStats out;
  json& t = out.tests;
  constexpr double kCap = 25.0;
  // --- NIS over all predicted beams (gated ones included), capped and raw.
  Acc nis_cap, nis_raw;
  for (const BeamRec& b : beams) {
    const double v = b.nu * b.nu / b.var;
    nis_cap.add(std::min(v, kCap));
    nis_raw.add(v);
  }
  const double n = std::max(1.0, nis_cap.n);
  const double half = 1.96 * std::sqrt(2.0 / n);
  t["innovations"] = nis_cap.n;
  t["nis_mean"] = orZero(nis_cap.mean());
  t["nis_mean_uncapped"] = orZero(nis_raw.mean());
  t["nis_band"] = {1 - half, 1 + half};
  t["beams_gated"] = std::count_if(beams.begin(), beams.end(), [](const BeamRec& b) { return b.status == Status::kGated; });
  // --- per-scan NIS against the 95 % band of its dof.
  int outside = 0, counted = 0;
  ChiSquareBand95 band;
  for (const ScanRec& r : scans) {
    if (r.dof < 1) continue;
    ++counted;
    const auto b = band(r.dof);
    if (r.nis_sum < b[0] || r.nis_sum > b[1]) ++outside;
  }
  t["scans"] = counted;
  t["scans_outside_band_frac"] = counted > 0 ? double(outside) / counted : 0.0;
  // --- windowed time-averaged NIS: windows of 10 scans.
  int w_out = 0, w_n = 0;
  json windows = json::array();
  for (std::size_t i = 0; i + 10 <= scans.size(); i += 10) {
    double s = 0;
    int d = 0;
    for (std::size_t j = i; j < i + 10; ++j) {
      s += scans[j].nis_sum;
      d += scans[j].dof;
    }
    if (d < 1) continue;
    ++w_n;
    const auto b = band(d);
    if (s < b[0] || s > b[1]) ++w_out;
  }
  t["windowed_nis_scans"] = 10;
  t["windowed_nis_outside_frac"] = w_n > 0 ? double(w_out) / w_n : 0.0;
  // --- whiteness: autocorrelation of the per-scan mean normalised innovation; Ljung-Box.
  std::vector<double> series;
  for (const ScanRec& r : scans)
    if (r.dof > 0) series.push_back(r.sum_norm / std::sqrt(double(r.dof)));
  t["ljung_box"] = ljungBox(series);
  // --- per-beam residuals (normalised innovation by beam index).
  int max_beam = 0;
  for (const BeamRec& b : beams) max_beam = std::max(max_beam, b.beam);
  std::vector<Acc> per(static_cast<std::size_t>(max_beam + 1));
  for (const BeamRec& b : beams) per[static_cast<std::size_t>(b.beam)].add(b.nu / std::sqrt(b.var));
  json pb = json::array();
  double worst = 0;
  for (std::size_t i = 0; i < per.size(); ++i) {
    pb.push_back({{"beam", i}, {"count", per[i].n}, {"mean_norm", orZero(per[i].mean())}, {"rms_norm", orZero(per[i].rms())},
                  {"t", orZero(per[i].tstat())}});
    worst = std::max(worst, std::abs(orZero(per[i].tstat())));
  }
  t["per_beam"] = pb;
  t["per_beam_max_abs_t"] = worst;
  // --- pose correction decomposed.
  Acc along, cross, head;
  for (const ScanRec& r : scans) {
    double a, c, h;
    correction(r, &a, &c, &h);
    along.add(a);
    cross.add(c);
    head.add(h);
  }
  auto accJson = [](const Acc& a) {
    return json{{"mean", orZero(a.mean())}, {"rms", orZero(a.rms())}, {"t", orZero(a.tstat())}};
  };
  t["pose_correction"] = {{"along_m", accJson(along)}, {"cross_m", accJson(cross)}, {"heading_rad", accJson(head)}};
  // --- OF observables against their predicted means.
  Acc o1, o2;
  for (const auto& o : obs) {
    if (std::isfinite(o[0])) o1.add(o[0]);
    if (std::isfinite(o[1])) o2.add(o[1]);
  }
  t["of_observables"] = {{"updates", obs.size()},
                         {"z1", {{"mean_norm", orZero(o1.mean())}, {"mean_square_norm", o1.n > 0 ? o1.s2 / o1.n : 0.0}}},
                         {"z2", o2.n > 0 ? json{{"mean_norm", orZero(o2.mean())}, {"mean_square_norm", o2.s2 / o2.n}} : json(nullptr)}};
  // --- NEES of the pose against truth.
  Acc nees;
  for (const ScanRec& r : scans)
    if (r.nees >= 0) nees.add(r.nees);
  t["nees_pose"] = jsonOrNull(nees.mean());
  t["nees_pose_dof"] = 3;

  // --- bins.
  auto binBy = [&](const std::vector<double>& edges, auto value) {
    json arr = json::array();
    for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
      double cnt = 0, nis = 0, norm = 0;
      Acc ba, bc, bh;
      for (const ScanRec& r : scans) {
        const double v = value(r);
        if (!(v >= edges[b] && (v < edges[b + 1] || (b + 2 == edges.size() && v <= edges[b + 1])))) continue;
        cnt += r.dof;
        nis += r.nis_sum;
        norm += r.sum_norm;
        double a, c, h;
        correction(r, &a, &c, &h);
        ba.add(a);
        bc.add(c);
        bh.add(h);
      }
      arr.push_back({{"lo", edges[b]}, {"hi", edges[b + 1]}, {"count", cnt},
                     {"nis_mean", cnt > 0 ? json(nis / cnt) : json(nullptr)},
                     {"mean_norm_innovation", cnt > 0 ? json(norm / cnt) : json(nullptr)},
                     {"along_mean_m", orZero(ba.mean())}, {"cross_mean_m", orZero(bc.mean())},
                     {"heading_mean_rad", orZero(bh.mean())}});
    }
    return arr;
  };
  auto quantileEdges = [&](auto value) {
    std::vector<double> v;
    for (const ScanRec& r : scans) v.push_back(value(r));
    std::vector<double> e;
    for (int i = 0; i <= 5; ++i) e.push_back(quantile(v, i / 5.0));
    e.erase(std::unique(e.begin(), e.end()), e.end());
    if (e.size() < 2) e = {e.empty() ? 0.0 : e[0], (e.empty() ? 0.0 : e[0]) + 1e-9};
    return e;
  };
  auto w_of = [](const ScanRec& r) { return r.w; };
  auto v_of = [](const ScanRec& r) { return r.v; };
  auto vw_of = [](const ScanRec& r) { return r.v * r.w; };
  const double pi = kPi<double>;
  json& bins = out.bins;
  bins["turn_rate"] = binBy(quantileEdges(w_of), w_of);
  bins["speed"] = binBy(quantileEdges(v_of), v_of);
  bins["v_omega"] = binBy(quantileEdges(vw_of), vw_of);
  std::vector<double> head_edges, wheel_edges;
  for (int i = 0; i <= 8; ++i) {
    head_edges.push_back(-pi + i * pi / 4);
    wheel_edges.push_back(i * pi / 4);
  }
  bins["heading"] = binBy(head_edges, [](const ScanRec& r) { return r.th; });
  bins["since_reversal"] = binBy({0, 0.05, 0.2, 1, 5, 1e300}, [](const ScanRec& r) { return std::min(r.s_rev, 1e299); });
  bins["wheel_angle"] = binBy(wheel_edges, [&](const ScanRec& r) {
    const double phi = std::fmod(r.s_signed / wheel_radius, 2 * pi);
    return phi < 0 ? phi + 2 * pi : phi;
  });
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const ScanRec& r : scans) {
    x0 = std::min(x0, r.x);
    x1 = std::max(x1, r.x);
    y0 = std::min(y0, r.y);
    y1 = std::max(y1, r.y);
  }
  json cells = binBy({0, 1, 2, 3, 4, 5, 6, 7, 8, 9}, [&](const ScanRec& r) {
    auto idx = [](double v, double lo, double hi) {
      const int i = hi > lo ? static_cast<int>((v - lo) / (hi - lo) * 3) : 0;
      return std::clamp(i, 0, 2);
    };
    return double(3 * idx(r.y, y0, y1) + idx(r.x, x0, x1)) + 0.5;
  });
  for (std::size_t c = 0; c < cells.size(); ++c) {
    const int col = static_cast<int>(c) % 3, row = static_cast<int>(c) / 3;
    cells[c]["x_range"] = {x0 + col * (x1 - x0) / 3, x0 + (col + 1) * (x1 - x0) / 3};
    cells[c]["y_range"] = {y0 + row * (y1 - y0) / 3, y0 + (row + 1) * (y1 - y0) / 3};
  }
  bins["map_cell"] = cells;

  // --- CUSUM on the standardised per-scan NIS, both directions.
  json alarms = json::array();
  double up = 0, down = 0;
  constexpr double kK = 0.5, kH = 10.0;
  for (const ScanRec& r : scans) {
    if (r.dof < 1) continue;
    const double z = (r.nis_sum - r.dof) / std::sqrt(2.0 * r.dof);
    up = std::max(0.0, up + z - kK);
    down = std::max(0.0, down - z - kK);
    if (up > kH) {
      alarms.push_back({{"t", r.t}, {"x", r.x}, {"y", r.y}, {"direction", "up"}});
      up = 0;
    }
    if (down > kH) {
      alarms.push_back({{"t", r.t}, {"x", r.x}, {"y", r.y}, {"direction", "down"}});
      down = 0;
    }
  }
  out.cusum = {{"k", kK}, {"h", kH}, {"alarms", alarms}};

  // --- the statistical part of the verdict (docs/diagnostics.md).
  const double nm = orZero(nis_cap.mean());
  out.consistent = nis_cap.n == 0 || (nm > 0.8 && nm < 1.25 && t["windowed_nis_outside_frac"].get<double>() < 0.25);
  t["nis_consistent"] = out.consistent;
  return out;
}

bool writeDiagnoseCsv(const std::string& dir, const std::vector<ScanRec>& scans, const std::vector<BeamRec>& beams,
                      const std::vector<TrajRec>& traj, std::string* error) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  std::ofstream fs_scans(fs::path(dir) / "scans.csv"), fs_beams(fs::path(dir) / "beams.csv"),
      fs_traj(fs::path(dir) / "trajectory.csv");
  if (!fs_scans || !fs_beams || !fs_traj) {
    *error = "cannot write to '" + dir + "': " + std::strerror(errno);
    return false;
  }
  char buf[256];
  fs_scans << "t,dist_m,x,y,theta,dof,nis_sum,band_lo,band_hi,along_m,cross_m,heading_rad\n";
  ChiSquareBand95 band;
  for (const ScanRec& r : scans) {
    const std::array<double, 2> b = r.dof > 0 ? band(r.dof) : std::array<double, 2>{0, 0};
    const double lo = b[0], hi = b[1];
    const double dx = r.x1 - r.x, dy = r.y1 - r.y, c = std::cos(r.th), s = std::sin(r.th);
    std::snprintf(buf, sizeof buf, "%.3f,%.3f,%.4f,%.4f,%.5f,%d,%.3f,%.3f,%.3f,%.6f,%.6f,%.7f\n", r.t, r.dist, r.x,
                  r.y, r.th, r.dof, r.nis_sum, lo, hi, c * dx + s * dy, -s * dx + c * dy, wrapAngle(r.th1 - r.th));
    fs_scans << buf;
  }
  fs_beams << "t,beam,hit_x,hit_y,innovation_m,nis,status\n";
  for (const BeamRec& b : beams) {
    std::snprintf(buf, sizeof buf, "%.3f,%d,%.4f,%.4f,%.5f,%.4f,%s\n", b.t, b.beam, b.hit_x, b.hit_y, b.nu,
                  b.nu * b.nu / b.var, statusName(b.status));
    fs_beams << buf;
  }
  fs_traj << "t,x,y,theta,truth_x,truth_y,truth_theta\n";
  for (const TrajRec& r : traj) {
    if (r.truth) {
      std::snprintf(buf, sizeof buf, "%.3f,%.4f,%.4f,%.5f,%.4f,%.4f,%.5f\n", r.t, r.x, r.y, r.th, r.tx, r.ty, r.tth);
    } else {
      std::snprintf(buf, sizeof buf, "%.3f,%.4f,%.4f,%.5f,,,\n", r.t, r.x, r.y, r.th);
    }
    fs_traj << buf;
  }
  if (!fs_scans || !fs_beams || !fs_traj) {
    *error = "writing to '" + dir + "' failed";
    return false;
  }
  return true;
}

}  // namespace odoerr::sim

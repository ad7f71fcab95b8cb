// odoerr diagnose: the statistics of the pose fixes (motion capture, UWB, RTK-GNSS,
// fiducials, a SLAM system's poses). Each fused fix is a 3-dof innovation (x, y, heading)
// with its covariance S = P_pose + R_fix; its NIS is chi-square with 3 degrees of freedom
// when the filter is consistent. Tests: the mean NIS with its chi-square band, the share of
// fixes outside their own 95 % band, the windowed NIS, whiteness (Ljung-Box on each
// normalised component), the innovation decomposed along-track, cross-track and in
// heading, the same binned by turn rate, speed and heading, and the NEES at the fixes
// against truth. A test without data is null with a note, never 0.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "odoerr/sim/stats.hpp"

namespace odoerr::sim {

using json = nlohmann::ordered_json;

namespace {

constexpr int kWindow = 10;      // fixes per window of the windowed NIS
constexpr int kMinWhiteness = 10;  // fixes needed for a whiteness test

/// A fix's innovation in the robot frame of its prior: along, cross (m), heading (rad),
/// each also divided by its own standard deviation.
struct Comp {
  double v[3], z[3];
};

Comp components(const PoseFixRec& f) {
  const double c = std::cos(f.th), s = std::sin(f.th);
  Comp o{};
  o.v[0] = c * f.nu[0] + s * f.nu[1];
  o.v[1] = -s * f.nu[0] + c * f.nu[1];
  o.v[2] = f.nu[2];
  // variances of the rotated components: r^T S r with r the row of the rotation
  const double sxx = f.s[0], sxy = f.s[1], syy = f.s[4];
  const double var[3] = {c * c * sxx + 2 * c * s * sxy + s * s * syy, s * s * sxx - 2 * c * s * sxy + c * c * syy, f.s[8]};
  for (int i = 0; i < 3; ++i) o.z[i] = var[i] > 0 ? o.v[i] / std::sqrt(var[i]) : std::nan("");
  return o;
}

using Acc = Moments;

json bins(const std::vector<PoseFixRec>& fixes, const std::vector<Comp>& comp, std::vector<double> edges,
          double (*value)(const PoseFixRec&)) {
  json arr = json::array();
  for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
    Acc nis, c[3], z[3];
    for (std::size_t i = 0; i < fixes.size(); ++i) {
      const double v = value(fixes[i]);
      if (!(v >= edges[b] && (v < edges[b + 1] || (b + 2 == edges.size() && v <= edges[b + 1])))) continue;
      nis.add(fixes[i].nis);
      for (int k = 0; k < 3; ++k) {
        c[k].add(comp[i].v[k]);
        z[k].add(comp[i].z[k]);
      }
    }
    arr.push_back({{"lo", edges[b]}, {"hi", edges[b + 1]}, {"count", nis.n}, {"nis_mean", jsonOrNull(nis.mean())},
                   {"along_mean_m", jsonOrNull(c[0].mean())}, {"cross_mean_m", jsonOrNull(c[1].mean())},
                   {"heading_mean_rad", jsonOrNull(c[2].mean())},
                   {"along_mean_norm", jsonOrNull(z[0].mean())}, {"cross_mean_norm", jsonOrNull(z[1].mean())},
                   {"heading_mean_norm", jsonOrNull(z[2].mean())}});
  }
  return arr;
}

std::vector<double> quantileEdges(const std::vector<PoseFixRec>& fixes, double (*value)(const PoseFixRec&)) {
  std::vector<double> v;
  for (const PoseFixRec& f : fixes) v.push_back(value(f));
  std::sort(v.begin(), v.end());
  std::vector<double> e;
  for (int i = 0; i <= 5; ++i) {
    const double pos = i / 5.0 * double(v.size() - 1);
    const std::size_t k = static_cast<std::size_t>(pos);
    const double f = pos - double(k);
    e.push_back(k + 1 < v.size() ? v[k] * (1 - f) + v[k + 1] * f : v[k]);
  }
  e.erase(std::unique(e.begin(), e.end()), e.end());
  if (e.size() < 2) e = {e[0], e[0] + 1e-9};
  return e;
}

}  // namespace

json poseFixTests(const std::vector<PoseFixRec>& fixes, bool* consistent) {
  json t = json::object();
  const int n = static_cast<int>(fixes.size());
  t["fixes"] = n;
  t["dof"] = 3;
  *consistent = false;
  if (n == 0) {
    for (const char* k : {"nis_mean", "nis_band", "fixes_outside_band_frac", "windowed_nis_outside_frac", "whiteness",
                          "innovation", "bins", "nees_pose", "nis_consistent"})
      t[k] = nullptr;
    t["note"] = "no pose fix was fused (all before the first encoder record, or none finite): no pose-fix test has data";
    return t;
  }
  // --- mean NIS: the sum of n independent 3-dof NIS is chi-square with 3n dof.
  double sum = 0;
  int outside = 0;
  const double lo1 = chiSquareQuantile(0.025, 3), hi1 = chiSquareQuantile(0.975, 3);
  for (const PoseFixRec& f : fixes) {
    sum += f.nis;
    if (f.nis < lo1 || f.nis > hi1) ++outside;
  }
  const double nm = sum / n;
  const double lo = chiSquareQuantile(0.025, 3.0 * n) / n, hi = chiSquareQuantile(0.975, 3.0 * n) / n;
  t["nis_mean"] = nm;
  t["nis_expected"] = 3;
  t["nis_band"] = {lo, hi};
  t["nis_per_dof"] = nm / 3;
  t["fix_band"] = {lo1, hi1};
  t["fixes_outside_band_frac"] = double(outside) / n;
  // --- windowed NIS: windows of kWindow fixes against chi-square(3 kWindow).
  int w_n = 0, w_out = 0;
  const double wlo = chiSquareQuantile(0.025, 3.0 * kWindow), whi = chiSquareQuantile(0.975, 3.0 * kWindow);
  for (int i = 0; i + kWindow <= n; i += kWindow) {
    double s = 0;
    for (int j = i; j < i + kWindow; ++j) s += fixes[static_cast<std::size_t>(j)].nis;
    ++w_n;
    if (s < wlo || s > whi) ++w_out;
  }
  t["windowed_nis_fixes"] = kWindow;
  t["windowed_nis_windows"] = w_n;
  if (w_n > 0) {
    t["windowed_nis_outside_frac"] = double(w_out) / w_n;
  } else {
    t["windowed_nis_outside_frac"] = nullptr;
    t["windowed_nis_note"] = "fewer than " + std::to_string(kWindow) + " fixes: no window";
  }
  // --- the components, raw and normalised.
  std::vector<Comp> comp;
  for (const PoseFixRec& f : fixes) comp.push_back(components(f));
  const char* names[3] = {"along_m", "cross_m", "heading_rad"};
  const char* short_names[3] = {"along", "cross", "heading"};
  json inn = json::object();
  for (int k = 0; k < 3; ++k) {
    Acc a, z;
    for (const Comp& c : comp) {
      a.add(c.v[k]);
      if (std::isfinite(c.z[k])) z.add(c.z[k]);
    }
    inn[names[k]] = {{"mean", jsonOrNull(a.mean())}, {"rms", jsonOrNull(a.rms())}, {"t", jsonOrNull(a.tstat())},
                     {"mean_norm", jsonOrNull(z.mean())}, {"rms_norm", jsonOrNull(z.rms())}};
  }
  t["innovation"] = inn;
  // --- whiteness: Ljung-Box on each normalised component, in fix order.
  if (n >= kMinWhiteness) {
    json wh = json::object();
    double p_min = 1;
    for (int k = 0; k < 3; ++k) {
      std::vector<double> series;
      for (const Comp& c : comp)
        if (std::isfinite(c.z[k])) series.push_back(c.z[k]);
      json lb = series.size() >= kMinWhiteness ? ljungBox(series) : json(nullptr);
      if (lb.is_object()) p_min = std::min(p_min, lb["p_value"].get<double>());
      wh[short_names[k]] = lb;
    }
    wh["p_min"] = p_min;
    t["whiteness"] = wh;
  } else {
    t["whiteness"] = nullptr;
    t["whiteness_note"] = "fewer than " + std::to_string(kMinWhiteness) + " fixes: no whiteness test";
  }
  // --- bins by the motion at the fix.
  auto w_of = [](const PoseFixRec& f) { return f.w; };
  auto v_of = [](const PoseFixRec& f) { return f.v; };
  auto h_of = [](const PoseFixRec& f) { return wrapAngle(f.th); };
  std::vector<double> head_edges;
  for (int i = 0; i <= 8; ++i) head_edges.push_back(-kPi<double> + i * kPi<double> / 4);
  t["bins"] = {{"turn_rate", bins(fixes, comp, quantileEdges(fixes, w_of), w_of)},
               {"speed", bins(fixes, comp, quantileEdges(fixes, v_of), v_of)},
               {"heading", bins(fixes, comp, head_edges, h_of)}};
  // --- NEES of the prior pose against truth at the fixes.
  Acc nees;
  for (const PoseFixRec& f : fixes)
    if (f.nees >= 0) nees.add(f.nees);
  t["nees_pose"] = jsonOrNull(nees.mean());
  if (nees.n == 0) t["nees_pose_note"] = "no truth in the log";
  // --- the verdict's part: the mean NIS per dof inside its band (never tighter than the
  // laser's 0.8-1.25) and no more windows outside theirs than chance allows.
  const double pd = nm / 3;
  const bool nis_ok = pd > std::min(0.8, lo / 3) && pd < std::max(1.25, hi / 3);
  // The windows outside their band: binomial(w_n, 0.05) when consistent; too many when
  // that many or more would happen by chance with probability under 1 %.
  double p_win = 0;
  for (int k = w_out; k <= w_n; ++k)
    p_win += std::exp(std::lgamma(w_n + 1.0) - std::lgamma(k + 1.0) - std::lgamma(w_n - k + 1.0) + k * std::log(0.05) +
                      (w_n - k) * std::log(0.95));
  if (w_n > 0) t["windowed_nis_p_value"] = std::min(1.0, p_win);
  const bool win_ok = w_n == 0 || p_win >= 0.01;
  *consistent = nis_ok && win_ok;
  t["nis_consistent"] = *consistent;
  return t;
}

DriveStats computeStats(const std::vector<ScanRec>& scans, const std::vector<BeamRec>& beams,
                        const std::vector<std::array<double, 2>>& obs, double wheel_radius,
                        const std::vector<PoseFixRec>& fixes, bool has_laser, bool has_fixes) {
  DriveStats out = computeStats(scans, beams, obs, wheel_radius);
  json& t = out.tests;
  const bool laser_data = has_laser && beams.size() >= static_cast<std::size_t>(kMinLaserInnovations);
  if (!laser_data) {
    // Every laser test is empty: null with a note, out of the verdict.
    for (const char* k : {"nis_mean", "nis_mean_uncapped", "nis_band", "scans_outside_band_frac",
                          "windowed_nis_outside_frac", "ljung_box", "per_beam_max_abs_t", "pose_correction",
                          "nees_pose", "nis_consistent"})
      t[k] = nullptr;
    t["per_beam"] = json::array();
    char note[240];
    std::snprintf(note, sizeof note,
                  "%zu beams of %zu scans were predicted against the map (the laser tests need at least %d): the "
                  "laser tests have no data and stay out of the verdict",
                  beams.size(), scans.size(), kMinLaserInnovations);
    t["laser_note"] = has_laser ? std::string(note)
                                : std::string("the log has no laser: the laser tests have no data and stay out of the verdict");
    out.missing.push_back(t["laser_note"].get<std::string>());
    for (auto& el : out.bins.items()) el.value() = nullptr;
    out.cusum["alarms"] = json::array();
    out.cusum["note"] = "the CUSUM runs on the scans' NIS: no scan";
  }
  std::vector<std::string> basis;
  bool ok = true;
  if (laser_data) {
    basis.push_back("laser");
    ok = out.consistent;
  }
  if (has_fixes) {
    bool fix_ok = false;
    t["pose_fixes"] = poseFixTests(fixes, &fix_ok);
    if (!fixes.empty()) {
      basis.push_back("pose_fixes");
      ok = ok && fix_ok;
    } else {
      out.missing.push_back("the log's pose fixes: none was fused");
    }
  }
  out.consistent = ok;
  out.has_data = !basis.empty();
  if (!laser_data || has_fixes) {
    t["nis_consistent"] = basis.empty() ? json(nullptr) : json(ok);
    t["verdict_rests_on"] = basis;
  }
  return out;
}

}  // namespace odoerr::sim

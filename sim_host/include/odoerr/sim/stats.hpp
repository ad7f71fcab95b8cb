// sim_host: the statistics `odoerr diagnose` computes on a replay's innovations: NIS with
// chi-square bands, windowed NIS, whiteness (Ljung-Box), per-beam residuals, the pose
// correction decomposed into along-track, cross-track and heading, the OF observables,
// NEES, the same binned by motion and place, and CUSUM change alarms.
#pragma once

#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "odoerr/akf.hpp"

namespace odoerr::sim {

/// The name of a beam status in the CSV outputs ("used", "gated", ...).
const char* statusName(Status s);

/// Chi-square survival function P(X > x) for k degrees of freedom (Boost.Math); 1 for x <= 0.
double chiSquareSf(double x, double k);
/// Chi-square quantile for k degrees of freedom, p in (0, 1) (Boost.Math, exact).
double chiSquareQuantile(double p, double k);
/// The non-centrality lambda at which a chi-square statistic of k degrees of freedom
/// exceeds `threshold` with probability `power`: P(chi2_k(lambda) > threshold) = power
/// (Boost.Math's non-central chi-square). k >= 1, threshold > 0, power in (0, 1).
double noncentralityForPower(double k, double threshold, double power);
/// The central 95 % band [q(0.025), q(0.975)] of a chi-square with dof degrees of freedom
/// (dof >= 1), computed once per dof a series asks for.
class ChiSquareBand95 {
 public:
  std::array<double, 2> operator()(int dof);

 private:
  std::map<int, std::array<double, 2>> cache_;
};
/// Count, sum and sum of squares of a series, for its mean, RMS and the t statistic of
/// its mean against 0. Each is empty without the data it needs (no value for the mean and
/// RMS, fewer than two or no spread for t): the caller says what an empty test reports.
struct Moments {
  double n = 0, s = 0, s2 = 0;
  void add(double v) {
    n += 1;
    s += v;
    s2 += v * v;
  }
  std::optional<double> mean() const { return n > 0 ? std::optional<double>(s / n) : std::nullopt; }
  std::optional<double> rms() const { return n > 0 ? std::optional<double>(std::sqrt(s2 / n)) : std::nullopt; }
  std::optional<double> tstat() const {
    if (n < 2) return std::nullopt;
    const double var = (s2 - s * s / n) / (n - 1);
    return var > 0 ? std::optional<double>((s / n) / std::sqrt(var / n)) : std::nullopt;
  }
};
/// A Moments figure as JSON: null when empty.
inline nlohmann::ordered_json jsonOrNull(const std::optional<double>& v) {
  return v ? nlohmann::ordered_json(*v) : nlohmann::ordered_json(nullptr);
}

/// Whiteness of a series: its autocorrelation up to min(20, n/5) lags and the Ljung-Box
/// statistic with its p-value; null when the series has no variance (or no values).
nlohmann::ordered_json ljungBox(const std::vector<double>& series);

/// One fused scan of a replay, with the motion around it.
struct ScanRec {
  double t, dist, x, y, th;  ///< before the update
  double x1, y1, th1;        ///< after the update
  double nis_sum, v, w, s_rev, s_signed;  ///< s_signed: the encoders' cumulative travel (wheel angle)
  int dof;
  double sum_norm;  ///< sum of nu / sqrt(S) over its predicted beams
  double nees = -1; ///< pose NEES against truth after the update (-1: no truth)
};
/// One fused pose fix (motion capture, UWB, GNSS, a SLAM pose...): its innovation
/// against the prior, the innovation covariance (prior pose covariance + the fix's),
/// and the motion at it.
struct PoseFixRec {
  double t, dist, x, y, th;  ///< the prior (before the fix)
  double nu[3];              ///< fix - prior: x, y (world), heading (wrapped)
  double s[9];               ///< innovation covariance, row-major (x, y, heading)
  double nis, v, w;
  double nees = -1;          ///< prior pose NEES against truth (-1: no truth)
};
/// One predicted beam (gated ones included).
struct BeamRec {
  double t;
  int beam;
  Status status;
  double hit_x, hit_y, nu, var;
};
struct TrajRec {
  double t, x, y, th, tx, ty, tth;
  bool truth;
};

struct DriveStats {
  nlohmann::ordered_json tests, bins, cusum;
  bool consistent = true;
  bool has_data = true;  ///< some test of the verdict had data (else: insufficient data)
  std::vector<std::string> missing;  ///< what the verdict lacks, when a part had no data
};

/// The laser tests need at least this many beams predicted against the map (their NIS band
/// is 1 +- 1.96 sqrt(2/n): at 30 beams +-0.72; fewer, and the band says nothing).
inline constexpr int kMinLaserInnovations = 30;

/// Statistics of one replay. obs: the OF's normalised observable residuals per update.
DriveStats computeStats(const std::vector<ScanRec>& scans, const std::vector<BeamRec>& beams,
                        const std::vector<std::array<double, 2>>& obs, double wheel_radius);
/// The same with the log's pose fixes. has_laser: the log has a laser, so the laser tests
/// apply (without one, they are null with a note and stay out of the verdict); has_fixes:
/// the log has pose records (then tests.pose_fixes holds their tests: the 3-dof NIS with
/// its chi-square band, whiteness, the along/cross/heading components and their bins).
DriveStats computeStats(const std::vector<ScanRec>& scans, const std::vector<BeamRec>& beams,
                        const std::vector<std::array<double, 2>>& obs, double wheel_radius,
                        const std::vector<PoseFixRec>& fixes, bool has_laser, bool has_fixes);

/// The tests of the pose fixes alone (tests.pose_fixes). Null-valued entries with a note
/// when there are none. consistent: whether they pass (false when there are none).
nlohmann::ordered_json poseFixTests(const std::vector<PoseFixRec>& fixes, bool* consistent);

/// scans.csv, beams.csv and trajectory.csv for the report. False with *error.
bool writeDiagnoseCsv(const std::string& dir, const std::vector<ScanRec>& scans,
                      const std::vector<BeamRec>& beams, const std::vector<TrajRec>& traj,
                      std::string* error);

}  // namespace odoerr::sim

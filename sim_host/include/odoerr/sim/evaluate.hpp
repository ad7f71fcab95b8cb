// sim_host: `odoerr evaluate` and `odoerr umbmark`: does the odometry error fall on runs
// the fit never saw? Calibration by the online estimator over calibration logs in order;
// odometry alone integrated on test logs with given constants; the relative pose error
// (RPE) over a length of path, as evo computes it; the error growth the non-systematic
// parameter predicts; and Borenstein's UMBmark from square runs as a baseline.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "odoerr/sim/diagnose.hpp"
#include "odoerr/sim/odolog.hpp"

namespace odoerr::sim {

/// A planar pose at a time.
struct Pose2 {
  double t, x, y, th;
};

/// One RPE segment: its start and end sample, the translation and rotation error.
struct RpeSegment {
  std::size_t i, j;
  double trans, rot;
};

/// The RPE segments over `delta` metres of the reference's path (evo's relative pose
/// error with delta in metres): a segment starts at the first sample at or after every
/// `step` metres of the reference path and ends at the first sample whose path from the
/// start is >= delta. The error of a segment is E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j) (Q the
/// reference, P the estimate, in SE(2)): trans = |t(E)|, rot = |angle(E)|. `ref` and `est`
/// are sampled at the same instants (same size).
std::vector<RpeSegment> rpeSegments(const std::vector<Pose2>& ref, const std::vector<Pose2>& est, double delta,
                                    double step = 0.1);

/// Mean and RMSE of translation and rotation over segments (null without segments).
nlohmann::ordered_json rpeJson(const std::vector<RpeSegment>& segs);

/// A motion feature term of the odometry (a discovered form, `feature:NAME@TARGET`):
/// increment += coef * feature * target direction (core/include/odoerr/effects/features.hpp).
struct OdoTerm {
  int feature = 0, target = 0;  ///< effects::MotionFeature, effects::MotionTarget
  double coef = 0;
  std::string token;
};

/// The drive constants of odometry: wheel scales and wheelbase scale on the log's nominal,
/// and any feature terms.
struct OdoConstants {
  double delta_R = 1, delta_L = 1, delta_d = 1;
  std::vector<OdoTerm> terms;
};

/// Dead reckoning of a diff-drive log's encoders from its init pose with constants c,
/// sampled at `times` (interpolated between encoder records). False with *error.
bool integrateOdometry(const Odolog& log, const OdoConstants& c, const std::vector<double>& times,
                       std::vector<Pose2>* out, std::string* error);

/// The reference of a log: its truth, or its pose fixes when it has no truth; "" when it has
/// neither (then *kind says so).
std::vector<Pose2> referenceOf(const Odolog& log, std::string* kind);

/// The position standard deviation, at the end of every RPE segment of `ref` (over delta
/// of path), that the non-systematic parameter K_w predicts for odometry with constants c
/// (wheel travel variance K_w |travel| per step, propagated from zero at the segment's
/// start): sqrt of the mean of trace(P_xy) over the segments. Negative without segments.
double predictedRpeSigma(const Odolog& log, const OdoConstants& c, double k_w, const std::vector<Pose2>& ref,
                         double delta, double step = 0.1);

/// The pose fixes' normalised innovations over the calibration logs (each fused fix's
/// innovation against its predicted covariance S): the mean NIS per degree of freedom of
/// the full 3-dof innovation, of its position block (2 dof) and of its heading (1 dof).
/// NaN without a fix. A filter whose noise is right has each near 1.
struct FixNis {
  long fixes = 0;
  double per_dof = 0, xy_per_dof = 0, heading = 0;
};

/// The calibration the online estimator reaches over `logs` in order.
struct Calibration {
  FixNis fix_nis;
  OdoConstants c;
  double sigma[3] = {0, 0, 0};
  double k_w = 0, k_w_sigma = 0;
  nlohmann::ordered_json effects = nlohmann::ordered_json::object();  ///< --with: name -> {estimate, sigma}
  nlohmann::ordered_json per_log = nlohmann::ordered_json::array();   ///< the state after each log
};

/// Runs the estimator (diagnose's engine, drive parameters and K free, the `with` catalogue
/// effects and motion feature terms free) over the logs in order: parameters and covariance (K's too) carried from
/// one log to the next, the pose re-initialised from each log's init. Diff drive only.
/// `base` carries the filter settings (tuning, k0_w); its `with` is ignored.
bool calibrateOnLogs(const std::vector<Odolog>& logs, const std::vector<std::string>& with, Calibration* out,
                     std::string* error, const DiagnoseOptions& base = DiagnoseOptions{});

/// Every pose fix of `logs` with the sigmas sxy (x and y) and stheta.
void setFixSigma(std::vector<Odolog>* logs, double sxy, double stheta);
/// Every pose fix of `logs` with its sigmas multiplied by `scale`.
void scaleFixSigma(std::vector<Odolog>* logs, double scale);

/// `odoerr evaluate --fix-sigma auto`: the pose fixes' sigmas chosen from the calibration
/// logs alone. The logs' own sigmas are multiplied by one scale s (their ratio kept), and s
/// is the root of "the calibration's pose-fix NIS per dof = 1" (FixNis::per_dof, which
/// falls as s grows), found by bisection in log s over [1/16, 16] (7 halvings: within
/// 4.5 %). When the NIS stays on one side of 1 over the whole range, the end is taken and
/// `note` says so. `trace` has every (scale, NIS per dof) tried.
struct FixSigmaChoice {
  double scale = 1, sigma_xy = 0, sigma_theta = 0;  ///< sigmas of the first log's first fix, scaled
  std::vector<std::pair<double, double>> trace;
  std::string note;
};
bool chooseFixSigma(const std::vector<Odolog>& logs, const std::vector<std::string>& with,
                    const DiagnoseOptions& base, FixSigmaChoice* out, std::string* error);

/// `odoerr evaluate`'s default (`--fix-sigma measured`): the noise of a log's pose fixes,
/// measured in the fixes themselves. For every window of four consecutive fixes a..a+3, the
/// odometry (nominal constants) carries fix a to the times of a+1..a+3; the residuals r_j
/// (fix minus carried pose: x, y and heading) lose fix a's error and the odometry's slow
/// drift in their second difference
///   e = [w+ (r3 - r2) - w- (r2 - r1)] / sqrt(w+^2 + (w+ + w-)^2 + w-^2),  w = 1/dt,
/// whose variance is the fixes' variance sigma^2 (plus the odometry's own random noise over
/// the two intervals, which this does not remove). sigma is 1.4826 times the median absolute
/// deviation of e (robust to the jumps where the motion changes): x and y pooled for the
/// position, the heading alone. `measured` is false (and the sigmas are the declared ones)
/// when the log has fewer than kMinSamples windows or a sigma comes out non-positive.
struct FixNoise {
  static constexpr long kMinSamples = 20;
  long fixes = 0, samples = 0;
  double sigma_xy = 0, sigma_theta = 0;        ///< measured (or the declared, when !measured)
  double declared_xy = 0, declared_theta = 0;  ///< the log's first fix (x sigma, heading sigma)
  bool measured = false;
  std::string note;
};
FixNoise measureFixNoise(const Odolog& log);
/// Every pose fix of `log` with the sigmas of `n` (x and y: sigma_xy).
void setFixSigma(Odolog* log, const FixNoise& n);

/// Borenstein's UMBmark from square runs (each a closed square of side `side_m`, the
/// return error measured by the log's reference at its end against dead reckoning with the
/// nominal constants): Ed, Eb and the corrected constants. A run's direction is the sign
/// of its total turn (cw < 0). Needs at least one run in each direction.
struct UmbmarkResult {
  double x_cw = 0, y_cw = 0, x_ccw = 0, y_ccw = 0;  ///< centres of gravity of the return errors (m)
  int n_cw = 0, n_ccw = 0;
  double alpha = 0, beta = 0, radius = 0, ed = 1, eb = 1;
  OdoConstants c;
};
bool umbmark(const std::vector<Odolog>& squares, double side_m, UmbmarkResult* out, std::string* error);

}  // namespace odoerr::sim

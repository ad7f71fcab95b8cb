// diagnose, the non-parametric step: on which state variables does the motion misfit
// depend, and how strongly, before any form is chosen.
//
// Each motion segment of discovery (about 0.5 s between fused measurements) gives a
// residual in the robot frame per metre of travel (along, cross, heading) and a row of
// the robot's state and history over the segment (speed, turn rate, acceleration, heading,
// position, time, travel since the start and since the last reversal, the wheels' speeds).
// For every (component, variable) a regression tree of depth 2 (three adaptive splits of the
// variable, each leaf at least 5 % of the travel; the weights are the segments' travel) is
// fitted and cross-validated over the same time blocks as discovery; its strength is the
// share of the cross-validated misfit it removes against a constant. The
// null is built by circular shifts of the state rows against the residuals (which keep
// both series' autocorrelation), with the maximum over all pairs (Westfall-Young), so that
// the family of tests has a false-alarm rate of `kDependenceAlpha` per drive.
// docs/diagnostics.md ("Dependence") states the rules.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

namespace odoerr::sim::diag {

/// The level of the family of dependence tests (per drive, over every pair).
constexpr double kDependenceAlpha = 0.01;
/// The smallest share of the cross-validated misfit a dependence must explain to be reported
/// (discovery's own smallest gain); below it for every pair, no null is drawn.
constexpr double kDependenceMinShare = 0.01;

/// The segments' responses and states.
struct StateTable {
  std::vector<std::string> names, units;  ///< per variable
  Eigen::MatrixXd state;                  ///< segments x variables
  Eigen::MatrixXd response;               ///< segments x 3: along (m/m), cross (m/m), heading (rad/m)
  Eigen::VectorXd weight;                 ///< per segment: its travel (m); 0 leaves it out
  std::vector<int> fold;                  ///< cross-validation fold of each segment
  int folds = 4;
};

/// The variables the table holds, in column order, with their units; wheels: the two
/// wheel speeds too (a differential drive).
void stateVariables(bool wheels, std::vector<std::string>* names, std::vector<std::string>* units);

/// The analysis: {"segments", "weight_m", "method", "alpha", "shifts", "pairs": [every pair's
/// explained share and adjusted p], "found": [the pairs with p <= alpha, strongest first, each
/// with its tree's leaves (ranges, means, counts) and the library's forms in the variable],
/// "follows_misfit": [those of them whose next segment's value explains the misfit at least as
/// well as their own: a reply to the error, not its cause]}. Fewer than `kMinSegments` usable
/// segments: the object says so ("found": null, "note"), never a finding.
nlohmann::ordered_json dependenceJson(const StateTable& t);

/// The smallest number of segments with travel the analysis runs on.
constexpr int kMinSegments = 40;

/// One segment's state, accumulated cycle by cycle in discovery's segment loop.
class SegmentState {
 public:
  /// A segment opens at t (s since the log's first event), with the travel so far and since
  /// the last reversal (infinite before the first).
  void open(double t, double s_abs, double s_rev);
  /// One cycle of the drive's increment (rho, th; the wheels' travels right, left) from the
  /// pose (x, y, heading) at its start; dt <= 0 (unknown) adds travel but no rate.
  void cycle(double dt, double rho, double th, double right, double left, double x, double y, double heading);
  /// The state row in stateVariables' order; false when no cycle had a known duration.
  bool row(bool wheels, Eigen::VectorXd* out) const;
  double travel() const { return abs_rho_; }
  /// A residual (world dx, dy, dtheta) per metre of travel in the robot frame of the
  /// segment's mean heading (along, cross, heading).
  Eigen::Vector3d perMetre(const Eigen::Vector3d& r_world) const;

 private:
  double t0_ = 0, s_abs_ = 0, s_rev_ = 0;
  double dur_ = 0, rho_ = 0, abs_rho_ = 0, th_ = 0, abs_th_ = 0, right_ = 0, left_ = 0;
  double sx_ = 0, sy_ = 0, sc_ = 0, ss_ = 0;
  // least squares of the cycles' rates on time: the segment's acceleration and turn-rate change
  double n_ = 0, st_ = 0, stt_ = 0, sv_ = 0, stv_ = 0, sw_ = 0, stw_ = 0;
};

/// The library's motion features in a state variable (the forms the parametric step can
/// propose in it), e.g. "a_along" -> acc_pos_ds, acc_neg_ds, acc_ds.
std::vector<std::string> featuresInVariable(const std::string& variable);

/// The forms the parametric step proposes for a dependence of `component` (along, cross,
/// heading) on `variable`: at most two feature terms a feature effect carries, as
/// "FEATURE@TARGET" (a wheel's speed on that wheel), and the catalogue's effects in that
/// variable (s_rev: backlash, wheel_backlash; speed: speed_scale, wheel_speed_scale; ...).
struct ProposedForms {
  std::vector<std::string> features;   ///< "acc_pos_ds@along", ...
  std::vector<std::string> catalogue;  ///< effect names
};
ProposedForms proposedForms(const std::string& variable, const std::string& component);

/// Whether a motion form on `target` (along, cross, heading, world_x, world_y, wheel_R,
/// wheel_L) moves the robot-frame misfit `component` (along, cross, heading): a wheel's
/// travel moves along and heading, a world-frame displacement along and cross, a robot-frame
/// target its own component only. A finding's selected forms are those that move its component.
bool targetMoves(const std::string& target, const std::string& component);

}  // namespace odoerr::sim::diag

// diagnose, the ranking of the catalogue's effects: every candidate scored against a
// reference run (an augmented run for its estimate and sigma, a held run for the profile
// likelihood; a noise effect by a two-dimensional profile over its size and K), the tests
// that name it (likelihood ratio, BIC and Wald must agree), the conditional tests of the
// best two given each other, and the confusable pairs from the joint information.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine.hpp"

namespace odoerr::sim::diag {

/// The test levels that name a candidate (Ranking::test): its likelihood ratio's (before the
/// BIC condition) and its Wald statistic's (the estimate against its own sigma).
inline constexpr double kRankAlphaLr = 1e-3;
inline constexpr double kRankAlphaWald = 1e-2;

/// One candidate effect scored against a reference.
struct Candidate {
  Eigen::VectorXd est, sig;
  std::vector<bool> informed;
  double ll = 0, ll_ref = 0;
  int k = 0;
  double k_mult = 1, q_best = 0;  ///< noise effect: its best profile point (whose likelihood is ll)
  double wald = 0;                ///< Wald statistic of the informed parameters (k degrees of freedom)
  /// Noise effect: its profile, {q, best log-likelihood over K, its K multiplier, the
  /// parabola's peak over log K} per q.
  std::vector<std::array<double, 4>> profile;
};

/// The tests of one candidate.
struct RankRow {
  int e;
  double dll, lr, bic, p;
  int k;
  bool detectable, significant;
  double cond_p = -1;  ///< conditional test given the best effect (-1: not run)
  double wald_p = 1;   ///< the Wald test's p-value
  std::string unnamed;  ///< why a significant effect was not named after all ("": it was not taken back)
};

template <template <typename> class DriveT>
class Ranking {
 public:
  using En = Engine<DriveT>;
  using RunSpec = typename En::RunSpec;
  using RunOut = typename En::RunOut;

  Ranking(const En& en, int threads) : en_(en), threads_(threads) {}

  /// Scores every candidate against `ref` (K held; its log-likelihood l_ref, over
  /// n_innov innovations), then ranks them and runs the conditional tests.
  void run(const RunSpec& ref, double l_ref, long n_innov);

  const std::vector<Candidate>& candidates() const { return cand_; }
  /// The rows, best first.
  const std::vector<RankRow>& rows() const { return rows_; }
  bool anySignificant() const;
  /// The effects named, best first.
  std::vector<int> named() const;
  /// The reference with the effects `given` held at their estimates (a noise effect with
  /// its K multiplier too).
  RunSpec heldAt(const std::vector<int>& given) const;
  /// Takes back the name of effect e (its row stays, not significant, with the reason).
  void unname(int e, const std::string& why);
  /// The ranking of the JSON contract; `joint` is the run with every augmentable
  /// candidate free, whose covariance gives the confusable pairs.
  nlohmann::ordered_json toJson(const RunOut& joint) const;

 private:
  using Tasks = std::vector<std::function<void()>>;
  std::array<double, 4> profileAtQ(const RunSpec& ref, int e, double q) const;
  void augmentTasks(const RunSpec& ref, double ll_ref, int e, Candidate* c, RunOut* aug, Tasks* tasks) const;
  void heldTasks(const RunSpec& ref, int e, Candidate* c, const RunOut& aug, Tasks* tasks) const;
  bool test(const Candidate& c, RankRow* r) const;
  std::vector<RankRow> conditional(int given, const std::vector<int>& others) const;

  const En& en_;
  int threads_;
  RunSpec ref0_;
  double ln_n_ = 0;
  std::vector<Candidate> cand_;
  std::vector<RankRow> rows_;
  std::vector<std::vector<int>> mutual_;  ///< pairs that explain each other away
};

extern template class Ranking<SyncDrive>;
extern template class Ranking<DiffDrive>;

}  // namespace odoerr::sim::diag

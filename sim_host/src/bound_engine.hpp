// sim_host (private): the bound's recursions along a true path (bound.hpp says what they
// compute; docs/nonsystematic.md derives them). Uses the core's model and Jacobians only:
// Akf::transition (F, G at the true state), Drive::noiseVariance (Q, linear in K) and
// Akf::expectedRange (the beam's H at the true pose).
// The joint recursion of K and delta (K with delta unknown) runs beside it: bound_joint.hpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "odoerr/akf.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/laser.hpp"
#include "odoerr/sim/bound.hpp"
#include "bound_joint.hpp"

namespace odoerr::sim::bound_detail {

/// One filter cycle of the true path: the encoder input, the true pose before and after
/// it, and the beams of its scan that have a valid return (empty: no scan).
template <typename Input>
struct PathCycle {
  Input u{};
  Pose<double> before{}, after{};
  std::vector<int> beams;
  bool scan = false;
};

template <typename ModelT>
struct Problem {
  using Drive = typename ModelT::Drive;
  ModelT model;
  typename ModelT::StateVec truth_params;  ///< parameter block used; pose entries ignored
  typename Drive::NonSysVec k_true;
  typename ModelT::StateMat p0;
  double min_cos_incidence = 0;
};

/// One beam's expected range from a laser at pose (x, y, heading with cosine c and sine s)
/// and its Jacobian in the pose: Akf::expectedRange on the caller's map and laser. Anything
/// but Status::kOk: the beam cannot be predicted there (it is skipped).
using BeamPredictor =
    std::function<Status(double x, double y, double c, double s, int beam, double* range, Eigen::Matrix<double, 1, 3>* h)>;

/// The predictor of a map (anything Akf::expectedRange casts against) and a laser; both must
/// outlive it.
template <typename ModelT, typename MapT, int MaxBeams>
BeamPredictor beamPredictor(const MapT& map, const LaserGeometry<double, MaxBeams>& laser, double min_cos_incidence) {
  return [&map, &laser, min_cos_incidence](double x, double y, double c, double s, int beam, double* range,
                                           Eigen::Matrix<double, 1, 3>* h) {
    return Akf<ModelT>::expectedRange(map, laser, x, y, c, s, beam, min_cos_incidence, range, h);
  };
}

/// The recursion over `path`, the beams predicted by `predict` with range sigma `range_sigma`.
/// Not templated on the map: bound.cpp instantiates it once per drive for the simulated
/// and the logged drive alike.
template <typename ModelT>
bool runBound(const Problem<ModelT>& pb, const BeamPredictor& predict, double range_sigma,
              const std::vector<PathCycle<typename ModelT::Input>>& path, const BoundOptions& opt, BoundResult* out,
              std::string* error) {
  using Drive = typename ModelT::Drive;
  using AkfT = Akf<ModelT>;
  constexpr int N = ModelT::kStates;
  constexpr int M = Drive::kNonSys;
  constexpr int NJ = N * (1 + M);  // joint: estimation error, then d xhat / dK_i for each i
  using StateMat = Eigen::Matrix<double, N, N>;
  using StateVec = Eigen::Matrix<double, N, 1>;
  using JointMat = Eigen::Matrix<double, NJ, NJ>;
  using KMat = Eigen::Matrix<double, M, M>;

  const double r = range_sigma * range_sigma;
  // The prior, its systematic block scaled by opt.systematic_prior_scale (1: the filter's).
  StateMat p0 = pb.p0;
  {
    StateVec sc = StateVec::Ones();
    sc.template segment<Drive::kParams>(ModelT::kDriveOffset).setConstant(opt.systematic_prior_scale);
    p0 = (sc.asDiagonal() * p0 * sc.asDiagonal()).eval();
  }
  StateMat p = p0;
  JointRecursion<ModelT> joint(p0);
  if (!joint.prior_ok) {
    *error = "the prior covariance of the systematic parameters is not positive definite";
    return false;
  }
  StateMat dp[M];
  for (auto& d : dp) d.setZero();
  JointMat c = JointMat::Zero();
  c.template topLeftCorner<N, N>() = p0;
  KMat info_cov = KMat::Zero();
  KMat info_mean = KMat::Zero();
  double dist = 0;
  double next_record = opt.every_m;
  double mismatch = 0;
  int cycles = 0;

  nlohmann::json dump_cycles = nlohmann::json::array();
  const bool dump = !opt.dump_path.empty();

  auto record = [&]() {
    BoundPoint bp;
    bp.distance_m = dist;
    bp.cycles = cycles;
    bp.x_sigma_m = std::sqrt(p(0, 0));
    bp.y_sigma_m = std::sqrt(p(1, 1));
    bp.position_sigma_m = std::sqrt(p(0, 0) + p(1, 1));
    bp.heading_sigma_rad = std::sqrt(p(2, 2));
    for (int i = 0; i < Drive::kParams; ++i) {
      const int j = ModelT::kDriveOffset + i;
      BoundValue v{Drive::kParamNames[i], pb.truth_params[j], std::sqrt(p(j, j)), -1};
      if (v.truth != 0) v.bound_pct = 100.0 * v.sigma / std::abs(v.truth);
      bp.systematic.push_back(v);
    }
    auto kBound = [&](const KMat& info, std::vector<BoundValue>* vals, std::vector<std::vector<double>>* fm) {
      // The inverse only through a Cholesky factorisation that succeeded (information
      // positive definite); otherwise the bound is left undefined (sigma -1, JSON null).
      Eigen::LLT<KMat> llt(info);
      const bool ok = llt.info() == Eigen::Success;
      KMat cov = KMat::Zero();
      if (ok) cov = llt.solve(KMat::Identity());
      for (int i = 0; i < M; ++i) {
        BoundValue v{Drive::kNonSysNames[i], pb.k_true[i], -1, -1};
        if (ok && cov(i, i) > 0 && std::isfinite(cov(i, i))) {
          v.sigma = std::sqrt(cov(i, i));
          v.bound_pct = 100.0 * v.sigma / std::abs(v.truth);
        }
        vals->push_back(v);
        fm->emplace_back();
        for (int j = 0; j < M; ++j) fm->back().push_back(info(i, j));
      }
    };
    kBound(info_cov + info_mean, &bp.nonsystematic, &bp.fisher);
    kBound(info_cov, &bp.nonsystematic_cov_term, &bp.fisher_cov_term);
    // K with delta unknown: the KK block of the joint information's inverse (its Schur
    // complement); delta's block of the same inverse; K from J_KK alone (delta given).
    {
      using JR = JointRecursion<ModelT>;
      using ThetaMat = typename JR::ThetaMat;
      const ThetaMat jj = joint.information();
      std::vector<std::vector<double>> unused;
      kBound(jj.template topLeftCorner<M, M>(), &bp.nonsystematic_delta_given, &unused);
      Eigen::LLT<ThetaMat> llt(jj);
      const bool ok = llt.info() == Eigen::Success;
      ThetaMat cov = ThetaMat::Zero();
      if (ok) cov = llt.solve(ThetaMat::Identity());
      for (int a = 0; a < JR::T; ++a) {
        const bool is_k = a < M;
        const char* name = is_k ? Drive::kNonSysNames[a] : Drive::kParamNames[a - M];
        const double truth = is_k ? pb.k_true[a] : pb.truth_params[ModelT::kDriveOffset + a - M];
        BoundValue v{name, truth, -1, -1};
        if (ok && cov(a, a) > 0 && std::isfinite(cov(a, a))) {
          v.sigma = std::sqrt(cov(a, a));
          if (truth != 0) v.bound_pct = 100.0 * v.sigma / std::abs(truth);
        }
        (is_k ? bp.nonsystematic_delta_unknown : bp.systematic_joint).push_back(v);
        bp.fisher_joint.emplace_back();
        for (int b = 0; b < JR::T; ++b) bp.fisher_joint.back().push_back(jj(a, b));
      }
    }
    const double scale = p.cwiseAbs().maxCoeff();
    mismatch = std::max(mismatch, (c.template topLeftCorner<N, N>() - p).cwiseAbs().maxCoeff() / scale);
    return bp;
  };

  for (const auto& cy : path) {
    // --- prediction at the true state ------------------------------------------------
    StateVec xt = pb.truth_params;
    xt[PoseIdx::kX] = cy.before.x;
    xt[PoseIdx::kY] = cy.before.y;
    xt[PoseIdx::kTheta] = cy.before.theta;
    Eigen::Matrix<double, 3, N> f_pose;
    Eigen::Matrix<double, 3, ModelT::kNoise> g_pose;
    (void)AkfT::transition(pb.model, xt, cy.u, &f_pose, &g_pose);
    StateMat f = StateMat::Identity();
    f.template topRows<3>() = f_pose;
    const auto q = pb.model.drive.noiseVariance(cy.u, pb.k_true);
    const Eigen::Matrix3d gqg = g_pose * q.asDiagonal() * g_pose.transpose();
    p = (f * p * f.transpose()).eval();
    p.template topLeftCorner<3, 3>() += gqg;
    typename Drive::NoiseVec dq[M];
    for (int i = 0; i < M; ++i) {
      typename Drive::NonSysVec e = Drive::NonSysVec::Zero();
      e[i] = 1.0;
      dq[i] = pb.model.drive.noiseVariance(cy.u, e);  // Q is linear in K: dQ/dK_i
      dp[i] = (f * dp[i] * f.transpose()).eval();
      dp[i].template topLeftCorner<3, 3>() += g_pose * dq[i].asDiagonal() * g_pose.transpose();
    }
    for (int a = 0; a <= M; ++a) {
      for (int b = 0; b <= M; ++b) {
        c.template block<N, N>(a * N, b * N) = f * c.template block<N, N>(a * N, b * N) * f.transpose();
      }
    }
    c.template topLeftCorner<3, 3>() += gqg;
    joint.predict(pb.model, xt, cy.u, pb.k_true);
    nlohmann::json dc;
    if (dump) {
      dc["F"] = nlohmann::json::array();
      for (int i = 0; i < 3; ++i) {
        std::vector<double> row(N);
        for (int j = 0; j < N; ++j) row[j] = f_pose(i, j);
        dc["F"].push_back(row);
      }
      dc["G"] = nlohmann::json::array();
      for (int i = 0; i < 3; ++i) {
        std::vector<double> row(ModelT::kNoise);
        for (int j = 0; j < ModelT::kNoise; ++j) row[j] = g_pose(i, j);
        dc["G"].push_back(row);
      }
      dc["dQ"] = nlohmann::json::array();
      for (int i = 0; i < M; ++i) dc["dQ"].push_back(std::vector<double>(dq[i].data(), dq[i].data() + dq[i].size()));
      dc["H"] = nlohmann::json::array();
      // d G / d delta_j (the joint recursion's, for the dense check)
      dc["dG_ddelta"] = nlohmann::json::array();
      for (int j = 0; j < Drive::kParams; ++j) {
        nlohmann::json b = nlohmann::json::array();
        for (int i = 0; i < 3; ++i) {
          std::vector<double> row(ModelT::kNoise);
          for (int n = 0; n < ModelT::kNoise; ++n) row[n] = joint.dg[j](i, n);
          b.push_back(row);
        }
        dc["dG_ddelta"].push_back(b);
      }
    }

    // --- the scan's beams, one scalar update each, H at the true pose ------------------
    if (cy.scan) ++out->scans;
    const double cth = std::cos(cy.after.theta);
    const double sth = std::sin(cy.after.theta);
    for (int beam : cy.beams) {
      double range = 0;
      Eigen::Matrix<double, 1, 3> h3;
      if (predict(cy.after.x, cy.after.y, cth, sth, beam, &range, &h3) != Status::kOk) {
        ++out->beams_skipped;
        continue;
      }
      StateVec h = StateVec::Zero();
      h.template head<3>() = h3.transpose();
      const StateVec ph = p * h;
      const double s = h.dot(ph) + r;
      if (!(std::isfinite(s) && s > r)) {
        *error = "the innovation variance of beam " + std::to_string(beam) + " at cycle " + std::to_string(cycles) +
                 " is not above the range variance (the bound's recursion broke down)";
        return false;
      }
      const StateVec k = ph / s;
      StateVec dk[M];
      double ds[M];
      for (int i = 0; i < M; ++i) {
        const StateVec dph = dp[i] * h;
        ds[i] = h.dot(dph);
        dk[i] = dph / s - ph * (ds[i] / (s * s));
      }
      for (int i = 0; i < M; ++i) {
        for (int j = 0; j < M; ++j) {
          info_cov(i, j) += 0.5 * ds[i] * ds[j] / (s * s);
          info_mean(i, j) += h.dot(c.template block<N, N>((1 + i) * N, (1 + j) * N) * h) / s;
        }
      }
      // P' = P - ph ph^T / s;  dP_i' = (I - k h^T) dP_i (I - k h^T)^T (the exact derivative)
      p -= ph * ph.transpose() / s;
      p = (0.5 * (p + p.transpose())).eval();
      for (int i = 0; i < M; ++i) {
        const StateMat a = StateMat::Identity() - k * h.transpose();
        dp[i] = (a * dp[i] * a.transpose()).eval();
      }
      // Joint z = (e, xi_1..xi_M): e' = (I - k h)e - k v;  xi_i' = (I - k h) xi_i + dk_i (h e + v).
      // C' = A C A^T + r b b^T with b = (-k, dk_1, .., dk_M); A applied as rank-one updates.
      auto applyA = [&](JointMat& x) {
        const Eigen::Matrix<double, 1, NJ> he = h.transpose() * x.template topRows<N>();
        for (int b = 0; b <= M; ++b) {
          const Eigen::Matrix<double, 1, NJ> hb = h.transpose() * x.template middleRows<N>(b * N);
          x.template middleRows<N>(b * N) -= k * hb;
          if (b > 0) x.template middleRows<N>(b * N) += dk[b - 1] * he;
        }
      };
      applyA(c);
      JointMat ct = c.transpose();
      applyA(ct);
      c = ct;
      Eigen::Matrix<double, NJ, 1> bv;
      bv.template head<N>() = -k;
      for (int i = 0; i < M; ++i) bv.template segment<N>((1 + i) * N) = dk[i];
      c += r * bv * bv.transpose();
      c = (0.5 * (c + c.transpose())).eval();
      joint.beam(h3.transpose(), r);
      ++out->beams;
      if (dump) dc["H"].push_back(std::vector<double>{h3(0), h3(1), h3(2)});
    }
    if (dump) dump_cycles.push_back(dc);
    ++cycles;
    dist += std::hypot(cy.after.x - cy.before.x, cy.after.y - cy.before.y);  // true path length
    if (opt.every_cycles > 0) {
      if (cycles % opt.every_cycles == 0) out->along.push_back(record());
    } else if (dist >= next_record - 1e-9) {
      out->along.push_back(record());
      while (next_record <= dist + 1e-9) next_record += opt.every_m;
    }
  }
  out->cycles = cycles;
  out->final_point = record();
  out->max_cov_mismatch = mismatch;
  if (dump) {
    nlohmann::json d;
    d["states"] = N;
    d["nonsys"] = M;
    d["range_variance"] = r;
    std::vector<std::vector<double>> p0v(N, std::vector<double>(N));
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < N; ++j) p0v[i][j] = p0(i, j);
    d["P0"] = p0v;
    d["k_true"] = std::vector<double>(pb.k_true.data(), pb.k_true.data() + M);
    d["cycles"] = std::move(dump_cycles);
    std::ofstream f(opt.dump_path);
    f << d.dump() << "\n";
    if (!f) {
      *error = "cannot write '" + opt.dump_path + "'";
      return false;
    }
  }
  return true;
}

/// The filter's prior (fw::makeEstimatorOn's) with the given pose sigmas.
template <typename ModelT>
typename ModelT::StateMat priorCovariance(const FilterSetup& setup, double sxy_x, double sxy_y, double sth) {
  typename ModelT::StateVec sig;
  sig.setConstant(setup.sigma_scale);
  sig[PoseIdx::kX] = sxy_x;
  sig[PoseIdx::kY] = sxy_y;
  sig[PoseIdx::kTheta] = sth;
  if constexpr (std::is_same_v<typename ModelT::Drive, SyncDrive<double>>) {
    sig[ModelT::kDriveOffset + SyncDrive<double>::kETheta] = setup.sigma_e_theta;
  }
  return sig.cwiseAbs2().asDiagonal();
}

extern template bool runBound<Model<SyncDrive<double>>>(const Problem<Model<SyncDrive<double>>>&, const BeamPredictor&,
                                                        double, const std::vector<PathCycle<SyncDrive<double>::Input>>&,
                                                        const BoundOptions&, BoundResult*, std::string*);
extern template bool runBound<Model<DiffDrive<double>>>(const Problem<Model<DiffDrive<double>>>&, const BeamPredictor&,
                                                        double, const std::vector<PathCycle<DiffDrive<double>::Input>>&,
                                                        const BoundOptions&, BoundResult*, std::string*);

}  // namespace odoerr::sim::bound_detail

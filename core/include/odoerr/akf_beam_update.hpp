// odoerr core: the AKF's scalar update of one beam: prediction, innovation, gate, covariance check, fusion.
// Part of the AKF (akf.hpp includes it after the class; not to be included on its own).
#pragma once

namespace odoerr {

template <typename ModelT>
template <bool kReport, typename MapT, int MaxBeams>
inline auto Akf<ModelT>::updateBeamCS(const MapT& map, const LaserGeometry<S, MaxBeams>& laser,
                                      int i, S measured, S c, S sn, S* nis_out, S* dtheta_out, S* predicted_out,
                                      S* variance_out) -> Status {
  const LaserConfig<S>& cfg = laser.config();
  if (!isFinite(measured) || !(measured > S(0)) || measured > cfg.range_max) {
    ++counters_.no_return;
    return Status::kNoReturn;
  }
  S hf[kHCols];
  S predicted = S(0);
  const Status ps = predictBeam(map, laser, i, c, sn, &predicted, hf);
  if (ps != Status::kOk) {
    if (ps == Status::kNoMapHit) ++counters_.no_map_hit;
    if (ps == Status::kGrazing) ++counters_.grazing;
    if (ps == Status::kTooClose) ++counters_.too_close;
    return ps;
  }

  const S r = cfg.sigma * cfg.sigma;
  // Within a scan only the upper triangle of P is kept current (the caller mirrors it
  // once at the end): up(j, k) reads the upper element. After unrolling the choice of
  // element is made at compile time.
  auto up = [this](int j, int k) -> S { return j <= k ? p_(j, k) : p_(k, j); };
  // P H^T: only the first kHCols columns of H can be non-zero (the pose, or every state
  // when measurement effects are composed in).
  S pht[N];
  S s = S(0);
  // kSparse (large host models): the states with variance, and the columns of H that are
  // non-zero among them; every product skipped is an exact zero (see kSparse).
  int act[kSparse ? N : 1];
  int n_act = 0;
  if constexpr (kSparse) {
    n_act = statesWithVariance(act);
    int hcol[N];
    int n_h = 0;
    // Only the states with variance are read below (a held state's entries would be exact
    // zeros, and the loops skip them); the pose's, for dtheta, whatever its variance.
    for (int j = 0; j < 3; ++j) pht[j] = S(0);
    for (int a = 0; a < n_act; ++a) {
      if (act[a] < kHCols && hf[act[a]] != S(0)) hcol[n_h++] = act[a];
    }
    for (int a = 0; a < n_act; ++a) {
      const int j = act[a];
      S acc = S(0);
      for (int b = 0; b < n_h; ++b) acc += up(j, hcol[b]) * hf[hcol[b]];
      pht[j] = acc;
    }
    for (int b = 0; b < n_h; ++b) s += hf[hcol[b]] * pht[hcol[b]];
  } else {
#pragma GCC unroll 16
    for (int j = 0; j < N; ++j) {
      S acc = up(j, 0) * hf[0] + up(j, 1) * hf[1] + up(j, 2) * hf[2];
      for (int k = 3; k < kHCols; ++k) acc += up(j, k) * hf[k];
      pht[j] = acc;
    }
    s = hf[0] * pht[0] + hf[1] * pht[1] + hf[2] * pht[2];
    for (int k = 3; k < kHCols; ++k) s += hf[k] * pht[k];
  }
  s += r;
  if constexpr (kReport) {
    *predicted_out = predicted;
    *variance_out = s;
  } else {
    (void)predicted_out;
    (void)variance_out;
  }
  if (!isFinite(s) || !(s > r)) {
    ++counters_.bad_innovation;
    return Status::kBadInnovation;
  }
  const S nu = measured - predicted;
  const S inv_s = S(1) / s;
  const S nis = nu * nu * inv_s;
  if (!(nis <= cfg_.gate_nis)) {
    ++counters_.gated;
    return Status::kGated;
  }
  // P -= g g^T with g = P H^T / sqrt(s), upper triangle only; mirrored by the caller, so
  // P stays symmetric bit for bit. Loops fully unrolled (N is fixed). The new diagonal is
  // checked before anything is applied: diag(P - g g^T) > 0 (a NaN fails the comparison
  // and is rejected too); the values checked are the values stored.
  const S k_nu = nu * inv_s;
  const S root = std::sqrt(inv_s);
  S g[N];
  S diag[N];
  if constexpr (kSparse) {
    // The states with variance only: a held state has pht 0, so g 0, its row, column and
    // diagonal stay 0 and its estimate does not move (the dense loops below, over every
    // state, agree).
    for (int a = 0; a < n_act; ++a) {
      const int j = act[a];
      g[j] = pht[j] * root;
      diag[j] = p_(j, j) - g[j] * g[j];
      if (!(diag[j] > S(0))) {
        ++counters_.bad_covariance;
        return Status::kBadCovariance;
      }
    }
    for (int a = 0; a < n_act; ++a) x_[act[a]] += pht[act[a]] * k_nu;
    for (int b = 0; b < n_act; ++b) {
      const int k = act[b];
      for (int a = 0; a < b; ++a) p_(act[a], k) -= g[act[a]] * g[k];
      p_(k, k) = diag[k];
    }
  } else {
    (void)act;
    (void)n_act;
#pragma GCC unroll 16
    for (int j = 0; j < N; ++j) {
      g[j] = pht[j] * root;
      diag[j] = p_(j, j) - g[j] * g[j];
      if (!(diag[j] > S(0)) && !heldState(j, pht[j])) {
        ++counters_.bad_covariance;
        return Status::kBadCovariance;
      }
    }
#pragma GCC unroll 16
    for (int j = 0; j < N; ++j) x_[j] += pht[j] * k_nu;
#pragma GCC unroll 16
    for (int j = 0; j < N; ++j) {
      p_(j, j) = diag[j];
#pragma GCC unroll 16
      for (int k = j + 1; k < N; ++k) {
        p_(j, k) -= g[j] * g[k];
      }
    }
  }
  x_[PoseIdx::kTheta] = wrapAngle(x_[PoseIdx::kTheta]);
  *dtheta_out = pht[PoseIdx::kTheta] * k_nu;
  ++counters_.beams_used;
  if (nis_out != nullptr) *nis_out = nis;
  return Status::kOk;
}

}  // namespace odoerr

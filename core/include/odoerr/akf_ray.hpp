// odoerr core: the AKF's ray prediction: a beam's expected range against the map and dr/d(x, y, theta).
// Part of the AKF (akf.hpp includes it after the class; not to be included on its own).
#pragma once

namespace odoerr {

template <typename ModelT>
template <typename MapT, int MaxBeams>
inline auto Akf<ModelT>::expectedRange(const MapT& map,
                                       const LaserGeometry<S, MaxBeams>& laser, S x, S y, S c, S sn,
                                       int i, S min_cos_incidence, S* range, Eigen::Matrix<S, 1, 3>* h,
                                       BeamContext<S>* geo, const RayShift<S>* shift) -> Status {
  const LaserConfig<S>& cfg = laser.config();
  S lx = x + c * cfg.mount_x - sn * cfg.mount_y;
  S ly = y + sn * cfg.mount_x + c * cfg.mount_y;
  S ux = c * laser.dirC(i) - sn * laser.dirS(i);
  S uy = sn * laser.dirC(i) + c * laser.dirS(i);
  if (shift != nullptr) {
    lx += shift->dlx;
    ly += shift->dly;
    rotate(&ux, &uy, shift->da);
  }
  const RayHit<S> hit = map.castDir(lx, ly, ux, uy, S(1e-6), cfg.range_max);
  if (!hit.hit) return Status::kNoMapHit;
  if (std::abs(hit.n_dot_u) < min_cos_incidence) return Status::kGrazing;
  if (hit.range < kNearRangeSigmas<S> * cfg.sigma) return Status::kTooClose;
  *range = hit.range;
  if (h != nullptr) {
    // r = (n.(a - pL)) / (n.u):  dr/dpL = -n/(n.u),  dr/dalpha = -r (n.u')/(n.u)
    const S inv = S(1) / hit.n_dot_u;
    const S drdx = -hit.nx * inv;
    const S drdy = -hit.ny * inv;
    const S n_dot_du = -hit.nx * uy + hit.ny * ux;
    const S drda = -hit.range * n_dot_du * inv;
    const S dlx = -sn * cfg.mount_x - c * cfg.mount_y;
    const S dly = c * cfg.mount_x - sn * cfg.mount_y;
    (*h) << drdx, drdy, drdx * dlx + drdy * dly + drda;
    if (geo != nullptr) {
      *geo = BeamContext<S>{hit.range, drdx, drdy, (*h)(2), drda, c, sn, hit.n_dot_u, hit.wall,
                            S(0), S(0), S(0), cfg.angle_min + S(i) * cfg.angle_inc};
    }
  }
  return Status::kOk;
}

template <typename ModelT>
template <typename MapT, int MaxBeams>
inline auto Akf<ModelT>::expectedRange(const MapT& map,
                                       const LaserGeometry<S, MaxBeams>& laser, const Pose<S>& p, int i,
                                       S max_incidence, S* range, Eigen::Matrix<S, 1, 3>* h) -> Status {
  return expectedRange(map, laser, p.x, p.y, std::cos(p.theta), std::sin(p.theta), i,
                       std::cos(max_incidence), range, h);
}

}  // namespace odoerr

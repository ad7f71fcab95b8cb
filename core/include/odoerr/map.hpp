// odoerr core: a known map of line segments and the ray-segment intersection used both to
// predict a beam's range (filter) and to simulate it (sim_host).
#pragma once

#include <Eigen/Core>

#include "odoerr/scalar.hpp"

namespace odoerr {

template <typename S>
struct Segment {
  S x1, y1, x2, y2;
};

/// Result of casting one ray against the map.
template <typename S>
struct RayHit {
  bool hit = false;
  int wall = -1;
  S range = S(0);
  S nx = S(0);      ///< unit normal of the wall that was hit
  S ny = S(0);
  S n_dot_u = S(0); ///< normal . ray direction: |n.u| = cos(incidence angle)
};

/// A fixed-capacity map (no heap). Walls are added at set-up time.
template <typename S, int MaxWalls = 32>
class SegmentMap {
 public:
  static constexpr int kMaxWalls = MaxWalls;

  /// Adds a wall; returns false when the map is full or the segment is degenerate or
  /// not finite.
  [[nodiscard]] bool add(const Segment<S>& w) {
    if (count_ >= MaxWalls) return false;
    if (!(isFinite(w.x1) && isFinite(w.y1) && isFinite(w.x2) && isFinite(w.y2))) return false;
    const S ex = w.x2 - w.x1;
    const S ey = w.y2 - w.y1;
    const S len = std::sqrt(ex * ex + ey * ey);
    if (!(len > S(0))) return false;
    Wall& d = walls_[count_++];
    d.seg = w;
    d.ex = ex;
    d.ey = ey;
    d.nx = -ey / len;
    d.ny = ex / len;
    return true;
  }

  int size() const { return count_; }
  const Segment<S>& wall(int i) const { return walls_[i].seg; }

  /// Nearest intersection of the ray p + r (cos a, sin a), r > min_range, with the map.
  RayHit<S> cast(S px, S py, S angle, S min_range = S(1e-6)) const {
    return castDir(px, py, std::cos(angle), std::sin(angle), min_range);
  }

  /// The same with the unit direction (ux, uy) given.
  RayHit<S> castDir(S px, S py, S ux, S uy, S min_range = S(1e-6)) const {
    RayHit<S> best;
    // Candidates are compared on numerators (r = rn / denom, t = tn / denom): one division
    // per ray instead of two per wall.
    S best_rn = S(0);
    S best_den = S(1);
    for (int i = 0; i < count_; ++i) {
      const Wall& w = walls_[i];
      // Solve p + r u = a + t e.  denom = u x e
      S denom = ux * w.ey - uy * w.ex;
      if (denom == S(0)) continue;  // parallel
      const S ax = w.seg.x1 - px;
      const S ay = w.seg.y1 - py;
      S rn = ax * w.ey - ay * w.ex;
      S tn = ax * uy - ay * ux;
      if (denom < S(0)) {
        denom = -denom;
        rn = -rn;
        tn = -tn;
      }
      if (!(rn > min_range * denom) || tn < S(0) || tn > denom) continue;
      if (best.hit && rn * best_den >= best_rn * denom) continue;  // not nearer
      best.hit = true;
      best.wall = i;
      best_rn = rn;
      best_den = denom;
    }
    if (best.hit) {
      const Wall& w = walls_[best.wall];
      best.range = best_rn / best_den;
      best.nx = w.nx;
      best.ny = w.ny;
      best.n_dot_u = w.nx * ux + w.ny * uy;
    }
    return best;
  }

 private:
  struct Wall {
    Segment<S> seg;
    S ex, ey;  // direction (unnormalised)
    S nx, ny;  // unit normal
  };
  Wall walls_[MaxWalls]{};
  int count_ = 0;
};

/// Range finder set-up (the `laser` record of odolog v1).
template <typename S>
struct LaserConfig {
  int beams = 36;
  S angle_min = -kPi<S>;
  S angle_inc = kTwoPi<S> / S(36);
  S range_max = S(20);
  S sigma = S(0.03);
  S mount_x = S(0);
  S mount_y = S(0);
  S mount_yaw = S(0);
};

/// The laser set-up with each beam's direction in the robot frame tabulated once, so that a
/// beam costs no trigonometry in the filter's inner loop.
template <typename S, int MaxBeams = 64>
class LaserGeometry {
 public:
  static constexpr int kMaxBeams = MaxBeams;
  LaserGeometry() = default;
  /// Returns false (and stays empty) when the set-up has too many beams or is not finite.
  [[nodiscard]] bool init(const LaserConfig<S>& cfg) {
    beams_ = 0;
    if (cfg.beams < 0 || cfg.beams > MaxBeams) return false;
    if (!(isFinite(cfg.angle_min) && isFinite(cfg.angle_inc) && isFinite(cfg.mount_x) &&
          isFinite(cfg.mount_y) && isFinite(cfg.mount_yaw) && cfg.sigma > S(0) &&
          cfg.range_max > S(0))) {
      return false;
    }
    cfg_ = cfg;
    for (int i = 0; i < cfg.beams; ++i) {
      const S a = cfg.mount_yaw + cfg.angle_min + S(i) * cfg.angle_inc;
      dir_c_[i] = std::cos(a);
      dir_s_[i] = std::sin(a);
    }
    beams_ = cfg.beams;
    return true;
  }
  int beams() const { return beams_; }
  const LaserConfig<S>& config() const { return cfg_; }
  S dirC(int i) const { return dir_c_[i]; }
  S dirS(int i) const { return dir_s_[i]; }

 private:
  LaserConfig<S> cfg_{};
  int beams_ = 0;
  S dir_c_[MaxBeams]{};
  S dir_s_[MaxBeams]{};
};

}  // namespace odoerr

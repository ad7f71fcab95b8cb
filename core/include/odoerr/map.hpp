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
    const S ux = std::cos(angle);
    const S uy = std::sin(angle);
    RayHit<S> best;
    for (int i = 0; i < count_; ++i) {
      const Wall& w = walls_[i];
      // Solve p + r u = a + t e.  denom = u x e
      const S denom = ux * w.ey - uy * w.ex;
      if (denom == S(0)) continue;  // parallel
      const S ax = w.seg.x1 - px;
      const S ay = w.seg.y1 - py;
      const S r = (ax * w.ey - ay * w.ex) / denom;
      const S t = (ax * uy - ay * ux) / denom;
      if (!(r > min_range) || t < S(0) || t > S(1)) continue;
      if (!best.hit || r < best.range) {
        best.hit = true;
        best.wall = i;
        best.range = r;
        best.nx = w.nx;
        best.ny = w.ny;
        best.n_dot_u = w.nx * ux + w.ny * uy;
      }
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

}  // namespace odoerr

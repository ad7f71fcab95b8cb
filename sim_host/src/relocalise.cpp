#include "odoerr/sim/relocalise.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace odoerr::sim {

bool LikelihoodField::build(const std::vector<OdologWall>& walls, double cell_m, double max_dist_m,
                            std::string* error) {
  d_.clear();
  if (walls.empty()) {
    *error = "the map has no wall to match a scan against";
    return false;
  }
  constexpr double kInf = std::numeric_limits<double>::infinity();
  double lo_x = kInf, lo_y = kInf, hi_x = -kInf, hi_y = -kInf;
  for (const OdologWall& w : walls) {
    if (!std::isfinite(w.x1) || !std::isfinite(w.y1) || !std::isfinite(w.x2) || !std::isfinite(w.y2)) {
      *error = "a wall of the map is not finite";
      return false;
    }
    lo_x = std::min({lo_x, w.x1, w.x2});
    lo_y = std::min({lo_y, w.y1, w.y2});
    hi_x = std::max({hi_x, w.x1, w.x2});
    hi_y = std::max({hi_y, w.y1, w.y2});
  }
  cell_ = cell_m;
  max_ = max_dist_m;
  const double margin = max_dist_m + cell_m;
  x0_ = lo_x - margin;
  y0_ = lo_y - margin;
  const double nx = std::ceil((hi_x - lo_x + 2 * margin) / cell_m) + 1;
  const double ny = std::ceil((hi_y - lo_y + 2 * margin) / cell_m) + 1;
  if (!(nx * ny <= 16.0 * 1024 * 1024)) {
    *error = "a likelihood field of " + std::to_string(cell_m) + " m cells over this map would exceed 16 M cells";
    return false;
  }
  nx_ = int(nx);
  ny_ = int(ny);
  const float big = float(max_dist_m);
  d_.assign(std::size_t(nx_) * std::size_t(ny_), big);
  // The walls drawn into the grid: points every half cell along each.
  for (const OdologWall& w : walls) {
    const double len = std::hypot(w.x2 - w.x1, w.y2 - w.y1);
    const int n = std::max(1, int(std::ceil(len / (0.5 * cell_m))));
    for (int k = 0; k <= n; ++k) {
      const double f = double(k) / n;
      const int i = int(std::floor((w.x1 + f * (w.x2 - w.x1) - x0_) / cell_m));
      const int j = int(std::floor((w.y1 + f * (w.y2 - w.y1) - y0_) / cell_m));
      if (i >= 0 && i < nx_ && j >= 0 && j < ny_) d_[std::size_t(j) * nx_ + i] = 0.0f;
    }
  }
  // Two-pass chamfer transform, weights 1 and sqrt(2) (in cells).
  const float a = float(cell_m), b = float(cell_m * std::sqrt(2.0));
  auto at = [&](int i, int j) -> float& { return d_[std::size_t(j) * nx_ + i]; };
  for (int j = 0; j < ny_; ++j) {
    for (int i = 0; i < nx_; ++i) {
      float v = at(i, j);
      if (i > 0) v = std::min(v, at(i - 1, j) + a);
      if (j > 0) {
        v = std::min(v, at(i, j - 1) + a);
        if (i > 0) v = std::min(v, at(i - 1, j - 1) + b);
        if (i + 1 < nx_) v = std::min(v, at(i + 1, j - 1) + b);
      }
      at(i, j) = v;
    }
  }
  for (int j = ny_ - 1; j >= 0; --j) {
    for (int i = nx_ - 1; i >= 0; --i) {
      float v = at(i, j);
      if (i + 1 < nx_) v = std::min(v, at(i + 1, j) + a);
      if (j + 1 < ny_) {
        v = std::min(v, at(i, j + 1) + a);
        if (i + 1 < nx_) v = std::min(v, at(i + 1, j + 1) + b);
        if (i > 0) v = std::min(v, at(i - 1, j + 1) + b);
      }
      at(i, j) = std::min(v, big);
    }
  }
  return true;
}

double LikelihoodField::distance(double x, double y) const {
  if (d_.empty()) return max_;
  const double fi = std::floor((x - x0_) / cell_), fj = std::floor((y - y0_) / cell_);
  if (!(fi >= 0 && fi < nx_ && fj >= 0 && fj < ny_)) return max_;
  return double(d_[std::size_t(fj) * std::size_t(nx_) + std::size_t(fi)]);
}

std::vector<ScanPoint> scanPoints(const OdologLaser& laser, const double* ranges, int max_points) {
  std::vector<ScanPoint> pts;
  int valid = 0;
  for (int i = 0; i < laser.beams; ++i) valid += std::isfinite(ranges[i]) && ranges[i] > 0 && ranges[i] < laser.range_max;
  if (valid == 0 || max_points < 1) return pts;
  const double step = valid > max_points ? double(valid) / max_points : 1.0;
  double next = 0;
  int k = 0;
  const double cm = std::cos(laser.mount_yaw), sm = std::sin(laser.mount_yaw);
  for (int i = 0; i < laser.beams; ++i) {
    const double r = ranges[i];
    if (!(std::isfinite(r) && r > 0 && r < laser.range_max)) continue;
    if (k++ < next) continue;
    next += step;
    const double a = laser.angle_min + i * laser.angle_inc;
    const double lx = r * std::cos(a), ly = r * std::sin(a);
    pts.push_back({laser.mount_x + cm * lx - sm * ly, laser.mount_y + sm * lx + cm * ly});
  }
  return pts;
}

double scanFit(const LikelihoodField& field, const std::vector<ScanPoint>& pts, double x, double y, double theta,
               double sigma) {
  if (pts.empty()) return 0;
  const double c = std::cos(theta), s = std::sin(theta), k = -0.5 / (sigma * sigma);
  double sum = 0;
  for (const ScanPoint& p : pts) {
    const double d = field.distance(x + c * p.x - s * p.y, y + s * p.x + c * p.y);
    sum += std::exp(k * d * d);
  }
  return sum / double(pts.size());
}

namespace {

// exp(-d^2 / (2 sigma^2)) tabulated over [0, max_dist] in 512 steps: the lattice's inner loop
// is a lookup.
class FitTable {
 public:
  FitTable(double sigma, double max_dist) : scale_(double(kN - 1) / max_dist) {
    for (int i = 0; i < kN; ++i) {
      const double d = double(i) / scale_;
      t_[std::size_t(i)] = std::exp(-0.5 * d * d / (sigma * sigma));
    }
  }
  double operator()(double d) const {
    const int i = int(d * scale_ + 0.5);
    return t_[std::size_t(i < kN ? i : kN - 1)];
  }

 private:
  static constexpr int kN = 512;
  double scale_;
  std::array<double, kN> t_{};
};

struct Candidate {
  double x, y, th, fit;
};

constexpr double kKeepFit = 0.2;  // a lattice pose fitting worse is never a candidate

// Two poses are distinct candidates when 0.5 m or 0.3 rad apart (ScanMatch::runner_up).
bool distinctPoses(const Candidate& a, const Candidate& b) {
  return std::hypot(a.x - b.x, a.y - b.y) >= 0.5 || std::fabs(std::remainder(a.th - b.th, 2 * M_PI)) >= 0.3;
}

// Every pose of the lattice (x +- n_xy*step_xy, th +- n_th*step_th) scored; the best ones
// (at most keep) appended to out.
void lattice(const LikelihoodField& field, const std::vector<ScanPoint>& pts, const Candidate& c, int n_xy,
             double step_xy, int n_th, double step_th, double sigma, std::size_t keep, std::vector<Candidate>* out) {
  std::vector<Candidate> all;
  std::vector<ScanPoint> rot(pts.size());
  const FitTable table(sigma, field.maxDistance());
  const double inv = 1.0 / double(std::max<std::size_t>(pts.size(), 1));
  for (int it = -n_th; it <= n_th; ++it) {
    const double th = c.th + it * step_th;
    const double ct = std::cos(th), st = std::sin(th);
    for (std::size_t q = 0; q < pts.size(); ++q) rot[q] = {ct * pts[q].x - st * pts[q].y, st * pts[q].x + ct * pts[q].y};
    for (int iy = -n_xy; iy <= n_xy; ++iy) {
      const double y = c.y + iy * step_xy;
      for (int ix = -n_xy; ix <= n_xy; ++ix) {
        const double x = c.x + ix * step_xy;
        double sum = 0;
        for (const ScanPoint& p : rot) sum += table(field.distance(x + p.x, y + p.y));
        const double fit = sum * inv;
        if (fit >= kKeepFit || all.empty()) all.push_back({x, y, th, fit});
      }
    }
  }
  std::sort(all.begin(), all.end(), [](const Candidate& a, const Candidate& b) { return a.fit > b.fit; });
  // The best ones that are distinct poses (0.5 m or 0.3 rad apart): the peaks, not one
  // peak's shoulders.
  std::vector<Candidate> picked;
  for (const Candidate& cand : all) {
    if (picked.size() >= keep) break;
    if (std::all_of(picked.begin(), picked.end(), [&](const Candidate& p) { return distinctPoses(cand, p); }))
      picked.push_back(cand);
  }
  out->insert(out->end(), picked.begin(), picked.end());
}

// At most 60 of the points, spread evenly: the coarse searches' subset.
std::vector<ScanPoint> coarseSubset(const std::vector<ScanPoint>& pts) {
  std::vector<ScanPoint> sub;
  const double every = pts.size() > 60 ? double(pts.size()) / 60 : 1.0;
  for (double f = 0; f < double(pts.size()); f += every) sub.push_back(pts[std::size_t(f)]);
  return sub;
}

// Each coarse candidate (of a 0.1 m / 0.02 rad lattice or finer) refined twice, on
// lattices four and sixteen times finer; `extra` (the filter's own pose) joins them. The
// best, and the best of the rest that is a distinct pose (its runner-up).
ScanMatch refine(const LikelihoodField& field, const std::vector<ScanPoint>& pts, const std::vector<Candidate>& coarse,
                 const Candidate* extra, double sigma) {
  constexpr double step_xy = 0.1, step_th = 0.02;
  std::vector<Candidate> refined;
  for (const Candidate& c0 : coarse) {
    std::vector<Candidate> r1;
    lattice(field, pts, c0, 4, step_xy / 4, 4, step_th / 4, sigma, 1, &r1);
    lattice(field, pts, r1.front(), 4, step_xy / 16, 4, step_th / 16, sigma, 1, &refined);
  }
  if (extra != nullptr) refined.push_back(*extra);
  if (refined.empty()) return {};
  const auto top = std::max_element(refined.begin(), refined.end(),
                                    [](const Candidate& a, const Candidate& b) { return a.fit < b.fit; });
  ScanMatch best{top->x, top->y, top->th, top->fit, 0};
  for (const Candidate& c : refined) {
    if (distinctPoses(c, *top)) best.runner_up = std::max(best.runner_up, c.fit);
  }
  return best;
}

}  // namespace

ScanMatch matchScan(const LikelihoodField& field, const std::vector<ScanPoint>& pts, double x, double y,
                    double theta, double window_m, double window_rad, double sigma) {
  ScanMatch best{x, y, theta, scanFit(field, pts, x, y, theta, sigma)};
  if (pts.empty() || field.empty()) return best;
  // Coarse: the whole window on a 0.1 m / 0.02 rad lattice, with at most 60 points and a
  // doubled sigma (a smoother fit, so the lattice's step does not miss the peak).
  const std::vector<ScanPoint> sub = coarseSubset(pts);
  const double step_xy = 0.1, step_th = 0.02;
  const int n_xy = std::max(0, int(std::ceil(window_m / step_xy)));
  const int n_th = std::max(0, int(std::ceil(window_rad / step_th)));
  std::vector<Candidate> coarse;
  lattice(field, sub, {x, y, theta, 0}, n_xy, step_xy, n_th, step_th, 2 * sigma, 8, &coarse);
  // Fine: each candidate refined twice, on lattices four and sixteen times finer.
  const Candidate here{x, y, theta, best.fit};
  return refine(field, pts, coarse, &here, sigma);
}

// The whole map (Cartographer's branch and bound, its idea, not its code). A point's fit is
// tabulated per field cell with the doubled sigma; level k of a pyramid holds, for each
// cell, the largest of the 2^k x 2^k cells from it on. A robot anywhere in a block of 2^k x
// 2^k cell centres puts each point in the 2^k x 2^k cells from the one the block's corner
// puts it in, so the mean of the points' level-k values bounds the fit of the whole block.
// Blocks are opened depth first from 2^L cells (about 3 m), the ones whose bound is below
// `floor` never; each single cell reaching it is a candidate, and the best distinct
// candidates are refined as in matchScan. A cell outside the grid is as far from a wall as
// the field reaches (the smallest value there is); a block reaching out of the grid on the
// low side takes the bound of the grid's first block (it holds every cell it could see).
ScanMatch matchGlobal(const LikelihoodField& field, const std::vector<ScanPoint>& pts, double sigma, double floor,
                      std::size_t* work) {
  std::size_t evaluated = 0;
  if (work != nullptr) *work = 0;
  if (pts.empty() || field.empty()) return {};
  const std::vector<ScanPoint> sub = coarseSubset(pts);
  const int nx = field.nx(), ny = field.ny();
  const double cell = field.cell();
  const FitTable table(2 * sigma, field.maxDistance());
  const float outside = float(table(field.maxDistance()));
  int levels = 0;
  while ((1 << levels) * cell < 3.0 && (1 << levels) < std::max(nx, ny)) ++levels;
  const std::size_t n = std::size_t(nx) * std::size_t(ny);
  // The pyramid holds levels + 2 grids of floats: on a very large field, fewer levels (more,
  // smaller root blocks: slower, the bound as valid) keep it within 256 MB.
  while (levels > 1 && n * std::size_t(levels + 2) * sizeof(float) > (std::size_t(256) << 20)) --levels;
  auto at = [nx](int i, int j) { return std::size_t(j) * std::size_t(nx) + std::size_t(i); };
  std::vector<std::vector<float>> pyr(std::size_t(levels) + 1, std::vector<float>(n));
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) pyr[0][at(i, j)] = float(table(field.cellDistance(i, j)));
  std::vector<float> tmp(n);
  for (int k = 1; k <= levels; ++k) {
    const int h = 1 << (k - 1);
    const std::vector<float>& g = pyr[std::size_t(k - 1)];
    std::vector<float>& out = pyr[std::size_t(k)];
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) tmp[at(i, j)] = std::max(g[at(i, j)], i + h < nx ? g[at(i + h, j)] : outside);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) out[at(i, j)] = std::max(tmp[at(i, j)], j + h < ny ? tmp[at(i, j + h)] : outside);
  }
  auto value = [&](int k, int ci, int cj) -> float {
    const int w = 1 << k;
    if (ci >= nx || cj >= ny || ci + w <= 0 || cj + w <= 0) return outside;
    return pyr[std::size_t(k)][at(std::max(ci, 0), std::max(cj, 0))];
  };
  const double inv = 1.0 / double(sub.size());
  const int n_th = int(std::ceil(2 * M_PI / 0.02));
  const double step_th = 2 * M_PI / n_th;
  std::vector<Candidate> cand;
  double bar = floor;
  std::vector<int> oi(sub.size()), oj(sub.size());
  struct Node {
    int k, i, j;
  };
  std::vector<Node> stack;
  for (int it = 0; it < n_th; ++it) {
    const double th = -M_PI + it * step_th;
    const double ct = std::cos(th), st = std::sin(th);
    for (std::size_t q = 0; q < sub.size(); ++q) {
      oi[q] = int(std::floor(0.5 + (ct * sub[q].x - st * sub[q].y) / cell));
      oj[q] = int(std::floor(0.5 + (st * sub[q].x + ct * sub[q].y) / cell));
    }
    auto bound = [&](int k, int i, int j) {
      double sum = 0;
      for (std::size_t q = 0; q < sub.size(); ++q) sum += double(value(k, i + oi[q], j + oj[q]));
      ++evaluated;
      return sum * inv;
    };
    const int w = 1 << levels;
    for (int j = 0; j < ny; j += w)
      for (int i = 0; i < nx; i += w) stack.push_back({levels, i, j});
    while (!stack.empty()) {
      const Node nd = stack.back();
      stack.pop_back();
      const double b = bound(nd.k, nd.i, nd.j);
      if (b < bar) continue;
      if (nd.k == 0) {
        cand.push_back({field.x0() + (nd.i + 0.5) * cell, field.y0() + (nd.j + 0.5) * cell, th, b});
        // A map with many look-alike places: keep the best 2000, and raise the bar to the
        // last of them.
        if (cand.size() >= 20000) {
          std::nth_element(cand.begin(), cand.begin() + 1999, cand.end(),
                           [](const Candidate& a, const Candidate& c) { return a.fit > c.fit; });
          bar = std::max(bar, cand[1999].fit);
          cand.resize(2000);
        }
        continue;
      }
      const int h = 1 << (nd.k - 1);
      for (int dj = 0; dj < 2; ++dj)
        for (int di = 0; di < 2; ++di) {
          const int ci = nd.i + di * h, cj = nd.j + dj * h;
          if (ci < nx && cj < ny) stack.push_back({nd.k - 1, ci, cj});
        }
    }
  }
  if (work != nullptr) *work = evaluated;
  if (cand.empty()) return {};
  std::sort(cand.begin(), cand.end(), [](const Candidate& a, const Candidate& b) { return a.fit > b.fit; });
  std::vector<Candidate> picked;
  for (const Candidate& c : cand) {
    if (picked.size() >= 8) break;
    if (std::all_of(picked.begin(), picked.end(), [&](const Candidate& p) { return distinctPoses(c, p); }))
      picked.push_back(c);
  }
  return refine(field, pts, picked, nullptr, sigma);
}

}  // namespace odoerr::sim

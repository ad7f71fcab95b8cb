#include "map_misfit.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

namespace odoerr::sim::diag {

namespace {

using json = nlohmann::ordered_json;

constexpr double kClipZ = 10.0;      // a beam's normalised residual counts at most this much
constexpr double kMinMeanZ = 1.0;    // a region's cells disagree by at least one laser sigma on average
constexpr int kMinScans = 10;        // a cell is tested when this many scans saw it
constexpr double kFamilyAlpha = 0.01;  // false-alarm rate over the whole map
constexpr double kCornerM = 0.05;    // a hit this close to a wall's end may jump walls: left out
constexpr double kMarginM = 1.0;     // the grid covers the walls' box and this much around it
constexpr double kMergeM = 0.3;      // short regions whose beams end this close are one thing
constexpr double kShortZ = 3.0;      // a beam this many sigmas short ended on something the map lacks
constexpr double kPlaceMarginM = 0.05;  // a short region's place: its extent and this much around
constexpr int kPlaceShareInv = 3;       // a scan disagrees there when 1 / this of its crossing beams ended there

/// Whether the segment (x0, y0)-(x1, y1) meets the box [bx0, bx1] x [by0, by1] (slabs).
bool segmentCrossesBox(double x0, double y0, double x1, double y1, double bx0, double by0, double bx1, double by1) {
  double t0 = 0, t1 = 1;
  const double d[2] = {x1 - x0, y1 - y0}, o[2] = {x0, y0}, lo[2] = {bx0, by0}, hi[2] = {bx1, by1};
  for (int k = 0; k < 2; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (o[k] < lo[k] || o[k] > hi[k]) return false;
      continue;
    }
    double a = (lo[k] - o[k]) / d[k], b = (hi[k] - o[k]) / d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    if (t0 > t1) return false;
  }
  return true;
}

/// z with P(|N(0,1)| > z) = p.
double twoSidedQuantile(double p) {
  double lo = 0, hi = 40;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (std::erfc(mid / std::sqrt(2.0)) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

template <typename En>
MapMisfit mapMisfit(const En& en, const typename En::RunOut& run, double cell_m) {
  MapMisfit m;
  m.cell_m = m.cell_asked_m = cell_m;
  const Odolog& log = en.log();
  const auto& laser = en.laser();
  const int nbeams = std::max(1, laser.beams());
  m.in_region.assign(log.scans.size() * static_cast<std::size_t>(nbeams), 0);
  if (log.walls.empty() || run.post_beams.empty() || !(cell_m > 0)) return m;
  const double inf = std::numeric_limits<double>::infinity();
  double x0 = inf, x1 = -inf, y0 = inf, y1 = -inf;
  for (const auto& w : log.walls) {
    x0 = std::min({x0, w.x1, w.x2});
    x1 = std::max({x1, w.x1, w.x2});
    y0 = std::min({y0, w.y1, w.y2});
    y1 = std::max({y1, w.y1, w.y2});
  }
  m.x0 = x0 - kMarginM;
  m.y0 = y0 - kMarginM;
  // The grid: at most kMaxGridCells cells, so a wider map gets wider cells (checked in
  // floating point before any conversion to int; a span a double cannot hold gets none).
  const double span_x = x1 - x0 + 2 * kMarginM, span_y = y1 - y0 + 2 * kMarginM;
  if (!std::isfinite(span_x) || !std::isfinite(span_y)) {
    m.grid_note = "the map's walls span more than a double holds: no grid of residuals";
    return m;
  }
  while (std::ceil(span_x / cell_m) * std::ceil(span_y / cell_m) > kMaxGridCells) cell_m *= 2;
  if (cell_m > m.cell_asked_m) {
    char note[200];
    std::snprintf(note, sizeof note, "the map spans %.3g x %.3g m: cells of %.3g m instead of %.3g (at most %.0f cells)",
                  span_x, span_y, cell_m, m.cell_asked_m, kMaxGridCells);
    m.grid_note = note;
  }
  m.cell_m = cell_m;
  m.nx = static_cast<int>(std::ceil(span_x / cell_m));
  m.ny = static_cast<int>(std::ceil(span_y / cell_m));
  const std::size_t ncell = static_cast<std::size_t>(m.nx) * static_cast<std::size_t>(m.ny);
  m.count.assign(ncell, 0);
  m.mean.assign(ncell, 0.0);
  m.rms.assign(ncell, 0.0);
  m.t.assign(ncell, std::numeric_limits<double>::quiet_NaN());
  const double sigma = std::max(1e-6, double(laser.config().sigma));

  struct Hit {
    int cell, post;
    long key;
    double z, mx, my;  // normalised residual; where the beam really ended
    double hx, hy;     // where the map says it ends
    double lx, ly;     // where it starts (the laser)
  };
  std::vector<Hit> hits;
  m.walls.resize(log.walls.size());
  m.wall_bin_m.resize(log.walls.size());
  for (std::size_t i = 0; i < log.walls.size(); ++i) {
    const auto& w = log.walls[i];
    const double len = std::hypot(w.x2 - w.x1, w.y2 - w.y1);  // finite: the span is
    const double bins = std::clamp(std::ceil(len / kWallBinM), 1.0, double(kMaxWallBins));
    m.walls[i].resize(static_cast<std::size_t>(bins));
    m.wall_bin_m[i] = std::max(kWallBinM, len / bins);
  }
  for (const PostBeam& b : run.post_beams) {
    const PostPose& q = run.post[static_cast<std::size_t>(b.post)];
    const Event& ev = en.events()[static_cast<std::size_t>(q.event)];
    if (ev.scan < 0) continue;
    BeamHit bh;
    if (!beamHit(en.map(), laser, q.x, q.y, q.th, b.beam, &bh)) continue;
    const double hx = bh.hx, hy = bh.hy;
    const auto& w = log.walls[static_cast<std::size_t>(bh.wall)];
    if (std::hypot(hx - w.x1, hy - w.y1) < kCornerM || std::hypot(hx - w.x2, hy - w.y2) < kCornerM) continue;
    const double fx = std::floor((hx - m.x0) / cell_m), fy = std::floor((hy - m.y0) / cell_m);
    if (!(fx >= 0 && fy >= 0 && fx < m.nx && fy < m.ny)) continue;  // off the grid, or not a number
    const int cx = static_cast<int>(fx), cy = static_cast<int>(fy);
    const double z = std::clamp(b.nu / sigma, -kClipZ, kClipZ);
    {  // along the wall: the hit's distance from the wall's first end
      auto& bins = m.walls[static_cast<std::size_t>(bh.wall)];
      const double along = std::hypot(hx - w.x1, hy - w.y1) / m.wall_bin_m[static_cast<std::size_t>(bh.wall)];
      const std::size_t k = along < double(bins.size()) ? static_cast<std::size_t>(along) : bins.size() - 1;
      ++bins[k].count;
      bins[k].sum += z;
    }
    const double rm = bh.range + b.nu;
    hits.push_back({cy * m.nx + cx, b.post, static_cast<long>(ev.scan) * nbeams + b.beam, z, bh.lx + rm * bh.ux,
                    bh.ly + rm * bh.uy, hx, hy, bh.lx, bh.ly});
  }
  // Per cell: the beams, and the scans (beams of one scan share its pose error, so the
  // test counts scans, not beams: per-scan means, then a t over them).
  std::vector<double> sum(ncell, 0.0), sum2(ncell, 0.0);
  std::vector<std::map<int, std::pair<double, int>>> per_scan(ncell);
  for (const Hit& h : hits) {
    const std::size_t k = static_cast<std::size_t>(h.cell);
    ++m.count[k];
    sum[k] += h.z;
    sum2[k] += h.z * h.z;
    auto& s = per_scan[k][h.post];
    s.first += h.z;
    s.second += 1;
  }
  for (std::size_t k = 0; k < ncell; ++k) {
    if (m.count[k] == 0) continue;
    m.mean[k] = sum[k] / double(m.count[k]);
    m.rms[k] = std::sqrt(sum2[k] / double(m.count[k]));
    const int ns = static_cast<int>(per_scan[k].size());
    if (ns < kMinScans) continue;
    double a = 0, a2 = 0;
    for (const auto& [post, s] : per_scan[k]) {
      const double v = s.first / s.second;
      a += v;
      a2 += v * v;
    }
    const double mu = a / ns, var = std::max(0.0, (a2 - ns * mu * mu) / (ns - 1));
    m.t[k] = var > 0 ? mu / std::sqrt(var / ns) : (mu != 0 ? std::copysign(1e9, mu) : 0.0);
    ++m.tested;
  }
  m.t_crit = m.tested > 0 ? twoSidedQuantile(kFamilyAlpha / m.tested) : 0.0;
  // Flagged cells, then connected regions (8 neighbours) of one sign.
  std::vector<int> sign(ncell, 0), label(ncell, -1);
  for (std::size_t k = 0; k < ncell; ++k)
    if (std::isfinite(m.t[k]) && std::abs(m.t[k]) > m.t_crit && std::abs(m.mean[k]) >= kMinMeanZ)
      sign[k] = m.mean[k] < 0 ? -1 : 1;
  for (std::size_t k0 = 0; k0 < ncell; ++k0) {
    if (sign[k0] == 0 || label[k0] >= 0) continue;
    MapRegion r;
    r.short_ = sign[k0] < 0;
    const int id = static_cast<int>(m.regions.size());
    std::vector<int> stack{static_cast<int>(k0)};
    label[k0] = id;
    while (!stack.empty()) {
      const int k = stack.back();
      stack.pop_back();
      r.cells.push_back(k);
      const int cx = k % m.nx, cy = k / m.nx;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int ax = cx + dx, ay = cy + dy;
          if (ax < 0 || ay < 0 || ax >= m.nx || ay >= m.ny) continue;
          const std::size_t a = static_cast<std::size_t>(ay * m.nx + ax);
          if (sign[a] != sign[k0] || label[a] >= 0) continue;
          label[a] = id;
          stack.push_back(static_cast<int>(a));
        }
    }
    m.regions.push_back(r);
  }
  // Region figures from their beams.
  for (std::size_t i = 0; i < m.regions.size(); ++i) {
    MapRegion& r = m.regions[i];
    double sx = 0, sy = 0, sz = 0;
    int cx0 = m.nx, cx1 = -1, cy0 = m.ny, cy1 = -1;
    for (int k : r.cells) {
      cx0 = std::min(cx0, k % m.nx);
      cx1 = std::max(cx1, k % m.nx);
      cy0 = std::min(cy0, k / m.nx);
      cy1 = std::max(cy1, k / m.nx);
    }
    r.w = (cx1 - cx0 + 1) * cell_m;
    r.h = (cy1 - cy0 + 1) * cell_m;
    std::vector<int> posts;
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    Eigen::Vector2d mm = Eigen::Vector2d::Zero();
    for (const Hit& h : hits) {
      if (label[static_cast<std::size_t>(h.cell)] != static_cast<int>(i)) continue;
      ++r.beams;
      sx += h.hx;
      sy += h.hy;
      sz += h.z;
      posts.push_back(h.post);
      if (h.key >= 0 && static_cast<std::size_t>(h.key) < m.in_region.size()) m.in_region[static_cast<std::size_t>(h.key)] = 1;
    }
    if (r.beams == 0) continue;
    r.x = sx / double(r.beams);
    r.y = sy / double(r.beams);
    r.mean_norm = sz / double(r.beams);
    // The beams whose real end points describe the thing. Something the map lacks stands
    // where the beams really ended, not where the map said they would (an object in the
    // open casts its evidence on the wall behind it): the beams that clearly ended early
    // (3 sigmas short) mark it; the cells' other beams (the wall seen past it from other
    // poses) do not. For a long region, all of them.
    double cut = 1e300;
    if (r.short_) {
      long n_short = 0;
      for (const Hit& h : hits)
        if (label[static_cast<std::size_t>(h.cell)] == static_cast<int>(i) && h.z <= -kShortZ) ++n_short;
      cut = n_short >= 10 ? -kShortZ : 0.0;
    }
    const bool clear = !r.short_ || cut < 0;  // its marks are clear enough to fit a wall to
    auto marks = [&](const Hit& h) { return label[static_cast<std::size_t>(h.cell)] == static_cast<int>(i) && h.z <= cut; };
    long nm = 0;
    mm.setZero();
    for (const Hit& h : hits)
      if (marks(h)) {
        mm += Eigen::Vector2d(h.mx, h.my);
        ++nm;
      }
    if (nm == 0) continue;
    mm /= double(nm);
    if (r.short_) {
      std::vector<double> xs, ys;
      for (const Hit& h : hits)
        if (marks(h)) {
          xs.push_back(h.mx);
          ys.push_back(h.my);
        }
      auto pct = [](std::vector<double> v, double q) {
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(q * double(v.size() - 1)), v.end());
        return v[static_cast<std::size_t>(q * double(v.size() - 1))];
      };
      r.x = pct(xs, 0.5);
      r.y = pct(ys, 0.5);
      r.w = pct(xs, 0.9) - pct(xs, 0.1);
      r.h = pct(ys, 0.9) - pct(ys, 0.1);
    }
    for (const Hit& h : hits)
      if (marks(h)) {
        const Eigen::Vector2d d(h.mx - mm[0], h.my - mm[1]);
        cov += d * d.transpose();
      }
    std::sort(posts.begin(), posts.end());
    posts.erase(std::unique(posts.begin(), posts.end()), posts.end());
    r.poses = static_cast<int>(posts.size());
    for (int j = 0; j < 6 && !posts.empty(); ++j) {
      const PostPose& q = run.post[static_cast<std::size_t>(posts[posts.size() * static_cast<std::size_t>(j) / 6])];
      r.seen_from.push_back({q.x, q.y});
    }
    // A candidate wall: where the beams really ended lies along a line, seen from many
    // poses (the measured points, not the map's: they are where the thing is).
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov / double(nm));
    const double l0 = es.eigenvalues()[0], l1 = es.eigenvalues()[1];
    if (clear && r.poses >= 20 && l1 > 0 && l0 < l1 / 25) {
      const Eigen::Vector2d dir = es.eigenvectors().col(1);
      double pmin = 1e300, pmax = -1e300;
      for (const Hit& h : hits)
        if (marks(h)) {
          const double p = dir.dot(Eigen::Vector2d(h.mx, h.my) - mm);
          pmin = std::min(pmin, p);
          pmax = std::max(pmax, p);
        }
      r.has_segment = true;
      r.seg[0] = mm[0] + pmin * dir[0];
      r.seg[1] = mm[1] + pmin * dir[1];
      r.seg[2] = mm[0] + pmax * dir[0];
      r.seg[3] = mm[1] + pmax * dir[1];
    }
  }
  // Short regions whose beams end in one place are one thing seen against several walls:
  // merged (their cells and beams together, the figures beam-weighted).
  for (std::size_t i = 0; i < m.regions.size(); ++i) {
    for (std::size_t j = i + 1; j < m.regions.size();) {
      MapRegion &a = m.regions[i], &b = m.regions[j];
      if (!a.short_ || !b.short_ || a.beams == 0 || b.beams == 0 ||
          std::hypot(a.x - b.x, a.y - b.y) > kMergeM + 0.5 * std::max({a.w, a.h, b.w, b.h})) {
        ++j;
        continue;
      }
      const double wa = double(a.beams), wb = double(b.beams);
      const double lo_x = std::min(a.x - a.w / 2, b.x - b.w / 2), hi_x = std::max(a.x + a.w / 2, b.x + b.w / 2);
      const double lo_y = std::min(a.y - a.h / 2, b.y - b.h / 2), hi_y = std::max(a.y + a.h / 2, b.y + b.h / 2);
      a.x = (a.x * wa + b.x * wb) / (wa + wb);
      a.y = (a.y * wa + b.y * wb) / (wa + wb);
      a.w = hi_x - lo_x;
      a.h = hi_y - lo_y;
      a.mean_norm = (a.mean_norm * wa + b.mean_norm * wb) / (wa + wb);
      a.beams += b.beams;
      a.poses = std::max(a.poses, b.poses);
      a.cells.insert(a.cells.end(), b.cells.begin(), b.cells.end());
      if (!a.has_segment && b.has_segment) {
        a.has_segment = true;
        std::copy(b.seg, b.seg + 4, a.seg);
      }
      m.regions.erase(m.regions.begin() + static_cast<std::ptrdiff_t>(j));
    }
  }
  // When each region was seen and how often it disagreed (map_history.hpp). A long region
  // (the map has a wall the ranges pass) is seen by the scans whose beams the map says end
  // in it; a scan disagrees when their mean z is kDisagreeZ or more. A short region
  // (something the map lacks) is a place where beams ended early: it is seen by every scan
  // with a beam whose line of sight crosses the place (the beam would end there if the
  // thing were there), and a scan disagrees when at least a third of those beams ended
  // there, kDisagreeZ or more short. A cabinet stops every beam that crosses it; a person walking
  // by stops few of the beams that cross the line they walk.
  {
    std::vector<int> region_of(ncell, -1);
    for (std::size_t i = 0; i < m.regions.size(); ++i)
      for (int k : m.regions[i].cells) region_of[static_cast<std::size_t>(k)] = static_cast<int>(i);
    for (std::size_t i = 0; i < m.regions.size(); ++i) {
      const MapRegion& r = m.regions[i];
      std::map<int, std::pair<int, int>> per_post;  // post -> (beams seeing it, disagreeing)
      if (!r.short_) {
        std::map<int, std::pair<double, int>> zs;
        for (const Hit& h : hits)
          if (region_of[static_cast<std::size_t>(h.cell)] == static_cast<int>(i)) {
            zs[h.post].first += h.z;
            ++zs[h.post].second;
          }
        for (const auto& [post, s] : zs) per_post[post] = {1, s.first / s.second >= kDisagreeZ ? 1 : 0};
      } else {
        const double hw = 0.5 * std::max(r.w, 0.1) + kPlaceMarginM, hh = 0.5 * std::max(r.h, 0.1) + kPlaceMarginM;
        const double bx0 = r.x - hw, bx1 = r.x + hw, by0 = r.y - hh, by1 = r.y + hh;
        for (const Hit& h : hits) {
          if (!segmentCrossesBox(h.lx, h.ly, h.hx, h.hy, bx0, by0, bx1, by1)) continue;
          auto& pp = per_post[h.post];
          ++pp.first;
          if (h.z <= -kDisagreeZ && h.mx >= bx0 && h.mx <= bx1 && h.my >= by0 && h.my <= by1) ++pp.second;
        }
      }
      std::vector<RegionSighting> seen;
      for (const auto& [post, c] : per_post)
        if (c.first > 0)
          seen.push_back({run.post[static_cast<std::size_t>(post)].t,
                          r.short_ ? kPlaceShareInv * c.second >= c.first : c.second > 0});
      m.regions[i].history = regionHistory(std::move(seen));
    }
  }
  // largest evidence first
  std::sort(m.regions.begin(), m.regions.end(), [](const MapRegion& a, const MapRegion& b) {
    return std::abs(a.mean_norm) * double(a.beams) > std::abs(b.mean_norm) * double(b.beams);
  });
  return m;
}

json mapMisfitJson(const MapMisfit& m, const std::string& grid_csv) {
  json regions = json::array();
  for (const MapRegion& r : m.regions) {
    json seen = json::array();
    for (const auto& p : r.seen_from) seen.push_back({p[0], p[1]});
    regions.push_back({{"x", r.x},
                       {"y", r.y},
                       {"extent_m", {r.w, r.h}},
                       {"sign", r.short_ ? "short" : "long"},
                       {"beams", r.beams},
                       {"mean_norm", r.mean_norm},
                       {"scans", r.poses},
                       {"seen_from", seen},
                       {"candidate_segment", r.has_segment ? json({r.seg[0], r.seg[1], r.seg[2], r.seg[3]}) : json(nullptr)},
                       {"history", regionHistoryJson(r.history)}});
  }
  json walls = json::array();
  for (std::size_t i = 0; i < m.walls.size(); ++i) {
    json bins = json::array();
    for (std::size_t k = 0; k < m.walls[i].size(); ++k) {
      const auto& b = m.walls[i][k];
      bins.push_back({{"from_m", double(k) * m.wall_bin_m[i]},
                      {"count", b.count},
                      {"mean_norm", b.count > 0 ? json(b.sum / double(b.count)) : json(nullptr)}});
    }
    walls.push_back({{"wall", i}, {"bin_m", m.wall_bin_m[i]}, {"bins", bins}});
  }
  json j = {{"cell_m", m.cell_m},
            {"cell_asked_m", m.cell_asked_m},
            {"wall_bin_m", kWallBinM},
            {"walls", walls},
            {"grid", {{"x0", m.x0}, {"y0", m.y0}, {"nx", m.nx}, {"ny", m.ny}}},
            {"cells_tested", m.tested},
            {"t_critical", m.tested > 0 ? json(m.t_crit) : json(nullptr)},
            {"family_alpha", kFamilyAlpha},
            {"regions", regions},
            {"grid_csv", grid_csv}};
  if (!m.grid_note.empty()) j["grid_note"] = m.grid_note;
  if (m.tested == 0) j["note"] = "no cell with enough beams: nothing tested (a log without laser has no beam)";
  return j;
}

bool writeMapCsv(const std::string& dir, const MapMisfit& m, std::string* error) {
  const std::string path = dir + "/map_grid.csv";
  FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    *error = "cannot write '" + path + "'";
    return false;
  }
  std::vector<int> region(m.count.size(), -1);
  for (std::size_t i = 0; i < m.regions.size(); ++i)
    for (int k : m.regions[i].cells) region[static_cast<std::size_t>(k)] = static_cast<int>(i);
  std::fprintf(f, "x,y,count,mean_norm,rms_norm,t,region\n");
  for (std::size_t k = 0; k < m.count.size(); ++k) {
    if (m.count[k] == 0) continue;
    const double x = m.x0 + (double(k % static_cast<std::size_t>(m.nx)) + 0.5) * m.cell_m;
    const double y = m.y0 + (double(k / static_cast<std::size_t>(m.nx)) + 0.5) * m.cell_m;
    std::fprintf(f, "%.3f,%.3f,%ld,%.4f,%.4f,%.3f,%d\n", x, y, m.count[k], m.mean[k], m.rms[k],
                 std::isfinite(m.t[k]) ? m.t[k] : 0.0, region[k]);
  }
  const bool ok = std::ferror(f) == 0;
  std::fclose(f);
  if (!ok) *error = "cannot write '" + path + "'";
  return ok;
}

template MapMisfit mapMisfit<Engine<SyncDrive>>(const Engine<SyncDrive>&, const Engine<SyncDrive>::RunOut&, double);
template MapMisfit mapMisfit<Engine<DiffDrive>>(const Engine<DiffDrive>&, const Engine<DiffDrive>::RunOut&, double);

}  // namespace odoerr::sim::diag

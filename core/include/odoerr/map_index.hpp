// odoerr core: building a map's grid index, once, allocation-free: the grid over the
// walls, its fence, and the cells' wall lists (map_tables.hpp's layout). SegmentMap calls
// it on the target; `odoerr map compile` on the host writes its result as constant tables.
#pragma once

#include <cstdint>

#include "odoerr/map_tables.hpp"

namespace odoerr {

/// Sets g's box inside the fence: half a cell in from the grid's edge (see gridFence).
template <typename S>
inline void setFenceBox(GridSpec<S>* g) {
  const S h = S(0.5) * g->cell;
  g->in_x0 = g->x0 + h;
  g->in_y0 = g->y0 + h;
  g->in_x1 = g->x0 + S(g->nx) * g->cell - h;
  g->in_y1 = g->y0 + S(g->ny) * g->cell - h;
}

/// The fence of a grid: four walls along the middle of its margin cells, which every ray
/// starting inside them hits (if nothing nearer), so that the walk needs no bounds test.
/// The grid's tables hold them after the map's own walls (indices n_walls .. n_walls + 3).
template <typename S>
inline void gridFence(const GridSpec<S>& g, WallRec<S> fence[4]) {
  const S gx1 = g.x0 + S(g.nx) * g.cell, gy1 = g.y0 + S(g.ny) * g.cell;
  const S x0 = g.in_x0, y0 = g.in_y0, x1 = g.in_x1, y1 = g.in_y1;  // setFenceBox
  // Each wall runs the grid's whole edge, past the box's corners, so that the four overlap
  // there: a ray aimed at a corner cannot slip between two of them by rounding.
  const Segment<S> sides[4] = {
      {g.x0, y0, gx1, y0}, {x1, g.y0, x1, gy1}, {gx1, y1, g.x0, y1}, {x0, gy1, x0, g.y0}};
  for (int k = 0; k < 4; ++k) (void)makeWallRec(sides[k], &fence[k]);
}

/// Whether wall w touches the closed cell [cx0, cx0 + cell] x [cy0, cy0 + cell] (grown by
/// a small margin, so that rounding never drops a wall from a cell its ray may meet).
template <typename S>
inline bool wallTouchesCell(const WallRec<S>& w, S cx0, S cy0, S cell) {
  const S m = cell * S(1e-3);
  const S lo_x = cx0 - m, hi_x = cx0 + cell + m, lo_y = cy0 - m, hi_y = cy0 + cell + m;
  const S x2 = w.x2, y2 = w.y2;
  // Bounding boxes first.
  if ((w.x1 < lo_x && x2 < lo_x) || (w.x1 > hi_x && x2 > hi_x) || (w.y1 < lo_y && y2 < lo_y) ||
      (w.y1 > hi_y && y2 > hi_y)) {
    return false;
  }
  // Then the wall's line: the box's corners must not all lie strictly on one side.
  const S d[4] = {w.ex * (lo_y - w.y1) - w.ey * (lo_x - w.x1), w.ex * (lo_y - w.y1) - w.ey * (hi_x - w.x1),
                  w.ex * (hi_y - w.y1) - w.ey * (lo_x - w.x1), w.ex * (hi_y - w.y1) - w.ey * (hi_x - w.x1)};
  const bool all_pos = d[0] > S(0) && d[1] > S(0) && d[2] > S(0) && d[3] > S(0);
  const bool all_neg = d[0] < S(0) && d[1] < S(0) && d[2] < S(0) && d[3] < S(0);
  return !all_pos && !all_neg;
}

/// The grid for `n` walls at cell size `cell`: a box around the walls, one cell of margin.
template <typename S>
inline IndexStatus gridFor(const WallRec<S>* walls, int n, S cell, int max_cells, GridSpec<S>* g) {
  if (!(cell > S(0)) || !isFinite(cell) || n <= 0) return IndexStatus::kBadCell;
  S lo_x = walls[0].x1, hi_x = lo_x, lo_y = walls[0].y1, hi_y = lo_y;
  for (int i = 0; i < n; ++i) {
    const S xs[2] = {walls[i].x1, walls[i].x1 + walls[i].ex};
    const S ys[2] = {walls[i].y1, walls[i].y1 + walls[i].ey};
    for (int k = 0; k < 2; ++k) {
      lo_x = xs[k] < lo_x ? xs[k] : lo_x;
      hi_x = xs[k] > hi_x ? xs[k] : hi_x;
      lo_y = ys[k] < lo_y ? ys[k] : lo_y;
      hi_y = ys[k] > hi_y ? ys[k] : hi_y;
    }
  }
  const S nxf = (hi_x - lo_x) / cell + S(3);
  const S nyf = (hi_y - lo_y) / cell + S(3);
  if (!(nxf * nyf <= S(max_cells))) return IndexStatus::kTooManyCells;
  g->cell = cell;
  g->inv_cell = S(1) / cell;
  g->nx = static_cast<int>(nxf);
  g->ny = static_cast<int>(nyf);
  g->x0 = lo_x - cell;
  g->y0 = lo_y - cell;
  setFenceBox(g);
  return IndexStatus::kOk;
}

/// Fills the grid's tables: cells (nx * ny entries, see MapCell) and cell_items (at most
/// max_items), each cell's walls in index order. Each wall visits only the cells of its
/// bounding box; two passes (count, then fill), no heap.
template <typename S>
inline IndexStatus fillGrid(const WallRec<S>* walls, int n, const GridSpec<S>& g, MapCell* cell_tab,
                            MapIndex* cell_items, int max_items, int* items_used) {
  const int cells = g.nx * g.ny;
  // The first pass counts cell c's walls in its low half; then each cell gets its start
  // and a count of 0, which the second pass counts up again as it fills.
  for (int c = 0; c < cells; ++c) cell_tab[c] = 0;
  auto cellRange = [&g](S a, S b, S origin, int n_cells, int* lo, int* hi) {
    const S mn = a < b ? a : b, mx = a < b ? b : a;
    *lo = static_cast<int>((mn - origin) * g.inv_cell) - 1;
    *hi = static_cast<int>((mx - origin) * g.inv_cell) + 1;
    *lo = *lo < 0 ? 0 : *lo;
    *hi = *hi >= n_cells ? n_cells - 1 : *hi;
  };
  int total = 0;
  for (int pass = 0; pass < 2; ++pass) {
    for (int i = 0; i < n; ++i) {
      const WallRec<S>& w = walls[i];
      int x_lo, x_hi, y_lo, y_hi;
      cellRange(w.x1, w.x2, g.x0, g.nx, &x_lo, &x_hi);
      cellRange(w.y1, w.y2, g.y0, g.ny, &y_lo, &y_hi);
      for (int iy = y_lo; iy <= y_hi; ++iy) {
        for (int ix = x_lo; ix <= x_hi; ++ix) {
          if (!wallTouchesCell(w, g.x0 + S(ix) * g.cell, g.y0 + S(iy) * g.cell, g.cell)) continue;
          const int c = iy * g.nx + ix;
          if (pass == 0) {
            if (total >= max_items || total >= kMaxMapIndex) return IndexStatus::kTooManyItems;
            ++total;
            ++cell_tab[c];
          } else {
            cell_items[cellStart(cell_tab[c]) + cellCount(cell_tab[c])] = static_cast<MapIndex>(i);
            ++cell_tab[c];
          }
        }
      }
    }
    if (pass == 0) {  // counts to starts (an empty cell stays 0)
      MapCell start = 0;
      for (int c = 0; c < cells; ++c) {
        const MapCell count = cell_tab[c];
        cell_tab[c] = count != 0 ? start << 16 : 0;
        start += count;
      }
    }
  }
  *items_used = total;
  return IndexStatus::kOk;
}

}  // namespace odoerr

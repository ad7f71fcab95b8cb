"""The part of the fixture that the map check adds to what `odoerr diagnose` writes:
diagnose.json's "map_misfit" and DIR/map_grid.csv.

The grid is the fixture's own beams (their predicted hit points and normalised residuals,
clipped at +-10) on 0.25 m cells over the walls' box plus 1 m. Planted: a cabinet the map
lacks, standing 35 cm in front of the right wall (x = 10) for 1 m around y = 5: the cells on
the wall behind it read short, one region of sign "short" with its candidate segment along the
cabinet's face. Used by make_fixture.py; only numpy."""
import os

import numpy as np

CELL = 0.25
CABINET = (9.65, 4.5, 9.65, 5.5)       # the face the laser sees (x1, y1, x2, y2)
SHIFT_Z = -4.2                         # what the cabinet does to the wall cells' mean z


def add_map_misfit(doc, outdir, walls, hx, hy, z, b_scan, scan_x, scan_y, rng):
    """Adds doc["map_misfit"] and writes outdir/map_grid.csv."""
    w = np.asarray(walls, float)
    x0 = float(np.floor(min(w[:, 0].min(), w[:, 2].min()) - 1.0))
    y0 = float(np.floor(min(w[:, 1].min(), w[:, 3].min()) - 1.0))
    nx = int(np.ceil((max(w[:, 0].max(), w[:, 2].max()) + 1.0 - x0) / CELL))
    ny = int(np.ceil((max(w[:, 1].max(), w[:, 3].max()) + 1.0 - y0) / CELL))
    z = np.clip(np.nan_to_num(z), -10, 10)
    ok = np.isfinite(hx) & np.isfinite(hy)
    ix = np.floor((hx - x0) / CELL).astype(np.int64)
    iy = np.floor((hy - y0) / CELL).astype(np.int64)
    ok &= (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    ix, iy, z, bs = ix[ok], iy[ok], z[ok], b_scan[ok]
    cx, cy = x0 + (ix + 0.5) * CELL, y0 + (iy + 0.5) * CELL
    behind = (cx > 9.7) & (cx < 10.3) & (cy > CABINET[1]) & (cy < CABINET[3])
    z = np.where(behind, z * 0.6 + SHIFT_Z, z)
    key = iy * nx + ix
    uk, inv = np.unique(key, return_inverse=True)
    cnt = np.bincount(inv)
    mean = np.bincount(inv, weights=z) / cnt
    rms = np.sqrt(np.bincount(inv, weights=z * z) / cnt)
    sd = np.sqrt(np.maximum(rms ** 2 - mean ** 2, 1e-6))
    t = mean / (sd / np.sqrt(np.maximum(cnt / 8.0, 1.0)))       # about 8 beams of a scan per cell
    ux, uy = x0 + (uk % nx + 0.5) * CELL, y0 + (uk // nx + 0.5) * CELL
    in_reg = (ux > 9.7) & (ux < 10.3) & (uy > CABINET[1]) & (uy < CABINET[3]) & (cnt >= 10)
    tested = int((cnt >= 30).sum())
    t_crit = 4.11
    with open(os.path.join(outdir, "map_grid.csv"), "w") as f:
        f.write("x,y,count,mean_norm,rms_norm,t,region\n")
        for k in range(len(uk)):
            f.write(f"{ux[k]:.3f},{uy[k]:.3f},{cnt[k]},{mean[k]:.4f},{rms[k]:.4f},{t[k]:.3f},"
                    f"{0 if in_reg[k] else -1}\n")
    sel = behind
    rb = int(sel.sum())
    scans = np.unique(bs[sel])
    pick = rng.choice(scans, min(6, scans.size), replace=False) if scans.size else []
    region = {"x": round(float(np.mean(cx[sel])), 4), "y": round(float(np.mean(cy[sel])), 4),
              "extent_m": [round(float(np.ptp(ux[in_reg]) + CELL), 3), round(float(np.ptp(uy[in_reg]) + CELL), 3)],
              "sign": "short", "beams": rb, "mean_norm": round(float(np.mean(z[sel])), 4), "scans": int(scans.size),
              "seen_from": [[round(float(scan_x[s]), 3), round(float(scan_y[s]), 3)] for s in pick],
              "candidate_segment": list(CABINET),
              # when it was seen and how often it disagreed (diagnose's map_history)
              "history": {"kind": "persistent",
                          "seen": {"scans": int(scans.size), "t_first": 2.0, "t_last": 231.5},
                          "disagreed": {"scans": int(0.9 * scans.size), "share": 0.9, "t_first": 2.0, "t_last": 231.5},
                          "change": None}}
    named = {r["effect"] for r in doc["ranking"] if r.get("significant")}
    doc["map_misfit"] = {
        "cell_m": CELL, "grid": {"x0": x0, "y0": y0, "nx": nx, "ny": ny}, "cells_tested": tested,
        "t_critical": t_crit, "family_alpha": 0.01, "regions": [region], "grid_csv": "map_grid.csv",
        "region_beams": "left out of the ranking",
        "ranking_with_region_beams": [
            {"effect": r["effect"], "significant": r["effect"] in named or r["effect"] == "laser_mount_xy",
             "p_value": 1e-7 if r["effect"] == "laser_mount_xy" else r.get("p_value")} for r in doc["ranking"]]}

"""scan_check.py: a line map against the laser scans of a corrected CARMEN log, at the
corrected poses: measured minus predicted range for every return that hits a segment.
This tells whether a map (and the beam geometry) agrees with the scans before any
estimator runs; a map built from the same log shares the SLAM system's errors, so it is a
consistency check, not an accuracy figure."""

import numpy as np

from carmen_grid import _beams


def ray_cast(x, y, angles, segs):
    """Range (inf: no hit) from (x, y) along each angle to the nearest segment (M x 4)."""
    a, e = segs[:, 0:2], segs[:, 2:4] - segs[:, 0:2]
    d = np.column_stack([np.cos(angles), np.sin(angles)])
    w = a[None, :, :] - np.array([x, y])[None, None, :]
    den = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (w[..., 0] * e[None, :, 1] - w[..., 1] * e[None, :, 0]) / den
        u = (w[..., 0] * d[:, None, 1] - w[..., 1] * d[:, None, 0]) / den
    ok = (s > 0) & (u >= 0) & (u <= 1)
    return np.where(ok, s, np.inf).min(axis=1)


def residuals(scans, segs, geo, max_range=20.0, every=1):
    """Measured minus predicted range (m) of the returns (<= max_range) that hit a segment,
    over every `every`-th scan; and how many returns had no segment to hit. scans: from
    carmen_grid.read_log (no return as nan); geo: its carmen_grid.Geometry."""
    segs = np.asarray(segs, dtype=float)
    out, missed = [], 0
    for s in scans[::every]:
        x, y, ang, reach, m = _beams(s, geo, max_range)
        pred = ray_cast(x, y, ang, segs)
        hit = m & np.isfinite(pred)
        missed += int((m & ~hit).sum())
        out.append(reach[hit] - pred[hit])
    res = np.concatenate(out) if out else np.zeros(0)
    return res, missed


def summary(res, missed):
    if len(res) == 0:
        raise ValueError("no return hit a segment: no residual to report")
    med = float(np.median(res))
    return dict(returns=int(len(res)), no_segment=missed, median_m=med,
                mad_m=float(np.median(np.abs(res - med))),
                within_10cm=float((np.abs(res) <= 0.10).mean()),
                within_30cm=float((np.abs(res) <= 0.30).mean()))

#!/usr/bin/env python3
"""odolog_check_sources.py: the physical checks of odolog_check.py, an imported odolog
file against the dataset it came from (OptiOdom run CSVs, CARMEN logs).

odolog_check.py runs them after its format checks (--optiodom-csv, --carmen-log); like it,
this file shares no code with the importers.

Checks:
- --optiodom-csv RUN: the file's constants equal the README's nominal robot
  (r = 0.084/2 m, 43.7*64 ticks/rev, d = 0.200 m); one enc and one truth per CSV row; each
  enc increment equals that row's nR / nL; the truth equals the row's mocap pose; the
  path length dead-reckoned from the written ticks (sum |(dR + dL)/2|) matches the mocap
  path length (polyline through every 5th sample, 0.25 s: at 20 Hz the mocap's sub-mm
  jitter would add several percent) within --path-tol (relative) when the mocap path is
  at least 0.5 m; the net rotation from the ticks ((dR - dL)/d) matches the mocap's net
  heading change within --rot-tol when that is at least 1 rad (on all 148 runs: path
  -0.1..+0.9 %, rotation +0.2..+2.5 %: the ticks over-read turns a little, as wheel
  slip or a slightly larger effective wheelbase would).
- --carmen-log LOG: the constants are the declared equivalent drive (0.0825 m, 4096,
  0.33 m); the truth poses are the FLASER poses in order. The log's intervals are read on
  their own (carmen_scans: after a FLASER, the first ODOM repeating its pose is its anchor;
  ODOM lines between a FLASER and its anchor belong to the interval before it when one of
  them carries the FLASER's stamp). Interval by interval, the ticks are dead-reckoned from
  the corrected pose P_k and must pass through EVERY raw ODOM line of the interval, up to
  the one paired with the next scan, within 2 cm / 0.01 rad (one enc step per ODOM line,
  or two where the importer wrote an arc and a turn in place: taken when the two land
  closer). An interval with no raw odometry in the log must be declared (meta
  odometry_gaps, the same count) and then ends at the next FLASER's odom fields. The
  path and the absolute rotation summed per ODOM line match the raw odometry's within
  --path-tol. With scan records: the laser's beam count is the FLASER's, each scan record
  sits at its truth's time and repeats the FLASER's ranges, `nan` for the readings at or
  above one no-return limit; the beam step and the mount's x equal the PARAMs
  laser_front_laser_resolution and robot_frontlaser_offset where the log states them, and
  the first beam is at -90 deg or at the start of a sector centred ahead.
"""

import gzip
import math


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def diff_consts(log):
    r = log.params["wheel_radius_m"]
    n = log.params["ticks_per_rev"]
    return 2 * math.pi * r / n, log.params["wheelbase_m"]


def expect_params(log, want, path, errs):
    if log.drive != "diff":
        errs.append(f"{path}: expected drive diff, got {log.drive}")
        return False
    for k, v in want.items():
        got = log.params.get(k)
        if got is None or abs(got - v) > 1e-9 * max(1.0, abs(v)):
            errs.append(f"{path}: param {k} is {got}, expected the nominal {v}")
    return True


def read_lines(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:2] == b"\x1f\x8b":
        data = gzip.decompress(data)
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    return data.decode("utf-8").splitlines()


def check_optiodom(log, path, csv, path_tol, rot_tol):
    errs, info = [], []
    if not expect_params(log, {"wheel_radius_m": 0.084 / 2, "ticks_per_rev": 43.7 * 64,
                               "wheelbase_m": 0.200}, path, errs):
        return errs, info
    rows = [[float(v) for v in ln.split(",")] for ln in read_lines(csv) if ln.strip()]
    if len(log.enc) != len(rows) or len(log.truth) != len(rows):
        errs.append(f"{path}: {len(log.enc)} enc / {len(log.truth)} truth records for {len(rows)} CSV rows")
        return errs, info
    prev = (0, 0)
    for i, (row, e, q) in enumerate(zip(rows, log.enc, log.truth)):
        d = (e[1] - prev[0], e[2] - prev[1])
        prev = e[1:3]
        if d != (int(row[4]), int(row[5])):
            errs.append(f"{path}:{e[3]}: enc increment {d} differs from CSV row {i + 1} (nR, nL) "
                        f"= ({int(row[4])}, {int(row[5])})")
            break
        if abs(e[0] - row[0]) > 1e-5 or abs(q[0] - row[0]) > 1e-5 or \
                max(abs(q[1] - row[1]), abs(q[2] - row[2]), abs(q[3] - row[3])) > 2e-6:
            errs.append(f"{path}:{q[4]}: truth/time differs from CSV row {i + 1}")
            break
    if log.init is None or max(abs(log.init[j] - rows[0][1 + j]) for j in range(3)) > 2e-6:
        errs.append(f"{path}: init is not the first mocap pose")
    tick, d = diff_consts(log)
    enc_path = enc_rot = 0.0
    for a, b in zip(log.enc, log.enc[1:]):
        dr, dl = (b[1] - a[1]) * tick, (b[2] - a[2]) * tick
        enc_path += abs(dr + dl) / 2
        enc_rot += (dr - dl) / d
    sub = rows[::5]
    if sub[-1] is not rows[-1]:
        sub.append(rows[-1])
    moc_path = sum(math.hypot(q[1] - p[1], q[2] - p[2]) for p, q in zip(sub, sub[1:]))
    moc_rot = rows[-1][3] - rows[0][3]
    info.append(f"path: ticks {enc_path:.3f} m, mocap {moc_path:.3f} m "
                f"({(enc_path / moc_path - 1) * 100 if moc_path > 0 else 0:+.2f} %)")
    info.append(f"net rotation: ticks {enc_rot:.3f} rad, mocap {moc_rot:.3f} rad "
                f"({(enc_rot / moc_rot - 1) * 100 if abs(moc_rot) > 0 else 0:+.2f} %)")
    if moc_path >= 0.5 and abs(enc_path / moc_path - 1) > path_tol:
        errs.append(f"{path}: dead-reckoned path {enc_path:.3f} m vs mocap {moc_path:.3f} m: "
                    f"more than {path_tol * 100:g} % apart")
    if abs(moc_rot) >= 1.0 and abs(enc_rot / moc_rot - 1) > rot_tol:
        errs.append(f"{path}: dead-reckoned rotation {enc_rot:.3f} rad vs mocap {moc_rot:.3f} rad: "
                    f"more than {rot_tol * 100:g} % apart")
    return errs, info


CARMEN_TOL = 1e-4   # m / rad: an anchor ODOM repeats its FLASER's pose


def carmen_scans(lines):
    """The log's scans, in order: [pose, odom fields, ranges, stamp, subs], subs being the raw
    ODOM poses of the interval from this scan to the next (after this scan's anchor, up to
    and including the ODOM line paired with the next scan), and the PARAM values by name.

    Read on its own from the CARMEN layout (not the importer's code): after FLASER k, the
    first ODOM line that repeats its pose is its anchor and is skipped. ODOM lines between a
    FLASER and its anchor belong to the interval before it when one of them carries the
    FLASER's stamp (its odometry logged after it), up to that one; otherwise to the
    interval after it."""
    scans = []
    params = {}
    after = None            # raw ODOM (pose, stamp) between the last FLASER and its anchor
    prefix_stamp = None     # stamp of the last ODOM line before the first FLASER

    def close(a, b):
        return abs(a[0] - b[0]) <= CARMEN_TOL and abs(a[1] - b[1]) <= CARMEN_TOL and \
            abs(wrap(a[2] - b[2])) <= CARMEN_TOL

    def settle():
        k = len(scans) - 1
        if after is None or k < 0:
            return
        st = scans[k][3]
        before = scans[k - 1][4][-1][1] if k > 0 and scans[k - 1][4] else (prefix_stamp if k == 0 else None)
        idx = [i for i, (o, s2) in enumerate(after) if s2 == st] if st != 0 and before != st else []
        if idx:
            i = idx[-1]
            if k > 0:
                scans[k - 1][4].extend(after[:i + 1])
            scans[k][4][:0] = after[i + 1:]
        else:
            scans[k][4][:0] = after

    for ln in lines:
        f = ln.split()
        if not f:
            continue
        if f[0] == "PARAM" and len(f) >= 3:
            params.setdefault(f[1], f[2])
        elif f[0] == "FLASER":
            settle()
            n = int(f[1])
            v = [float(x) for x in f[n + 2:n + 9]]
            scans.append([tuple(v[0:3]), tuple(v[3:6]), f[2:2 + n], v[6], []])
            after = []
        elif f[0] == "ODOM":
            o = (float(f[1]), float(f[2]), float(f[3]))
            st = float(f[7])
            if not scans:
                prefix_stamp = st
            elif after is not None:
                if close(o, scans[-1][0]):
                    settle()
                    after = None
                else:
                    after.append((o, st))
            else:
                scans[-1][4].append((o, st))
    settle()
    return scans, params


def check_carmen(log, path, src, path_tol):
    errs, info = [], []
    if not expect_params(log, {"wheel_radius_m": 0.0825, "ticks_per_rev": 4096, "wheelbase_m": 0.33},
                         path, errs):
        return errs, info
    scans, params = carmen_scans(read_lines(src))
    m = len(log.truth)
    if m == 0 or m > len(scans):
        errs.append(f"{path}: {m} truth records, the log has {len(scans)} scans")
        return errs, info
    for k in range(m):
        q, p = log.truth[k], scans[k][0]
        if max(abs(q[1] - p[0]), abs(q[2] - p[1]), abs(wrap(q[3] - p[2]))) > 2e-6:
            errs.append(f"{path}:{q[4]}: truth {k} is not FLASER pose {k} {p}")
            return errs, info
    # intervals with no raw odometry in the log: the file must say it filled them
    gaps = [k for k in range(m - 1) if not scans[k][4]]
    declared = log.meta_int("odometry_gaps") or 0
    if len(gaps) != declared:
        errs.append(f"{path}: {len(gaps)} intervals have no raw odometry in the log (the first: interval "
                    f"{gaps[0] if gaps else '-'}), the file declares {declared} (meta odometry_gaps)")
        return errs, info
    tick, d = diff_consts(log)
    # enc records between consecutive truth records, in file order
    groups = [[] for _ in range(m)]
    last_enc = None
    k = -1
    for kind, i in log.order:
        if kind == "truth":
            k += 1
            if last_enc is not None:
                groups[k].append(last_enc)      # the enc the truth sits on starts the group
        elif kind == "enc":
            last_enc = log.enc[i]
            if k >= 0:
                groups[k].append(last_enc)
    raw_path = raw_rot = enc_path = enc_rot = 0.0
    worst_pos = worst_th = 0.0
    worst_k = -1
    gaps_end = []
    n_targets = n_two = 0
    for k in range(m - 1):
        p0 = scans[k][0]
        targets = [o for o, st in scans[k][4]] or [scans[k + 1][1]]
        g = groups[k]
        steps = [((b[1] - a[1]) * tick, (b[2] - a[2]) * tick) for a, b in zip(g, g[1:])]
        extra = len(steps) - len(targets)
        if not 0 <= extra <= len(targets):
            errs.append(f"{path}: interval {k}: {len(steps)} enc steps for {len(targets)} ODOM sub-steps")
            return errs, info
        pose = tuple(log.truth[k][1:4])

        def dr(p, st):
            x, y, th = p
            for r, l in st:
                rho, dth = (r + l) / 2, (r - l) / d
                x += rho * math.cos(th + dth / 2)
                y += rho * math.sin(th + dth / 2)
                th += dth
            return x, y, th

        def err(p, o):
            return math.hypot(p[0] - o[0], p[1] - o[1]) + abs(wrap(p[2] - o[2]))

        prev = p0
        j = 0
        for o in targets:
            take = 1
            if extra > 0 and j + 2 <= len(steps) and \
                    err(dr(pose, steps[j:j + 2]), o) < err(dr(pose, steps[j:j + 1]), o):
                take = 2
            if j + take > len(steps):
                errs.append(f"{path}: interval {k}: the enc steps run out before the ODOM sub-steps")
                return errs, info
            part = steps[j:j + take]
            new = dr(pose, part)
            enc_path += abs(sum((r + l) / 2 for r, l in part))
            enc_rot += abs(wrap(sum((r - l) / d for r, l in part)))
            raw_path += math.hypot(o[0] - prev[0], o[1] - prev[1])
            raw_rot += abs(wrap(o[2] - prev[2]))
            gp, gt = math.hypot(new[0] - o[0], new[1] - o[1]), abs(wrap(new[2] - o[2]))
            if gp > worst_pos:
                worst_pos, worst_k = gp, k
            worst_th = max(worst_th, gt)
            extra -= take - 1
            n_two += take - 1
            n_targets += 1
            j += take
            pose, prev = new, o
        if j != len(steps):
            errs.append(f"{path}: interval {k}: {len(steps) - j} enc steps left over after the ODOM sub-steps")
            return errs, info
        gaps_end.append(math.hypot(pose[0] - targets[-1][0], pose[1] - targets[-1][1]))
    gaps_end.sort()
    med = gaps_end[len(gaps_end) // 2] if gaps_end else 0.0
    info.append(f"scans {m}, intervals checked {m - 1} ({len(gaps)} without raw odometry, filled as declared)")
    info.append(f"ODOM sub-steps {n_targets}, {n_two} of them written as two enc steps (arc + turn)")
    info.append(f"path: ticks {enc_path:.3f} m, raw odometry {raw_path:.3f} m "
                f"({(enc_path / raw_path - 1) * 100 if raw_path else 0:+.3f} %)")
    info.append(f"abs rotation: ticks {enc_rot:.3f} rad, raw odometry {raw_rot:.3f} rad "
                f"({(enc_rot / raw_rot - 1) * 100 if raw_rot else 0:+.3f} %)")
    info.append(f"gap to the raw odometry at every ODOM line: interval ends median {med * 1000:.2f} mm, "
                f"max {worst_pos * 1000:.2f} mm (interval {worst_k}), max heading {worst_th:.5f} rad")
    if raw_path > 0 and abs(enc_path / raw_path - 1) > path_tol:
        errs.append(f"{path}: dead-reckoned path {enc_path:.3f} m vs raw odometry {raw_path:.3f} m")
    if raw_rot > 0 and abs(enc_rot / raw_rot - 1) > path_tol:
        errs.append(f"{path}: dead-reckoned rotation {enc_rot:.3f} rad vs raw odometry {raw_rot:.3f} rad")
    if worst_pos > 0.02 or worst_th > 0.01:
        errs.append(f"{path}: dead-reckoned ticks miss the raw odometry by up to "
                    f"{worst_pos * 1000:.1f} mm / {worst_th:.4f} rad")
    if log.laser is not None and log.scan_ranges is not None:
        errs += check_carmen_laser(log, path, scans, params, info)
    return errs, info


def check_carmen_laser(log, path, scans, params, info):
    """The laser record and the scans against the FLASER lines and the PARAMs."""
    errs = []
    n, start, step, rmax, sigma, mx, my, myaw = log.laser
    n = int(n)
    if n != len(scans[0][2]):
        return [f"{path}: laser N {n}, the log's FLASER lines have {len(scans[0][2])} beams"]
    if len(log.scan_ranges) != len(log.truth):
        return [f"{path}: {len(log.scan_ranges)} scan records for {len(log.truth)} truth records"]
    span = (n - 1) * step
    if min(abs(start + math.pi / 2), abs(start + span / 2), abs(start + (span + step) / 2)) > 1e-4:
        errs.append(f"{path}: the first beam at {math.degrees(start):g} deg is neither -90 deg nor the "
                    f"sector's centred start")
    checks = []
    if "laser_front_laser_resolution" in params:
        want = math.radians(float(params["laser_front_laser_resolution"]))
        checks.append(("step", step, want, "laser_front_laser_resolution"))
    if "robot_frontlaser_offset" in params:
        checks.append(("mount x", mx, float(params["robot_frontlaser_offset"]), "robot_frontlaser_offset"))
    for what, got, want, name in checks:
        if abs(got - want) > 1e-6:
            errs.append(f"{path}: laser {what} {got:g}, PARAM {name} says {want:g}")
    kept_max, nan_min, nans = -math.inf, math.inf, 0
    for k, ((t, toks), sc) in enumerate(zip(log.scan_ranges, scans)):
        if abs(t - log.truth[k][0]) > 1e-9:
            errs.append(f"{path}: scan {k} at t={t}, its truth at t={log.truth[k][0]}")
            break
        for a, b in zip(toks, sc[2]):
            v = float(b)
            if a.lower() == "nan":
                nan_min = min(nan_min, v)
                nans += 1
            elif float(a) != v:
                errs.append(f"{path}: scan {k}: range {a}, the FLASER says {b}")
                return errs
            else:
                kept_max = max(kept_max, v)
    if nans and kept_max >= nan_min:
        errs.append(f"{path}: no single no-return limit: {nan_min:g} m written as nan, {kept_max:g} m kept")
    info.append(f"laser: {n} beams, first at {math.degrees(start):.4f} deg, {math.degrees(step):.4f} deg apart, "
                f"mount x {mx:g} m; {len(log.scan_ranges)} scans equal to the FLASER ranges, {nans} nan "
                f"(readings >= {nan_min:g} m)" if nans else
                f"laser: {n} beams, first at {math.degrees(start):.4f} deg, {math.degrees(step):.4f} deg apart, "
                f"mount x {mx:g} m; {len(log.scan_ranges)} scans equal to the FLASER ranges, no nan")
    return errs

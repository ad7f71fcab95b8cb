#!/usr/bin/env python3
"""odolog_check.py: an independent, minimal checker of odolog v1 files, plus physical
sanity checks of the two dataset importers against their sources.

Usage:
    odolog_check.py FILE [--any-enc-start]
    odolog_check.py FILE --optiodom-csv RUN_CSV [--path-tol 0.05] [--rot-tol 0.05]
    odolog_check.py FILE --carmen-log LOG[.gz] [--path-tol 0.05]

It shares no code with the importers or with the C++ reader (sim_host/src/odolog.cpp):
it re-reads the rules of docs/odolog.md on its own, so that a mistake in one place is
not copied into the other.

Format checks (every file):
- the first non-comment record is `odolog 1` and appears only once;
- header records (drive, param, laser, wall, init, meta) come before the first data
  record (enc, scan, pose, truth); `drive` once, before any data record, diff or sync;
  each param NAME once, a finite number; the drive's required params present and > 0;
- field counts per record type: laser 8, wall 4, init 6, enc 3, scan 1 + N (N from
  laser), pose 7, truth 4, meta >= 1; numbers finite (nan only as a scan range); enc
  counts signed 64-bit integers; init / pose sigmas > 0;
- data records in non-decreasing time;
- enc counts cumulative: the first enc record is `0 0` (counts since the start of the
  log; --any-enc-start relaxes this for logs that start mid-count);
- unknown record types must be lower-case words; they are counted, not refused.

Physical checks:
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
  0.33 m); the truth poses are the FLASER poses in order; for the scans in the file, the
  raw odometry path (sum of the sub-step translations between consecutive ODOM lines of
  each anchored segment) matches the path dead-reckoned from the ticks within --path-tol,
  the absolute rotation likewise; and, interval by interval, dead-reckoning the ticks from
  the corrected pose P_k lands on the raw odometry O_(k+1) (the ODOM line before the next
  FLASER): the position and heading gaps are reported and must stay below 2 cm / 0.01
  rad (they come only from the tick quantisation and the dropped sideways motion).

Exit status: 0 all checks pass, 1 a check fails (each failure printed as FILE:LINE: rule
or FILE: what), 2 bad usage or unreadable input.
"""

import argparse
import gzip
import math
import re
import sys

HEADER = {"drive", "param", "laser", "wall", "init", "meta"}
DATA = {"enc", "scan", "pose", "truth"}
REQUIRED = {"diff": ("wheel_radius_m", "ticks_per_rev", "wheelbase_m"),
            "sync": ("ticks_per_m", "ticks_per_rad")}
NUM = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")
INT = re.compile(r"^[+-]?\d+$")
WORD = re.compile(r"^[a-z0-9_]+$")


class Fail(Exception):
    pass


def tokens(line):
    i = line.find("#")
    if i >= 0:
        line = line[:i]
    return line.split()


def number(tok, nan_ok=False):
    if tok.lower() == "nan":
        return math.nan if nan_ok else None
    if not NUM.match(tok):
        return None
    v = float(tok)
    return v if math.isfinite(v) else None


class Log:
    def __init__(self):
        self.drive = None
        self.params = {}
        self.laser_n = None
        self.walls = 0
        self.init = None
        self.meta = []
        self.enc = []     # (t, a, b, line)
        self.truth = []   # (t, x, y, th, line)
        self.pose = []
        self.scans = 0
        self.unknown = 0
        self.order = []   # ('enc'|'truth'|..., index) in file order


def check_format(path, any_enc_start):
    """Parses and validates; returns (Log, [errors])."""
    errs = []
    log = Log()
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise Fail(f"{path}: cannot read: {e.strerror or e}")
    seen_version = False
    in_data = False
    last_t = -math.inf

    def err(no, msg):
        errs.append(f"{path}:{no}: {msg}")

    for no, raw in enumerate(data.split(b"\n"), start=1):
        if len(errs) >= 20:
            errs.append(f"{path}: (stopping after 20 errors)")
            break
        try:
            line = raw.decode("utf-8")
        except UnicodeDecodeError:
            err(no, "not UTF-8 text")
            continue
        f = tokens(line)
        if not f:
            continue
        typ = f[0]
        if not seen_version:
            if f != ["odolog", "1"]:
                err(no, "the first record must be 'odolog 1'")
                break
            seen_version = True
            continue
        if typ == "odolog":
            err(no, "'odolog' appears again")
            continue
        args = f[1:]
        if typ in HEADER:
            if in_data:
                err(no, f"header record '{typ}' after the first data record")
                continue
            if typ == "drive":
                if len(args) != 1 or args[0] not in REQUIRED:
                    err(no, "drive takes one field, diff or sync")
                elif log.drive is not None:
                    err(no, "drive given twice")
                else:
                    log.drive = args[0]
            elif typ == "param":
                if len(args) != 2:
                    err(no, f"param takes 2 fields, got {len(args)}")
                elif args[0] in log.params:
                    err(no, f"param {args[0]} given twice")
                elif number(args[1]) is None:
                    err(no, f"param value '{args[1]}' is not a finite number")
                else:
                    log.params[args[0]] = number(args[1])
            elif typ == "laser":
                if len(args) != 8:
                    err(no, f"laser takes 8 fields, got {len(args)}")
                elif log.laser_n is not None:
                    err(no, "laser given twice")
                elif not INT.match(args[0]) or not 1 <= int(args[0]) <= 4096:
                    err(no, "laser N must be an integer in 1..4096")
                elif any(number(a) is None for a in args[1:]):
                    err(no, "laser field not a finite number")
                elif not (number(args[3]) > 0 and number(args[4]) > 0):
                    err(no, "laser RANGE_MAX and SIGMA must be positive")
                else:
                    log.laser_n = int(args[0])
            elif typ == "wall":
                v = [number(a) for a in args]
                if len(args) != 4:
                    err(no, f"wall takes 4 fields, got {len(args)}")
                elif None in v:
                    err(no, "wall coordinate not a finite number")
                elif v[0:2] == v[2:4]:
                    err(no, "wall has zero length")
                else:
                    log.walls += 1
            elif typ == "init":
                v = [number(a) for a in args]
                if len(args) != 6:
                    err(no, f"init takes 6 fields, got {len(args)}")
                elif None in v:
                    err(no, "init field not a finite number")
                elif not all(s > 0 for s in v[3:]):
                    err(no, "init sigmas must be positive")
                elif log.init is not None:
                    err(no, "init given twice")
                else:
                    log.init = v
            else:  # meta
                if not args:
                    err(no, "meta takes KEY VALUE...")
                else:
                    log.meta.append((args[0], " ".join(args[1:])))
            continue
        if typ in DATA:
            if log.drive is None:
                err(no, f"data record '{typ}' before the drive record")
                continue
            in_data = True
            if not args:
                err(no, f"{typ} needs a time")
                continue
            t = number(args[0])
            if t is None:
                err(no, f"time '{args[0]}' is not a finite number")
                continue
            if t < last_t:
                err(no, f"time goes backwards: {args[0]} after {last_t!r}")
            last_t = max(last_t, t)
            if typ == "enc":
                if len(args) != 3:
                    err(no, f"enc takes 3 fields, got {len(args)}")
                elif not (INT.match(args[1]) and INT.match(args[2])):
                    err(no, "enc counts must be integers")
                elif not all(-2**63 <= int(a) < 2**63 for a in args[1:]):
                    err(no, "enc counts must fit in signed 64 bits")
                else:
                    log.order.append(("enc", len(log.enc)))
                    log.enc.append((t, int(args[1]), int(args[2]), no))
            elif typ == "scan":
                if log.laser_n is None:
                    err(no, "scan before the laser record")
                elif len(args) != 1 + log.laser_n:
                    err(no, f"scan has {len(args) - 1} ranges, laser says {log.laser_n}")
                elif any(number(a, nan_ok=True) is None for a in args[1:]):
                    err(no, "scan range not a number (nan allowed)")
                else:
                    log.scans += 1
            elif typ == "pose":
                v = [number(a) for a in args]
                if len(args) != 7:
                    err(no, f"pose takes 7 fields, got {len(args)}")
                elif None in v:
                    err(no, "pose field not a finite number")
                elif not all(s > 0 for s in v[4:]):
                    err(no, "pose sigmas must be positive")
                else:
                    log.order.append(("pose", len(log.pose)))
                    log.pose.append(tuple(v) + (no,))
            else:
                v = [number(a) for a in args]
                if len(args) != 4:
                    err(no, f"truth takes 4 fields, got {len(args)}")
                elif None in v:
                    err(no, "truth field not a finite number")
                else:
                    log.order.append(("truth", len(log.truth)))
                    log.truth.append(tuple(v) + (no,))
            continue
        if not WORD.match(typ):
            err(no, f"record type '{typ}' is not a lower-case word")
        else:
            log.unknown += 1
    if not seen_version:
        errs.append(f"{path}: no 'odolog 1' record")
    elif log.drive is None:
        errs.append(f"{path}: no drive record")
    else:
        for name in REQUIRED[log.drive]:
            if name not in log.params:
                errs.append(f"{path}: drive {log.drive} needs param {name}")
            elif not log.params[name] > 0:
                errs.append(f"{path}: param {name} must be positive")
    if log.enc and not any_enc_start and log.enc[0][1:3] != (0, 0):
        errs.append(f"{path}:{log.enc[0][3]}: the first enc record must be 0 0 "
                    f"(cumulative counts since the start of the log)")
    return log, errs


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


def carmen_intervals(lines):
    """[(P_k, [raw ODOM poses after the anchor, up to the one before FLASER k+1])]."""
    scans = []
    cur = None
    skip_anchor = False
    for ln in lines:
        f = ln.split()
        if not f:
            continue
        if f[0] == "FLASER":
            n = int(f[1])
            scans.append(((float(f[n + 2]), float(f[n + 3]), float(f[n + 4])), []))
            cur = scans[-1][1]
            skip_anchor = True
        elif f[0] == "ODOM" and cur is not None:
            if skip_anchor:
                skip_anchor = False
                continue
            cur.append((float(f[1]), float(f[2]), float(f[3])))
    return scans


def check_carmen(log, path, src, path_tol):
    errs, info = [], []
    if not expect_params(log, {"wheel_radius_m": 0.0825, "ticks_per_rev": 4096, "wheelbase_m": 0.33},
                         path, errs):
        return errs, info
    scans = carmen_intervals(read_lines(src))
    m = len(log.truth)
    if m == 0 or m > len(scans):
        errs.append(f"{path}: {m} truth records, the log has {len(scans)} scans")
        return errs, info
    for k in range(m):
        q, p = log.truth[k], scans[k][0]
        if max(abs(q[1] - p[0]), abs(q[2] - p[1]), abs(wrap(q[3] - p[2]))) > 2e-6:
            errs.append(f"{path}:{q[4]}: truth {k} is not FLASER pose {k} {p}")
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
    gaps = []
    for k in range(m - 1):
        p0, subs = scans[k]
        pts = [p0] + subs
        for a, b in zip(pts, pts[1:]):
            raw_path += math.hypot(b[0] - a[0], b[1] - a[1])
            raw_rot += abs(wrap(b[2] - a[2]))
        x, y, th = log.truth[k][1:4]
        g = groups[k]
        for a, b in zip(g, g[1:]):
            dr, dl = (b[1] - a[1]) * tick, (b[2] - a[2]) * tick
            rho, dth = (dr + dl) / 2, (dr - dl) / d
            x += rho * math.cos(th + dth / 2)
            y += rho * math.sin(th + dth / 2)
            th += dth
            enc_path += abs(rho)
            enc_rot += abs(dth)
        if len(g) - 1 != len(subs):
            errs.append(f"{path}: interval {k}: {len(g) - 1} enc steps for {len(subs)} ODOM sub-steps")
            return errs, info
        o = subs[-1]
        gp, gt = math.hypot(x - o[0], y - o[1]), abs(wrap(th - o[2]))
        gaps.append(gp)
        if gp > worst_pos:
            worst_pos, worst_k = gp, k
        worst_th = max(worst_th, gt)
    gaps.sort()
    med = gaps[len(gaps) // 2] if gaps else 0.0
    info.append(f"scans {m}, intervals checked {m - 1}")
    info.append(f"path: ticks {enc_path:.3f} m, raw odometry {raw_path:.3f} m "
                f"({(enc_path / raw_path - 1) * 100 if raw_path else 0:+.3f} %)")
    info.append(f"abs rotation: ticks {enc_rot:.3f} rad, raw odometry {raw_rot:.3f} rad "
                f"({(enc_rot / raw_rot - 1) * 100 if raw_rot else 0:+.3f} %)")
    info.append(f"per-interval end gap to raw odometry: median {med * 1000:.2f} mm, "
                f"max {worst_pos * 1000:.2f} mm (interval {worst_k}), max heading {worst_th:.5f} rad")
    if raw_path > 0 and abs(enc_path / raw_path - 1) > path_tol:
        errs.append(f"{path}: dead-reckoned path {enc_path:.3f} m vs raw odometry {raw_path:.3f} m")
    if raw_rot > 0 and abs(enc_rot / raw_rot - 1) > path_tol:
        errs.append(f"{path}: dead-reckoned rotation {enc_rot:.3f} rad vs raw odometry {raw_rot:.3f} rad")
    if worst_pos > 0.02 or worst_th > 0.01:
        errs.append(f"{path}: dead-reckoned interval ends miss the raw odometry by up to "
                    f"{worst_pos * 1000:.1f} mm / {worst_th:.4f} rad")
    return errs, info


def main(argv=None):
    ap = argparse.ArgumentParser(prog="odolog_check.py", description="Check an odolog v1 file.")
    ap.add_argument("file", metavar="FILE")
    ap.add_argument("--any-enc-start", action="store_true",
                    help="do not require the first enc record to be 0 0")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--optiodom-csv", metavar="RUN_CSV")
    g.add_argument("--carmen-log", metavar="LOG")
    ap.add_argument("--path-tol", type=float, default=0.05)
    ap.add_argument("--rot-tol", type=float, default=0.05)
    ap.add_argument("-q", "--quiet", action="store_true", help="print failures only")
    a = ap.parse_args(argv)
    try:
        log, errs = check_format(a.file, a.any_enc_start)
        info = []
        if not errs and a.optiodom_csv:
            e2, info = check_optiodom(log, a.file, a.optiodom_csv, a.path_tol, a.rot_tol)
            errs += e2
        elif not errs and a.carmen_log:
            e2, info = check_carmen(log, a.file, a.carmen_log, a.path_tol)
            errs += e2
    except Fail as e:
        print(f"FAIL {e}")
        return 2
    except (OSError, ValueError, IndexError, UnicodeDecodeError, EOFError) as e:
        print(f"FAIL {a.file}: cannot read the source for the physical check: {e}")
        return 2
    for e in errs:
        print(f"FAIL {e}")
    if not errs and not a.quiet:
        t = [r[0] for r in log.enc + log.truth + log.pose]
        span = f"{min(t):.3f}..{max(t):.3f} s" if t else "no data"
        print(f"ok {a.file}: drive {log.drive}, {len(log.enc)} enc, {len(log.truth)} truth, "
              f"{len(log.pose)} pose, {log.scans} scan, {log.walls} wall, {len(log.meta)} meta, "
              f"{log.unknown} unknown; {span}")
        for line in info:
            print(f"   {line}")
    return 1 if errs else 0


if __name__ == "__main__":
    sys.exit(main())

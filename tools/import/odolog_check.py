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
  counts signed 64-bit integers; init / pose sigmas > 0; init / pose / truth X and Y
  less than 2^46 m in size;
- data records in non-decreasing time;
- enc counts cumulative: the first enc record is `0 0` (counts since the start of the
  log; --any-enc-start relaxes this for logs that start mid-count);
- unknown record types must be lower-case words; they are counted, not refused.

Physical checks (tools/import/odolog_check_sources.py, where they are described):
- --optiodom-csv RUN: an OptiOdom import against its run CSV;
- --carmen-log LOG: a CARMEN import against its log (the ticks at every ODOM line, the
  scans against the FLASER ranges).

Exit status: 0 all checks pass, 1 a check fails (each failure printed as FILE:LINE: rule
or FILE: what), 2 bad usage or unreadable input.
"""

import argparse
import math
import re
import sys

from odolog_check_sources import check_carmen, check_optiodom

HEADER = {"drive", "param", "laser", "wall", "init", "meta"}
DATA = {"enc", "scan", "pose", "truth"}
REQUIRED = {"diff": ("wheel_radius_m", "ticks_per_rev", "wheelbase_m"),
            "sync": ("ticks_per_m", "ticks_per_rad")}
NUM = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")
INT = re.compile(r"^[+-]?\d+$")
WORD = re.compile(r"^[a-z0-9_]+$")


# Rule R34 of docs/odolog.md: a pose's X and Y are less than 2^46 m in size.
REACH_M = 2.0 ** 46


def within_reach(xy):
    return all(abs(c) < REACH_M for c in xy)


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
        self.scan_ranges = None   # [(t, [tokens])] when asked for (--carmen-log)
        self.laser = None         # the laser record's 8 fields, as numbers
        self.unknown = 0
        self.order = []   # ('enc'|'truth'|..., index) in file order

    def meta_int(self, key):
        """The integer that the first `meta KEY` record with one starts with, else None."""
        for k, v in self.meta:
            if k != key:
                continue
            first = v.split()[:1]
            if first and INT.match(first[0]):
                return int(first[0])
        return None


def check_format(path, any_enc_start, keep_scans=False):
    """Parses and validates; returns (Log, [errors])."""
    errs = []
    log = Log()
    if keep_scans:
        log.scan_ranges = []
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
                    log.laser = [number(a) for a in args]
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
                elif not within_reach(v[0:2]):
                    err(no, "init X or Y beyond 2^46 m")
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
                    if keep_scans:
                        log.scan_ranges.append((t, args[1:]))
            elif typ == "pose":
                v = [number(a) for a in args]
                if len(args) != 7:
                    err(no, f"pose takes 7 fields, got {len(args)}")
                elif None in v:
                    err(no, "pose field not a finite number")
                elif not all(s > 0 for s in v[4:]):
                    err(no, "pose sigmas must be positive")
                elif not within_reach(v[1:3]):
                    err(no, "pose X or Y beyond 2^46 m")
                else:
                    log.order.append(("pose", len(log.pose)))
                    log.pose.append(tuple(v) + (no,))
            else:
                v = [number(a) for a in args]
                if len(args) != 4:
                    err(no, f"truth takes 4 fields, got {len(args)}")
                elif None in v:
                    err(no, "truth field not a finite number")
                elif not within_reach(v[1:3]):
                    err(no, "truth X or Y beyond 2^46 m")
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
        log, errs = check_format(a.file, a.any_enc_start, keep_scans=bool(a.carmen_log))
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

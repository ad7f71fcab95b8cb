#!/usr/bin/env python3
"""test_carmen_variants.py: tools/import/carmen_to_odolog.py on small synthetic CARMEN logs,
one for each way real loggers differ (docs/real-data.md, "CARMEN logs: what the importer
reads"), and on damaged copies.

Usage: test_carmen_variants.py [ODOERR] [--work DIR]

The logs are written here, from a made-up drive (a robot whose raw odometry over-reads
distance by 3 % and under-reads turns by 3 %, its "corrected" poses the true ones), in the
corrected layout of the five buildings: raw ODOM lines, the FLASER with the corrected pose,
the anchor ODOM repeating it (time stamp 0), NEFF. No line of the real logs is used.

- beam counts 180, 181, 360, 361 (the beam-count rule), 270 (refused with --scans, read
  without), PARAM laser_front_laser_fov / _resolution (degrees, radians, overriding the
  rule, not fitting the beam count, a flipped laser);
- PARAM robot_frontlaser_offset / _side_offset / _angular_offset and robot_front_laser_max
  in the laser record, readings at or above the limit written nan; a no-return code no
  PARAM states (the pile-up note, --no-return);
- ODOM after its FLASER: the same records as before it;
- time stamps of 0 with a logger stamp (the same records), with none (refused naming the
  line; --time order reads it), stamps of 6 significant digits (refused; --time order);
- headings not wrapped (continuous, 3 turns up): the same ticks;
- other message types (RAWLASER1, ROBOTLASER1, TRUEPOS, SYNC, GPSNMEA, ...): counted in
  meta, the same records;
- a scan with no raw odometry (refused; --missing-odometry flaser fills and declares it);
  sparse odometry (one ODOM line a scan: arc + turn records);
- damaged lines, each refused with exit 2, FILE:LINE of the damage and no output: too few
  fields, a non-number, a truncated last line (inside the fields and inside the type), a
  type that is not an upper-case word, a PARAM the importer reads that is not a number
  or changes, a raw (uncorrected) FLASER, two FLASERs with nothing between, an anchor
  after raw odometry.
Every output is checked by tools/import/odolog_check.py --carmen-log (which shares no code
with the importer), and, when ODOERR is given, some are replayed by `odoerr replay`.
Exit status 0 when everything holds, 1 otherwise (each failure printed).
"""
import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
IMPORTER = os.path.join(ROOT, "tools", "import", "carmen_to_odolog.py")
CHECKER = os.path.join(ROOT, "tools", "import", "odolog_check.py")
PY = sys.executable or "python3"
TAU = 2 * math.pi

# the made-up drive: (steps, travel per step m, rotation per step rad)
SEGMENTS = [(10, 0.05, 0.0), (10, 0.05, 0.12), (10, 0.0, 0.25), (10, 0.06, 0.0), (8, 0.0, -0.2), (12, 0.05, 0.02)]
SCAN_EVERY = 5
START = (1.0, 2.0, 0.3)


def wrap(a):
    return (a + math.pi) % TAU - math.pi


def advance(p, rho, dth):
    x, y, th = p
    return (x + rho * math.cos(th + dth / 2), y + rho * math.sin(th + dth / 2), th + dth)


def rel(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    wx, wy = b[0] - a[0], b[1] - a[1]
    return (c * wx + s * wy, -s * wx + c * wy, b[2] - a[2])


def compose(a, d):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * d[0] - s * d[1], a[1] + s * d[0] + c * d[1], a[2] + d[2])


def drive():
    """(true poses, raw odometry poses), one per odometry step."""
    true, raw = [START], [(0.0, 0.0, 0.0)]
    for n, rho, dth in SEGMENTS:
        for _ in range(n):
            true.append(advance(true[-1], rho, dth))
            raw.append(advance(raw[-1], rho * 1.03, dth * 0.97))
    return true, raw


def make_log(beams=180, params=(), order="before", zero_ipc=(), zero_both=None, stamp=None,
             unwrap=False, others=False, missing=(), sparse=False, ranges=None, raw_flaser=False,
             late_older=False):
    """The text of a synthetic corrected CARMEN log and {what: line number}."""
    true, raw = drive()
    scans = list(range(2, len(true), SCAN_EVERY))
    out, where = [], {}
    add = out.append

    def head(th):
        return th + 3 * TAU if unwrap else wrap(th)

    def ts(j):
        t = 100.0 + 0.1 * j
        return stamp(t) if stamp else f"{t:.6f}"

    def odom(p, j, kind):
        ipc = "0" if kind in zero_ipc else ts(j)
        lts = ts(j)
        if zero_both == (kind, j):
            ipc = lts = "0"
        add(f"ODOM {p[0]:.9f} {p[1]:.9f} {head(p[2]):.9f} 0 0 0 {ipc} nohost {lts}")
        where.setdefault(kind, len(out))
        where[f"{kind}@{j}"] = len(out)

    def flaser(k, j):
        p = true[j]
        rs = ranges(k) if ranges else [("81.83" if i % 23 == 5 else f"{1.5 + (i % 17) * 0.1 + 0.01 * k:.2f}")
                                       for i in range(beams)]
        q = (p[0] + 0.05, p[1], p[2]) if raw_flaser else p
        ipc = "0" if "flaser" in zero_ipc else ts(j)
        if zero_both == ("flaser", j):
            ipc = "0"
        pose = f"{p[0]:.9f} {p[1]:.9f} {head(p[2]):.9f} {q[0]:.9f} {q[1]:.9f} {head(q[2]):.9f}"
        add(f"FLASER {beams} {' '.join(rs)} {pose} {ipc} nohost "
            f"{'0' if zero_both == ('flaser', j) else ts(j)}")
        where.setdefault("flaser", len(out))
        where[f"flaser{k}"] = len(out)

    add("# CARMEN Logfile (synthetic, written by tests/import/test_carmen_variants.py)")
    add("# message formats defined: PARAM SYNC ODOM FLASER RLASER TRUEPOS")
    for name, value in params:
        add(f"PARAM {name} {value} nohost 0")
        where.setdefault(f"param {name}", len(out))
    if others:
        add("SYNC 1 nohost 100.0")
    prev = None
    pair = []
    for k, s in enumerate(scans):
        lo = 0 if prev is None else prev + 1
        for j in range(lo, s + 1):
            if prev is None:
                p = raw[j]                                       # the raw frame, before the first scan
            elif k in missing or (sparse and j != s):
                continue
            else:
                p = compose(true[prev], rel(raw[prev], raw[j]))  # anchored at the previous scan
            if order == "after" and k not in missing and (j == s or (late_older and j == s - 1)):
                pair.append((p, j))       # written after the FLASER
                continue
            odom(p, j, "odom")
            if others and j % 7 == 3:
                add(f"TRUEPOS {true[j][0]:.6f} {true[j][1]:.6f} {true[j][2]:.6f} {p[0]:.6f} {p[1]:.6f} "
                    f"{p[2]:.6f} {ts(j)} nohost {ts(j)}")
        flaser(k, s)
        for p, j in pair:
            odom(p, j, "odom")
        pair = []
        odom(true[s], s, "anchor")
        out[-1] = re.sub(r" \S+ nohost \S+$", " 0 nohost 0", out[-1])   # the anchor's stamps are 0
        add(f"NEFF {30 - k * 0.5:g}")
        if others and k % 3 == 1:
            add(f"RAWLASER1 0 -1.5708 3.14159 0.0174533 81.9 0.01 0 3 1 2 3 0 {ts(s)} nohost {ts(s)}")
            add(f"ROBOTLASER1 0 -1.5708 3.14159 0.0174533 81.9 0.01 0 2 1 2 0 0 0 0 0 0 0 0 0 0 0 0 "
                f"{ts(s)} nohost {ts(s)}")
            add(f"GPSNMEA $GPGGA,1,2,3 {ts(s)} nohost {ts(s)}")
        prev = s
    for j in range(prev + 1, len(true)):
        odom(compose(true[prev], rel(raw[prev], raw[j])), j, "odom")
    return "\n".join(out) + "\n", where


class Run:
    def __init__(self, work, odoerr):
        self.work = work
        self.odoerr = odoerr
        self.fails = 0
        self.n = 0

    def ok(self, what):
        self.n += 1
        print(f"ok   {what}")

    def fail(self, what):
        self.n += 1
        self.fails += 1
        print(f"FAIL {what}")

    def write(self, name, text):
        p = os.path.join(self.work, name)
        with open(p, "wb") as f:  # bytes as given: a test may write a line that is not text
            f.write(text if isinstance(text, bytes) else text.encode("ascii"))
        return p

    def imp(self, name, text, *opts):
        """(exit status, stderr, output path, output text or None)."""
        src = self.write(name + ".log", text)
        out = os.path.join(self.work, name + ".odolog")
        if os.path.exists(out):
            os.unlink(out)
        r = subprocess.run([PY, IMPORTER, src, "--out", out, *opts], capture_output=True, text=True)
        body = open(out).read() if os.path.exists(out) else None
        return r.returncode, r.stderr, src, out, body

    def good(self, what, name, text, *opts, check=True):
        """Imports, expects success and a passing odolog_check --carmen-log; returns the text."""
        rc, err, src, out, body = self.imp(name, text, *opts)
        if rc != 0 or body is None:
            self.fail(f"{what}: exit {rc}: {err.strip()}")
            return None
        if check:
            r = subprocess.run([PY, CHECKER, out, "--carmen-log", src], capture_output=True, text=True)
            if r.returncode != 0:
                self.fail(f"{what}: odolog_check --carmen-log: {r.stdout.strip()}")
                return None
        return body

    def refused(self, what, name, text, line, needle, *opts):
        """Imports, expects exit 2 naming FILE:LINE with needle in the message, and no output."""
        rc, err, src, out, body = self.imp(name, text, *opts)
        if rc != 2:
            self.fail(f"{what}: exit {rc}, expected 2: {err.strip()}")
        elif f"{src}:{line}:" not in err:
            self.fail(f"{what}: the message does not name {os.path.basename(src)}:{line}: {err.strip()}")
        elif needle not in err:
            self.fail(f"{what}: the message lacks '{needle}': {err.strip()}")
        elif body is not None:
            self.fail(f"{what}: an output file was left behind")
        else:
            self.ok(f"{what}: {err.strip().split(': ', 2)[-1][:150]}")


def records(text, kinds=("enc", "truth", "scan", "pose", "laser", "init")):
    return [ln for ln in text.splitlines() if ln.split()[:1] and ln.split()[0] in kinds]


def meta(text, key):
    for ln in text.splitlines():
        f = ln.split(None, 2)
        if f[:2] == ["meta", key]:
            return f[2] if len(f) > 2 else ""
    return None


def laser(text):
    for ln in text.splitlines():
        if ln.startswith("laser "):
            return [float(v) for v in ln.split()[1:]]
    return None


def near(a, b, tol=1e-8):
    return abs(a - b) <= tol


def test_beam_counts(t):
    for n, step in ((180, 1.0), (181, 1.0), (360, 0.5), (361, 0.5)):
        text, _ = make_log(beams=n)
        body = t.good(f"{n} beams", f"beams{n}", text, "--scans")
        if body is None:
            continue
        las = laser(body)
        if las[0] == n and near(las[1], -math.pi / 2, 1e-9) and near(las[2], math.radians(step), 1e-9) \
                and "beam-count rule" in meta(body, "laser_beams"):
            t.ok(f"{n} beams: first beam -90 deg, {step:g} deg apart, from the beam-count rule")
        else:
            t.fail(f"{n} beams: laser record {las}, meta {meta(body, 'laser_beams')}")
    text, w = make_log(beams=270)
    t.refused("270 beams without PARAM, --scans", "beams270", text, w["flaser"], "no beam-count rule", "--scans")
    if t.good("270 beams without --scans", "beams270-noscan", text) is not None:
        t.ok("270 beams without --scans: imported (no laser record needed)")


def test_param_geometry(t):
    cases = [
        ("fov 135 deg, resolution 0.5, 271 beams", 271,
         [("laser_front_laser_fov", "135"), ("laser_front_laser_resolution", "0.5")], -67.5, 0.5, "degrees"),
        ("fov 3.14159 (radians), resolution 0.5, 361 beams", 361,
         [("laser_front_laser_fov", "3.14159"), ("laser_front_laser_resolution", "0.5")],
         -math.degrees(3.14159) / 2, 0.5, "radians"),
        ("fov 180 deg, resolution 1, 180 beams (the last beam dropped)", 180,
         [("laser_front_laser_fov", "180"), ("laser_front_laser_resolution", "1.0")], -90.0, 1.0, "not in the log"),
        ("resolution 0.5 overrides the rule for 181 beams", 181,
         [("laser_front_laser_resolution", "0.5")], -90.0, 0.5, "PARAM overrides"),
        ("fov 90 deg, no resolution, 181 beams", 181, [("laser_front_laser_fov", "90")], -45.0, 0.5, "overrides"),
    ]
    for what, n, params, start, step, word in cases:
        text, _ = make_log(beams=n, params=params)
        body = t.good(what, "geom", text, "--scans")
        if body is None:
            continue
        las, m = laser(body), meta(body, "laser_beams")
        if near(las[1], math.radians(start), 1e-8) and near(las[2], math.radians(step), 1e-8) and word in m:
            t.ok(f"PARAM {what}: first beam {start:g} deg, {step:g} deg apart; meta: ...{word}...")
        else:
            t.fail(f"PARAM {what}: laser {las[:3]}, meta {m}")
    text, w = make_log(beams=181, params=[("laser_front_laser_fov", "90"), ("laser_front_laser_resolution", "1")])
    t.refused("PARAM fov 90 with 181 beams 1 deg apart", "geom-bad", text, w["param laser_front_laser_fov"],
              "does not fit 181 beams", "--scans")
    text, w = make_log(beams=181, params=[("laser_front_laser_flipped", "1")])
    t.refused("PARAM laser_front_laser_flipped 1", "flipped", text, w["param laser_front_laser_flipped"],
              "flipped", "--scans")


def test_offset_and_range(t):
    params = [("robot_frontlaser_offset", "0.12"), ("robot_frontlaser_side_offset", "0.01"),
              ("robot_frontlaser_angular_offset", "0.02"), ("robot_front_laser_max", "40")]

    def rs(k):
        return ["45.0" if i == 3 else "39.99" if i == 4 else "81.83" if i == 5 else "2.00" for i in range(180)]
    text, _ = make_log(params=params, ranges=rs)
    body = t.good("PARAM offsets and max range", "offset", text, "--scans")
    if body is not None:
        las = laser(body)
        scan = [ln.split()[1:] for ln in body.splitlines() if ln.startswith("scan ")][0]
        if las[3:4] + las[5:] == [40.0, 0.12, 0.01, 0.02] and scan[4:7] == ["nan", "39.99", "nan"] and \
                "PARAM robot_frontlaser_offset 0.12" in meta(body, "laser_mount"):
            t.ok("PARAM offsets -> mount 0.12 0.01 0.02, robot_front_laser_max 40 -> RANGE_MAX 40, 45 m nan")
        else:
            t.fail(f"PARAM offsets and max range: laser {las}, scan {scan[:8]}")
        body2 = t.good("--range-max over PARAM", "offset2", text, "--scans", "--range-max", "20")
        if body2 is not None and laser(body2)[3] == 20.0 and "--range-max" in meta(body2, "laser_range"):
            t.ok("--range-max 20 wins over PARAM robot_front_laser_max, and says so")
        elif body2 is not None:
            t.fail(f"--range-max: {meta(body2, 'laser_range')}")

    def code(k):
        return ["50" if i % 9 == 0 else f"{3 + 0.01 * i + 0.001 * k:.3f}" for i in range(180)]
    text, _ = make_log(ranges=code)
    rc, err, src, out, body = t.imp("nocode", text, "--scans")
    if rc == 0 and meta(body, "laser_no_return_suspect") and "--no-return 50" in err:
        t.ok("a repeated top reading no PARAM states: meta laser_no_return_suspect and a note naming --no-return 50")
    else:
        t.fail(f"no-return code: exit {rc}, {err.strip()}, meta {body and meta(body, 'laser_no_return_suspect')}")
    body = t.good("--no-return 50", "nocode2", text, "--scans", "--no-return", "50")
    if body is not None and meta(body, "laser_no_return_suspect") is None and \
            sum(ln.count(" nan") for ln in body.splitlines() if ln.startswith("scan ")) == 20 * 12:
        t.ok("--no-return 50: the 50 m readings written nan, no note")
    elif body is not None:
        t.fail("--no-return 50: not all 50 m readings are nan")


def test_order_and_stamps(t):
    base, _ = make_log()
    ref = t.good("the standard layout", "std", base, "--scans")
    if ref is None:
        return
    again = t.good("the standard layout, twice", "std", base, "--scans")
    if again == ref:
        t.ok("reproducible: byte-identical twice")
    else:
        t.fail("two imports of the same log differ")
    text, _ = make_log(order="after")
    body = t.good("ODOM after FLASER", "after", text, "--scans")
    if body is not None and records(body) == records(ref):
        t.ok("ODOM after its FLASER: the same records as before it")
    elif body is not None:
        t.fail("ODOM after its FLASER: the records differ")
    text, _ = make_log(order="after", late_older=True)
    body = t.good("ODOM after FLASER, an older one first", "after2", text, "--scans")
    if body is not None and records(body) == records(ref):
        t.ok("two ODOM lines after their FLASER (the older first, then its own stamp): the same records")
    elif body is not None:
        t.fail("two ODOM lines after their FLASER: the records differ")
    text, _ = make_log(zero_ipc=("odom", "flaser"))
    body = t.good("ipc stamps 0, logger stamps set", "zero-ipc", text, "--scans")
    if body is not None and records(body) == records(ref) and \
            re.search(r"\b(\d+) of \1 lines used took the logger's", meta(body, "time_stamps")):
        t.ok(f"ipc stamps 0: the logger's taken, the same records ({meta(body, 'time_stamps').split(': ')[-1]})")
    elif body is not None:
        t.fail(f"ipc stamps 0: records differ or meta wrong: {meta(body, 'time_stamps')}")
    text, w = make_log(zero_both=("odom", 20))
    t.refused("an ODOM line with both stamps 0", "zero-both", text, w["odom@20"], "no usable time stamp")
    body = t.good("both stamps 0, --time order", "zero-both-order", text, "--time", "order")
    if body is not None and "--time order" in meta(body, "time"):
        t.ok("both stamps 0 with --time order: imported on a synthetic clock, said in meta time")
    text, w = make_log(zero_both=("flaser", 2))
    t.refused("the first FLASER with both stamps 0", "zero-flaser", text, w["flaser0"], "is 0")
    text, w = make_log(stamp=lambda t: f"{1134860000 + t:g}")
    t.refused("stamps of 6 significant digits", "coarse", text, w["flaser0"], "a step of 10000 s")
    body = t.good("coarse stamps, --time order", "coarse-order", text, "--time", "order", "--scans")
    if body is not None:
        ts = [float(ln.split()[1]) for ln in body.splitlines() if ln.startswith("enc ")]
        if ts[0] == 0.0 and all(b > a for a, b in zip(ts, ts[1:])) and \
                records(body, ("truth",))[-1].split()[2:] == records(ref, ("truth",))[-1].split()[2:]:
            t.ok(f"coarse stamps with --time order: {len(ts)} enc records 0 to {ts[-1]:g} s, the same poses")
        else:
            t.fail("coarse stamps with --time order: the clock or the poses are wrong")
    text, w = make_log(order="after", zero_both=("flaser", 27))
    t.refused("ODOM after FLASER with no usable stamp", "after-zero", text, w["flaser5"], "no usable time stamp")
    text, w = make_log(order="after", stamp=lambda t: f"{1134860000 + t:g}")
    t.refused("ODOM after FLASER, --time order (paired by order, so the anchor follows raw odometry)",
              "after-order", text, w["anchor"], "an anchor must follow",
              "--time", "order")


def test_headings(t):
    base, _ = make_log()
    ref = t.good("wrapped headings", "wrapped", base)
    text, _ = make_log(unwrap=True)
    body = t.good("headings not wrapped", "unwrapped", text)
    if ref is None or body is None:
        return
    hi = max(float(ln.split()[3]) for ln in text.splitlines() if ln.startswith("ODOM "))
    same_enc = records(body, ("enc",)) == records(ref, ("enc",))
    tr_a = [ln.split() for ln in records(ref, ("truth",))]
    tr_b = [ln.split() for ln in records(body, ("truth",))]
    turns = {round((float(b[4]) - float(a[4])) / TAU, 6) for a, b in zip(tr_a, tr_b)}
    if same_enc and all(x == int(x) and x >= 3 for x in turns) and hi > 3 * TAU + math.pi:
        t.ok(f"headings up to {hi:.2f} rad, not wrapped: the same enc records; truth whole turns "
             f"({', '.join(f'{x:g}' for x in sorted(turns))}) up, as written")
    else:
        t.fail(f"unwrapped headings: enc identical {same_enc}, truth offsets {sorted(turns)[:4]}")


def test_other_messages(t):
    base, _ = make_log()
    ref = t.good("without other messages", "plain", base)
    text, _ = make_log(others=True)
    body = t.good("other message types", "others", text)
    if ref is None or body is None:
        return
    m = meta(body, "carmen_messages")
    counts = {k: text.count(f"\n{k} ") for k in ("SYNC", "TRUEPOS", "RAWLASER1", "ROBOTLASER1", "GPSNMEA", "NEFF")}
    listed = all(f"{k} {v}" in m for k, v in counts.items()) and \
        all(k in m.split("skipped (counted only):")[1] for k in counts)
    if records(body) == records(ref) and listed and "SYNC ODOM FLASER RLASER TRUEPOS" in \
            meta(body, "carmen_formats_declared"):
        t.ok(f"other message types counted, not read: {m}")
    else:
        t.fail(f"other message types: records same {records(body) == records(ref)}, meta: {m}")


def test_missing_and_sparse(t):
    text, w = make_log(missing=(3, 7))
    t.refused("a scan with no raw odometry", "missing", text, w["flaser3"], "--missing-odometry flaser")
    body = t.good("--missing-odometry flaser", "missing-fill", text, "--missing-odometry", "flaser")
    if body is not None and meta(body, "odometry_gaps").startswith("2 intervals"):
        t.ok("--missing-odometry flaser: 2 intervals filled from the FLASER odom fields, declared; checked")
    elif body is not None:
        t.fail(f"--missing-odometry flaser: meta {meta(body, 'odometry_gaps')}")
    text, _ = make_log(sparse=True)
    body = t.good("sparse odometry (one ODOM line a scan)", "sparse", text)
    if body is not None:
        n = int(meta(body, "odometry_split").split()[0])
        if n > 0:
            t.ok(f"sparse odometry: {n} sub-steps written as arc + turn in place; the ticks reach every ODOM line")
        else:
            t.fail("sparse odometry: no sub-step split")


def test_auto(t):
    """--auto: each refusal that names an option, and the no-return pile-up, become a choice
    said on stderr, in a meta line and in --choices; a given option is never overridden, and
    a log that needs no choice imports byte-identically."""
    def same(text):  # the records and meta lines, without the source's name and the choices
        return [ln for ln in text.splitlines() if not ln.startswith(("#", "meta source", "meta choice_"))]
    base, _ = make_log()
    plain = t.good("the standard layout", "auto-std-plain", base, "--scans")
    choices = os.path.join(t.work, "auto-std.json")
    body = t.good("--auto on the standard layout", "auto-std", base, "--scans", "--auto", "--choices", choices)
    if plain is not None and body is not None and same(body) == same(plain):
        c = json.load(open(choices))
        if not any(v["chosen"] for v in c.values()) and "not taken as a code" in c["no_return"]["reason"]:
            t.ok("--auto on a log that needs no choice: the plain import's records; the ranges' top pile-up "
                 "(a far wall seen often) is not taken as a no-return code, and the reason says why")
        else:
            t.fail(f"--auto on the standard layout: choices {c}")
    elif plain is not None:
        t.fail("--auto changed a log that needs no choice")
    cases = [
        ("coarse stamps", make_log(stamp=lambda t: f"{1134860000 + t:g}")[0], "time", "order",
         ("--time", "order")),
        ("scans without raw odometry", make_log(missing=(3, 7))[0], "missing_odometry", "flaser",
         ("--missing-odometry", "flaser")),
        ("a no-return code no PARAM states",
         make_log(ranges=lambda k: ["50" if i % 9 == 0 else f"{3 + 0.01 * i + 0.001 * k:.3f}"
                                    for i in range(180)])[0], "no_return", 50.0, ("--no-return", "50")),
    ]
    for what, text, key, value, hand in cases:
        name = "auto-" + key
        choices = os.path.join(t.work, name + ".json")
        body = t.good(f"--auto, {what}", name, text, "--scans", "--auto", "--choices", choices)
        handmade = t.good(f"{' '.join(hand)}, {what}", name + "-hand", text, "--scans", *hand)
        if body is None or handmade is None:
            continue
        c = json.load(open(choices))
        line = meta(body, "choice_" + key)
        rest, hand_rest = same(body), same(handmade)
        if c[key]["chosen"] and c[key]["value"] == value and c[key]["reason"] and line and rest == hand_rest \
                and not any(c[k]["chosen"] for k in c if k != key):
            t.ok(f"--auto, {what}: chose {hand[0]} {value} ({c[key]['reason'][:70]}...), the same records as {' '.join(hand)}")
        else:
            t.fail(f"--auto, {what}: choices {c}, meta {line}, same as by hand {rest == hand_rest}")
    text, w = make_log(stamp=lambda t: f"{1134860000 + t:g}")
    t.refused("--auto does not override a given --time stamps", "auto-given", text, w["flaser0"],
              "a step of 10000 s", "--auto", "--time", "stamps")


def test_damage(t):
    base, w = make_log()
    lines = base.split("\n")
    raw = [ln.encode("ascii") for ln in lines]
    raw[4] += b" \xe9"
    t.refused("a byte that is not ASCII (Latin-1 e acute)", "not-ascii", b"\n".join(raw), 5,
              "the line is not ASCII text")

    def damaged(no, new):
        c = list(lines)
        c[no - 1] = new
        return "\n".join(c)
    o = w["odom@20"]
    t.refused("too few fields (ODOM)", "few", damaged(o, lines[o - 1].rsplit(" ", 1)[0]), o, "takes 9 fields")
    f = w["flaser4"]
    bad = lines[f - 1].split()
    bad[10] = "abc"
    t.refused("a non-number (FLASER range)", "nan", damaged(f, " ".join(bad)), f, "'abc' is not a decimal number")
    bad = lines[o - 1].split()
    bad[2] = "1.2.3"
    t.refused("a non-number (ODOM y)", "nan2", damaged(o, " ".join(bad)), o, "ODOM y")
    last = max(v for k, v in w.items() if k.startswith("flaser"))
    cut = "\n".join(lines[:last - 1] + [lines[last - 1][:len(lines[last - 1]) // 2]])
    t.refused("a truncated last line (FLASER)", "trunc", cut, last, "truncated")
    cut = "\n".join(lines[:last - 1] + ["FLA"])
    t.refused("a truncated last line (inside the type)", "trunc2", cut, last, "truncated")
    t.refused("a type that is not an upper-case word", "lower", damaged(o, lines[o - 1].lower()), o,
              "not a CARMEN message type")
    text, w2 = make_log(params=[("robot_frontlaser_offset", "abc")])
    t.refused("PARAM robot_frontlaser_offset abc", "param", text, w2["param robot_frontlaser_offset"],
              "not a decimal number")
    text, w2 = make_log(params=[("robot_front_laser_max", "40"), ("robot_front_laser_max", "50")])
    t.refused("PARAM robot_front_laser_max changing", "param2", text, w2["param robot_front_laser_max"] + 1,
              "changes from 40")
    text, w2 = make_log(raw_flaser=True)
    t.refused("a raw FLASER (odom fields differ)", "raw", text, w2["flaser0"], "raw (uncorrected) log")
    f4, f5 = w["flaser4"], w["flaser5"]
    c = lines[:f4] + [ln for ln in lines[f4:f5 - 1] if not ln.startswith("ODOM")] + lines[f5 - 1:]
    t.refused("two FLASERs with no ODOM between", "twoflaser", "\n".join(c), c.index(lines[f5 - 1]) + 1,
              "two FLASER lines")
    c = list(lines)
    anchor = c.pop(f4)          # the anchor of FLASER 4 after the next two raw ODOM lines
    raws = [i for i, ln in enumerate(c) if i > f4 and ln.startswith("ODOM")]
    c.insert(raws[1] + 1, anchor)
    t.refused("a FLASER whose anchor comes after raw odometry", "lateanchor", "\n".join(c), raws[0] + 1,
              "has no anchor")


def test_replay(t):
    if not t.odoerr:
        print("--   no odoerr binary given: the replays are skipped")
        return
    for name in ("std", "missing-fill", "coarse-order"):
        p = os.path.join(t.work, name + ".odolog")
        if not os.path.exists(p):
            t.fail(f"replay {name}: no output to replay")
            continue
        r = subprocess.run([t.odoerr, "replay", p, "--out", os.path.join(t.work, "replay-" + name)],
                           capture_output=True, text=True)
        if r.returncode == 0:
            t.ok(f"odoerr replay {name}.odolog")
        else:
            t.fail(f"odoerr replay {name}.odolog: exit {r.returncode}: {r.stderr.strip()}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("odoerr", nargs="?", help="the odoerr binary, for the replays (optional)")
    ap.add_argument("--work", help="working folder (default: a temporary one, removed)")
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix="carmen-variants-")
    if a.work:
        shutil.rmtree(work, ignore_errors=True)
        os.makedirs(work)
    t = Run(work, a.odoerr if a.odoerr and os.path.exists(a.odoerr) else None)
    try:
        for test in (test_beam_counts, test_param_geometry, test_offset_and_range, test_order_and_stamps,
                     test_headings, test_other_messages, test_missing_and_sparse, test_auto, test_damage, test_replay):
            test(t)
    finally:
        if not a.work:
            shutil.rmtree(work, ignore_errors=True)
    print(f"\n{t.n - t.fails} of {t.n} checks passed")
    return 1 if t.fails else 0


if __name__ == "__main__":
    sys.exit(main())

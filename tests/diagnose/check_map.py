#!/usr/bin/env python3
"""Map misfit of `odoerr diagnose` on drives whose map is not the building.

  check_map.py ODOERR OUTDIR [--seeds 21,22] [--clean-seeds 21,...,30]
               [--pysim PATH] [--python PY] [--only NAME[,NAME...]] [--strict-named]

Each case is a drive of the independent simulator (tools/pysim/odosim.py) with one
``--map-error`` (its docstring, "Map errors"): the map written as ``wall`` records differs
from the world the laser sees, while the robot, its odometry and its laser are those of the
clean drive with the same seed. For every case and seed the script runs
`ODOERR diagnose DRIVE --json OUT` and checks:

  * `map_misfit.regions` holds a region whose centre (x, y) is within MATCH_M = 0.3 m of
    where the generator put the error, with the right sign:
      - object (a box in the world, not in the map): the nearest point of the box's
        outline (the faces the laser sees, or the map wall it stands against); "short";
      - phantom (a wall in the map, not in the world): the nearest point of the phantom's
        wall record; "long" (the map says a wall is there, the beams go further);
      - shift (map wall i written d along its left normal): the nearest point of the
        written wall record i; the sign is derived from the drive: the robot's side of
        the wall is the side of the median truth position; a wall drawn NEARER to the
        robot than it is (d along the normal towards the robot's side) gives ranges
        longer than predicted, "long"; drawn further away, "short";
  * no catalogue effect of kind "motion" or "noise" is named (`ranking[i].significant`
    true): a map error is not an odometry effect. Measurement effects may be named (a
    shifted wall is wall_offset's mirror image) and are reported. An odometry effect that
    diagnose names on the CLEAN drive of the same seed as well (that seed's own false
    alarm, counted in the clean drives' budget, not the map error's doing) is reported but
    does not fail the case; --strict-named fails it too. The clean drive of a case's seed
    is the clean set's when the seed is in --clean-seeds, else it is made and diagnosed
    for the comparison.
Clean drives (no map error, --clean-seeds, default 21-30) are one case: a drive is FLAGGED
when `map_misfit.regions` is not empty. The rule, as in check_discovery.py: at most
ceil(5 % of the seeds) drives flagged, i.e. 1 of 10 (1 of 20); a clean drive whose JSON
lacks a key fails the case outright. `--clean-seeds=` (empty) leaves the case out (the clean
drives of the cases' seeds are still made for the comparison above): the ctest entry does
so, because check_discovery.py's clean case flags a region on the same drives (the same
simulator, seeds and diagnose call), 20 of them.

A key missing from the JSON (a binary without the map-misfit analysis) is a FAIL line
naming the key, not a traceback. Each line also shows what today's diagnose says
(verdict, named effects, the top of the ranking, `unexplained.features`). Prints one line
per drive (the clean set's summary after its drives) and finally exactly
`N passed, M failed`; exits 0 only when none failed. The figures of every drive are also
written to OUTDIR/summary_map.json.
"""
import argparse
import json
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from diag_json import Missing, common_args, diagnose, feature_text, fmt, named_rows, need, run, seed_list  # noqa: E402
DEFAULT_PYSIM = os.path.normpath(os.path.join(HERE, "..", "..", "tools", "pysim", "odosim.py"))

MATCH_M = 0.3               # a region's centre within this of the error
CLEAN_FALSE_ALARM = 0.05    # at most ceil(5 % of the clean seeds) flagged
WRONG_KINDS = {"motion", "noise"}

# name -> (kind, values, words). The placements are odosim's suggested ones
# (odosim.py --list-map-errors): each met by more than a thousand beams of a 4-minute
# drive of seeds 21 and 22, from many poses, at least 1.25 m from the path.
CASES = {
    "cabinet": ("object", [5.0, 0.2, 0.6, 0.4], "0.6 x 0.4 cabinet against the bottom wall"),
    "pillar": ("object", [4.3, 3.2, 0.3, 0.3], "0.3 x 0.3 pillar in the open (lower lobe's centre)"),
    "pallet": ("object", [7.5, 3.0, 1.0, 0.5], "1.0 x 0.5 pallet in the open"),
    "phantom": ("phantom", [1.5, 3.0, 1.5, 4.5], "1.5 m wall in the map at x = 1.5, not in the world"),
    "shift_room": ("shift", [0, 0.10], "bottom room wall drawn 0.10 m into the room"),
    "shift_box": ("shift", [4, 0.10], "bottom wall of the 1.2 m box drawn 0.10 m into the box"),
    # the world changing during the drive (tools/pysim/world_events.py)
    "door": ("door", [1.5, 3.0, 1.5, 4.5, 120.0], "a door at x = 1.5 in the map, closed until 120 s, open after"),
    "walker": ("walker", [7.5, 2.0, 7.5, 5.0, 0.8], "a person walking to and fro along x = 7.5, y 2..5 at 0.8 m/s"),
}
# Each region's history (map_misfit.regions[i].history) must tell these apart: a fixed map
# error is "persistent"; the door "changed" within CHANGE_S of its opening; near the walker's
# line no region is persistent or changed (one there is "transient" or "intermittent").
EXPECT_KIND = {"object": "persistent", "phantom": "persistent", "door": "changed"}
CHANGE_S = 20.0



def spec_text(kind, values):
    return "%s=%s" % (kind, ",".join(str(v) if isinstance(v, int) else repr(float(v))
                                      for v in values))


def generate(args, log, seed, kind=None, values=None):
    cmd = [args.python, args.pysim, "--drive", "diff", "--seed", str(seed), "--out", log]
    if kind:
        cmd += ["--map-error", spec_text(kind, values)]
    return run(cmd)


# ---------------------------------------------------------------------------
# Geometry of the generated drive (read from the log itself)
# ---------------------------------------------------------------------------

def read_walls_truth(log):
    """(wall records [[x1, y1, x2, y2]..], truth positions [(x, y)..]) of an odolog."""
    walls, truth = [], []
    with open(log, encoding="utf-8") as f:
        for line in f:
            if line.startswith("wall "):
                walls.append([float(v) for v in line.split()[1:5]])
            elif line.startswith("truth "):
                tok = line.split()
                truth.append((float(tok[2]), float(tok[3])))
    return walls, truth


def seg_dist(px, py, seg):
    x1, y1, x2, y2 = seg
    ex, ey = x2 - x1, y2 - y1
    ee = ex * ex + ey * ey
    u = 0.0 if ee == 0 else max(0.0, min(1.0, ((px - x1) * ex + (py - y1) * ey) / ee))
    return math.hypot(px - x1 - u * ex, py - y1 - u * ey)


def box_outline(x, y, w, h):
    x0, x1, y0, y1 = x - w / 2, x + w / 2, y - h / 2, y + h / 2
    return [[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]]


def target(kind, values, log):
    """(segments where the error is, expected sign, words on how the sign was derived)."""
    walls, truth = read_walls_truth(log)
    if kind == "object":
        return box_outline(*values), "short", "an object: beams end early"
    if kind == "door":
        return [[float(v) for v in values[:4]]], "long", "a door opened at %.0f s: beams go further after" % values[4]
    if kind == "walker":
        return [[float(v) for v in values[:4]]], None, "a person passing: at most a transient region"
    if kind == "phantom":
        seg = [float(v) for v in values]
        if not any(all(abs(a - b) < 1e-9 for a, b in zip(seg, w)) for w in walls):
            raise ValueError("the phantom %s is not among the log's wall records" % seg)
        return [seg], "long", "a phantom: beams go further"
    i, d = int(values[0]), float(values[1])
    x1, y1, x2, y2 = walls[i]                # the wall as written (shifted)
    length = math.hypot(x2 - x1, y2 - y1)
    nx, ny = -(y2 - y1) / length, (x2 - x1) / length
    # which side of the wall's line is the robot on? the median signed distance of the truth
    sd = sorted((px - x1) * nx + (py - y1) * ny for px, py in truth)
    side = 1.0 if sd[len(sd) // 2] > 0 else -1.0
    nearer = d * side > 0                    # moved towards the robot's side
    return [walls[i]], "long" if nearer else "short", (
        "wall %d drawn %.2f m %s the robot (its side: %s the left normal (%+.0f, %+.0f))"
        % (i, abs(d), "towards" if nearer else "away from", "along" if side > 0 else "against",
           nx + 0.0, ny + 0.0))


# ---------------------------------------------------------------------------
# What today's diagnose says
# ---------------------------------------------------------------------------

def todays_words(j):
    """One text with the verdict, named effects, top of the ranking, unexplained features;
    never raises."""
    parts = ["verdict %s" % j.get("verdict")]
    nis = j.get("tests", {}).get("nis_mean") if isinstance(j.get("tests"), dict) else None
    parts.append("NIS %s" % fmt(nis, ".3f"))
    rank = j.get("ranking")
    if isinstance(rank, list):
        named = [r.get("effect") for r in rank if isinstance(r, dict) and r.get("significant") is True]
        parts.append("named %s" % (named or "none"))
        parts.append("top %s" % ", ".join(
            "%s(%s, p %s)" % (r.get("effect"), r.get("kind"), fmt(r.get("p_value"), ".2g"))
            for r in rank[:3] if isinstance(r, dict)))
    else:
        parts.append("no ranking")
    un = j.get("unexplained")
    if isinstance(un, dict):
        feats = un.get("features") or []
        parts.append("unexplained %s: %s" % (un.get("significant"), "; ".join(
            feature_text(f) for f in feats[:3]) or "no feature"))
    else:
        parts.append("no unexplained")
    return ", ".join(parts)


def region_text(r):
    if not isinstance(r, dict):
        return repr(r)
    ext = r.get("extent_m")
    ext = "x".join(fmt(v, ".2f") for v in ext) if isinstance(ext, list) else "?"
    return "(%s, %s) %s m %s, %s beams, mean_norm %s%s" % (
        fmt(r.get("x"), ".2f"), fmt(r.get("y"), ".2f"), ext, r.get("sign"), r.get("beams"),
        fmt(r.get("mean_norm"), ".2f"),
        ", segment %s" % [round(v, 2) for v in r["candidate_segment"]]
        if isinstance(r.get("candidate_segment"), list) else "")


# ---------------------------------------------------------------------------
# Cases
# ---------------------------------------------------------------------------

def clean_drive(args, seed):
    """(json or None, odosim s, diagnose s, error) of the clean drive of a seed, made and
    diagnosed once per run (the clean set and the cases' comparisons share it)."""
    if seed not in args.clean_cache:
        base = os.path.join(args.outdir, "clean_s%d" % seed)
        ok, gen_s, err = generate(args, base + ".odolog", seed)
        if not ok:
            args.clean_cache[seed] = (None, gen_s, 0.0, "odosim failed: %s" % err)
        else:
            j, diag_s, err = diagnose(args, base + ".odolog", base + ".json")
            args.clean_cache[seed] = (j, gen_s, diag_s, err)
    return args.clean_cache[seed]


def check_case(args, name, seed):
    """(passed, line, record)."""
    kind, values, words = CASES[name]
    base = os.path.join(args.outdir, "%s_s%d" % (name, seed))
    log = base + ".odolog"
    label = "%s seed %d (%s)" % (name, seed, spec_text(kind, values))
    rec = {"case": name, "seed": seed, "map_error": spec_text(kind, values)}
    ok, gen_s, err = generate(args, log, seed, kind, values)
    if not ok:
        return False, "%s: FAIL: odosim failed: %s" % (label, err), rec
    try:
        segs, sign, why = target(kind, values, log)
    except (OSError, ValueError, IndexError) as e:
        return False, "%s: FAIL: cannot read the drive's geometry: %s" % (label, e), rec
    j, diag_s, err = diagnose(args, log, base + ".json")
    if j is None:
        return False, "%s: FAIL: %s" % (label, err), rec

    fails, info = [], []
    # 1. a region at the error, with the right sign
    try:
        regions = need(j, "map_misfit", "regions")
        if not isinstance(regions, list):
            raise Missing("map_misfit.regions (not a list)")
        scored = []
        for k, r in enumerate(regions):
            x, y = need(regions, k, "x"), need(regions, k, "y")
            need(regions, k, "sign")
            scored.append((min(seg_dist(x, y, s) for s in segs), r))
        scored.sort(key=lambda t: t[0])
        hits = [(d, r) for d, r in scored if d <= MATCH_M and r.get("sign") == sign]
        rec["regions"] = len(regions)
        if sign is None:  # the walker: nothing fixed may be found where it walks
            near = [(d, r) for d, r in scored if d <= 0.5 + MATCH_M]
            fixed = [(d, r) for d, r in near if (r.get("history") or {}).get("kind") in ("persistent", "changed")]
            info.append("%d region(s) near its line%s" % (len(near), ": " + "; ".join(
                "%s, %s" % (region_text(r), (r.get("history") or {}).get("kind")) for _, r in near) if near else ""))
            if fixed:
                fails.append("a region near the walker's line is %s: %s" % (
                    (fixed[0][1].get("history") or {}).get("kind"), region_text(fixed[0][1])))
        elif hits:
            d, r = hits[0]
            info.append("region %s at %.2f m from the error" % (region_text(r), d))
            rec.update(match_m=d, region=r)
            h = r.get("history") or {}
            want = EXPECT_KIND.get(kind)
            if want:
                ch = h.get("change") or {}
                info.append("history: %s%s" % (h.get("kind"), ", changed at %.1f s" % ch["t"] if ch.get("t") else ""))
                if h.get("kind") != want:
                    fails.append("the region is %s, not %s (disagreed in %s of %s scans)" % (
                        h.get("kind"), want, (h.get("disagreed") or {}).get("scans"), (h.get("seen") or {}).get("scans")))
                elif kind == "door" and abs(ch.get("t", -1e9) - values[4]) > CHANGE_S:
                    fails.append("the change at %s s is more than %g s from the door's opening at %g s" % (
                        ch.get("t"), CHANGE_S, values[4]))
        else:
            near = "; ".join("%s at %.2f m" % (region_text(r), d) for d, r in scored[:3])
            fails.append("no %s region within %.1f m of the error (%d region(s)%s)" % (
                sign, MATCH_M, len(regions), ": " + near if near else ""))
        info.append("%d region(s)" % len(regions))
    except Missing as e:
        fails.append("diagnose JSON has no '%s' (map misfit not in this binary?)" % e)
    # 1b. along the wall concerned (phantom, shift): its bins lean the expected way
    if kind in ("phantom", "shift"):
        try:
            walls_rec, _ = read_walls_truth(log)
            wi = int(values[0]) if kind == "shift" else next(
                k for k, w in enumerate(walls_rec)
                if all(abs(a - float(b)) < 1e-9 for a, b in zip(w, values)))
            bins = need(j, "map_misfit", "walls", wi, "bins")
            n = sum(b.get("count", 0) for b in bins if b.get("mean_norm") is not None)
            mean = (sum(b["count"] * b["mean_norm"] for b in bins if b.get("mean_norm") is not None) / n
                    if n else None)
            info.append("wall %d along its length: %s beams, mean z %s" % (wi, n, fmt(mean)))
            if mean is None or (mean < 0) != (sign == "short"):
                fails.append("wall %d's bins do not lean %s (mean z %s)" % (wi, sign, fmt(mean)))
        except Missing as e:
            fails.append("diagnose JSON has no '%s' (wall bins)" % e)
    # 2. no odometry effect named for a map error
    try:
        named = named_rows(j)
        wrong = [(e, k) for e, k in named if k in WRONG_KINDS]
        rec["named"] = named
        if wrong:
            cj, _, _, cerr = clean_drive(args, seed)
            try:
                clean_named = set(e for e, _ in named_rows(cj)) if cj is not None else None
            except Missing:
                clean_named = None
            own = [] if clean_named is None else [(e, k) for e, k in wrong if e in clean_named]
            added = [(e, k) for e, k in wrong if (e, k) not in own]
            if clean_named is None:
                info.append("(the clean drive of seed %d could not be compared: %s)" % (
                    seed, cerr or "no ranking"))
            if own:
                info.append("%s named on the clean drive of seed %d too (the seed's own "
                            "false alarm)" % (", ".join("%s (%s)" % w for w in own), seed))
            blame = wrong if args.strict_named else added
            if blame:
                fails.append("odometry effect named for a map error: %s" % ", ".join(
                    "%s (%s)" % w for w in blame))
            rec["named_on_clean_too"] = [e for e, _ in own]
    except Missing as e:
        fails.append("diagnose JSON has no '%s'" % e)
    info.append(todays_words(j))
    rec["today"] = todays_words(j)
    status = "ok" if not fails else "FAIL: " + "; ".join(fails)
    line = "%s: %s | expect %s near %s (%s) | %s | odosim %.2f s, diagnose %.1f s" % (
        label, status, sign or "nothing fixed", words, why, " | ".join(info), gen_s, diag_s)
    rec.update(ok=not fails, line=line)
    return not fails, line, rec


def check_clean(args, seeds):
    """(passed, [lines], [records])."""
    lines, recs, flagged, broken = [], [], [], []
    for s in seeds:
        rec = {"case": "clean", "seed": s}
        j, gen_s, diag_s, err = clean_drive(args, s)
        if j is None:
            broken.append(s)
            lines.append("  clean seed %d: FAIL: %s" % (s, err))
            recs.append(rec)
            continue
        try:
            regions = need(j, "map_misfit", "regions")
            if not isinstance(regions, list):
                raise Missing("map_misfit.regions (not a list)")
            if regions:
                flagged.append(s)
                status = "flagged: %d region(s): %s" % (len(regions), "; ".join(
                    region_text(r) for r in regions[:3]))
            else:
                status = "clean (no region)"
            rec["regions"] = len(regions)
        except Missing as e:
            broken.append(s)
            status = "FAIL: diagnose JSON has no '%s' (map misfit not in this binary?)" % e
        rec["today"] = todays_words(j)
        lines.append("  clean seed %d: %s | %s | odosim %.2f s, diagnose %.1f s" % (
            s, status, todays_words(j), gen_s, diag_s))
        recs.append(rec)
    allowed = math.ceil(CLEAN_FALSE_ALARM * len(seeds))
    ok = not broken and len(flagged) <= allowed
    lines.append("clean (%d seeds): %s | map_misfit regions on %d (seeds %s), at most %d "
                 "allowed%s" % (len(seeds), "ok" if ok else "FAIL", len(flagged),
                                flagged or "-", allowed,
                                "; broken seeds %s" % broken if broken else ""))
    return ok, lines, recs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    common_args(ap, DEFAULT_PYSIM, CASES, "map-error cases")
    ap.add_argument("--strict-named", action="store_true",
                    help="fail a case on any motion/noise effect named, even one named on "
                         "the clean drive of the same seed too")
    args = ap.parse_args()
    args.clean_cache = {}
    names = list(CASES) + ["clean"]
    if args.only:
        names = [n.strip() for n in args.only.split(",") if n.strip()]
        unknown = [n for n in names if n not in CASES and n != "clean"]
        if unknown:
            ap.error("--only: unknown case(s) %s; known: %s, clean" % (unknown, ", ".join(CASES)))
    try:
        seeds, clean_seeds = seed_list(args.seeds), seed_list(args.clean_seeds)
    except ValueError:
        ap.error("--seeds / --clean-seeds: comma-separated integers or ranges A-B")
    if not os.path.isfile(args.pysim):
        ap.error("--pysim %s: no such file" % args.pysim)
    os.makedirs(args.outdir, exist_ok=True)

    passed = failed = 0
    results = []
    for name in names:
        if name == "clean":
            if not clean_seeds:
                continue
            ok, lines, recs = check_clean(args, clean_seeds)
            for line in lines:
                print(line, flush=True)
            results.append({"case": "clean", "ok": ok, "drives": recs, "line": lines[-1]})
            passed, failed = passed + ok, failed + (not ok)
            continue
        for s in seeds:
            ok, line, rec = check_case(args, name, s)
            print(line, flush=True)
            results.append(rec)
            passed, failed = passed + ok, failed + (not ok)
    with open(os.path.join(args.outdir, "summary_map.json"), "w") as f:
        json.dump({"passed": passed, "failed": failed, "results": results}, f, indent=1)
    print("%d passed, %d failed" % (passed, failed))
    return 0 if failed == 0 and passed > 0 else 1


if __name__ == "__main__":
    sys.exit(main())

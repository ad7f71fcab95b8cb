"""Reading and checking what `odoerr diagnose` wrote: diagnose.json and the CSV files.

Every problem is an InputError whose message names the file (and the line or key)."""
import csv
import io
import json
import operator
import os
import re

import numpy as np


class InputError(Exception):
    """An input file is missing or malformed; the message names the file."""


# ----------------------------------------------------------------------------------------
# Reading and checking the inputs
# ----------------------------------------------------------------------------------------

def read_json(path):
    if not os.path.isfile(path):
        raise InputError(f"{path}: file not found (odoerr diagnose writes it)")
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except json.JSONDecodeError as e:
        raise InputError(f"{path}: not valid JSON: {e.msg} (line {e.lineno}, column {e.colno})")
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{path}: cannot read: {e}")


def read_csv(path, columns, str_columns=()):
    """Columns of a CSV file as numpy arrays (float; '' -> nan), str_columns as str arrays.

    A large file is parsed by numpy's C reader (fast_columns); a file it cannot take (quotes,
    blank lines, a row of another width, a field that is not a number) is read again row by row,
    which finds the problem and names its line."""
    if not os.path.isfile(path):
        raise InputError(f"{path}: file not found (odoerr diagnose writes it)")
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{path}: cannot read: {e}")
    out = fast_columns(text, columns, str_columns) if len(text) > FAST_BYTES else None
    return out if out is not None else read_csv_rows(path, text, columns, str_columns)


FAST_BYTES = 64 * 1024     # smaller files: the row-by-row reader is as fast


def fast_columns(text, columns, str_columns):
    """The columns by np.loadtxt, or None when the file is not plain comma-separated numbers
    (and the str columns) of one width: the caller then reads it row by row."""
    if '"' in text:
        return None
    lines = text.splitlines()
    while lines and lines[-1] == "":
        lines.pop()
    if len(lines) < 2 or not lines[0].strip():
        return None
    header = [h.strip() for h in lines[0].split(",")]
    if any(c not in header for c in columns) or len(set(header)) != len(header):
        return None
    body = lines[1:]
    counts = np.fromiter(map(operator.methodcaller("count", ","), body), dtype=np.int64, count=len(body))
    if (counts != len(header) - 1).any():          # blank lines, rows of another width
        return None
    if any(x in text for x in (",,", ",\n", "\n,", ", ,")) or text.startswith(",") or body[-1].endswith(","):
        body = EMPTY_FIELD.sub(r"\1nan", "\n".join(body)).split("\n")
    num_cols = [c for c in columns if c not in str_columns]
    out = {}
    try:
        if num_cols:
            a = np.loadtxt(body, delimiter=",", usecols=[header.index(c) for c in num_cols], dtype=float,
                           ndmin=2, comments=None)
            for k, c in enumerate(num_cols):
                out[c] = a[:, k].copy()
        for c in columns:
            if c in str_columns:
                v = np.loadtxt(body, delimiter=",", usecols=[header.index(c)], dtype=str, ndmin=1, comments=None)
                out[c] = np.char.strip(v).astype(object)
    except ValueError:
        return None
    return out


EMPTY_FIELD = re.compile(r"(^|,)[ \t]*(?=,|$)", re.MULTILINE)     # an empty field: nan


def read_csv_rows(path, text, columns, str_columns=()):
    """read_csv with Python's csv module: slower, and names the line of a malformed row."""
    try:
        rows = [r for r in csv.reader(io.StringIO(text, newline="")) if r]
    except csv.Error as e:
        raise InputError(f"{path}: cannot read: {e}")
    if not rows:
        raise InputError(f"{path}: empty file; expected the header {','.join(columns)}")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in columns if c not in header]
    if missing:
        raise InputError(f"{path}: header lacks column(s) {', '.join(missing)} "
                         f"(header is: {','.join(header)})")
    body = rows[1:]
    width = len(header)
    if any(len(r) != width for r in body):
        for i, r in enumerate(body):
            if len(r) != width:
                raise InputError(f"{path}:{i + 2}: {len(r)} fields where the header has {width}")
    cols = list(zip(*body)) if body else [()] * width
    out = {}
    for c in columns:
        raw = cols[header.index(c)]
        if c in str_columns:
            out[c] = np.array([s.strip() for s in raw], dtype=object)
            continue
        try:
            out[c] = np.array(raw, dtype=float) if raw else np.zeros(0)
        except ValueError:
            vals = np.empty(len(raw))
            for i, s in enumerate(raw):
                s = s.strip()
                if s == "":
                    vals[i] = np.nan
                    continue
                try:
                    vals[i] = float(s)
                except ValueError:
                    raise InputError(f"{path}:{i + 2}: column '{c}': '{s[:40]}' is not a number")
            out[c] = vals
    return out


def is_num(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def num(obj, key, where, path):
    """obj[key] as float, None when missing/null; a non-number is an error."""
    if not isinstance(obj, dict) or key not in obj or obj[key] is None:
        return None
    v = obj[key]
    if not is_num(v):
        raise InputError(f"{path}: '{where}.{key}' should be a number, found {json.dumps(v)[:60]}")
    return float(v)


def expect(cond, path, msg):
    if not cond:
        raise InputError(f"{path}: {msg}")


def check_diagnose(d, path):
    """Structural checks; values that are merely missing are shown as '—' later."""
    expect(isinstance(d, dict), path, "top level should be a JSON object")
    for k in ("log", "drive", "verdict", "tests", "ranking"):
        expect(k in d, path, f"missing key '{k}'")
    for k in ("log", "drive", "verdict"):
        expect(isinstance(d[k], str), path, f"'{k}' should be a string")
    expect(isinstance(d["tests"], dict), path, "'tests' should be an object")
    expect(isinstance(d["ranking"], list), path, "'ranking' should be a list")
    for i, r in enumerate(d["ranking"]):
        expect(isinstance(r, dict) and isinstance(r.get("effect"), str), path,
               f"'ranking[{i}]' should be an object with a string 'effect'")
        for k in ("delta_loglik", "bic_gain", "p_value", "informed_params"):
            num(r, k, f"ranking[{i}]", path)
        for k in ("estimate", "sigma"):
            v = r.get(k)
            expect(v is None or is_num(v) or (isinstance(v, list) and all(is_num(x) or x is None for x in v)),
                   path, f"'ranking[{i}].{k}' should be a list of numbers")
        cw = r.get("confused_with")
        expect(cw is None or (isinstance(cw, list) and all(isinstance(x, str) for x in cw)),
               path, f"'ranking[{i}].confused_with' should be a list of names")
    t = d["tests"]
    for k, v in t.items():
        if k == "nis_band":
            expect(v is None or (isinstance(v, list) and len(v) == 2 and all(is_num(x) for x in v)),
                   path, "'tests.nis_band' should be [lo, hi]")
        elif k == "ljung_box":
            expect(v is None or isinstance(v, dict), path, "'tests.ljung_box' should be an object")
            for kk in ("lags", "q", "p_value"):
                num(v, kk, "tests.ljung_box", path)
    h = d.get("heldout")
    if h is not None:
        expect(isinstance(h, dict), path, "'heldout' should be null or an object")
        for k in ("before", "after"):
            expect(isinstance(h.get(k), dict), path, f"'heldout.{k}' should be an object")
            for kk in h[k]:
                num(h[k], kk, f"heldout.{k}", path)
        bl = h.get("blocks") or []
        expect(isinstance(bl, list) and all(isinstance(b, list) and len(b) == 2 and all(is_num(x) for x in b)
                                            for b in bl), path, "'heldout.blocks' should be [[t0,t1],...]")
    e = d.get("excitation")
    if e is not None:
        expect(isinstance(e, dict), path, "'excitation' should be an object")
        ps = e.get("parameters") or []
        expect(isinstance(ps, list), path, "'excitation.parameters' should be a list")
        for i, p in enumerate(ps):
            expect(isinstance(p, dict), path, f"'excitation.parameters[{i}]' should be an object")
            for k in ("sigma_achievable", "prior_sigma"):
                num(p, k, f"excitation.parameters[{i}]", path)
        w = e.get("warnings") or []
        expect(isinstance(w, list), path, "'excitation.warnings' should be a list of sentences")
    dp = d.get("detection_power")
    if dp is not None:
        expect(isinstance(dp, dict), path, "'detection_power' should be an object")
        num(dp, "power", "detection_power", path)
        fams = dp.get("families") or []
        expect(isinstance(fams, list), path, "'detection_power.families' should be a list")
        for i, f in enumerate(fams):
            expect(isinstance(f, dict) and isinstance(f.get("parameters") or [], list), path,
                   f"'detection_power.families[{i}]' should be an object with a list of parameters")
            for j, p in enumerate(f.get("parameters") or []):
                expect(isinstance(p, dict), path, f"'detection_power.families[{i}].parameters[{j}]' should be an object")
                for k in ("min_detectable", "reference_size"):
                    num(p, k, f"detection_power.families[{i}].parameters[{j}]", path)
        feats = dp.get("features")
        if feats is not None:
            expect(isinstance(feats, dict), path, "'detection_power.features' should be an object")
            for design in ("motion", "beam"):
                terms = (feats.get(design) or {}).get("terms") or []
                expect(isinstance(terms, list), path, f"'detection_power.features.{design}.terms' should be a list")
                for i, t in enumerate(terms):
                    expect(isinstance(t, dict), path, f"'detection_power.features.{design}.terms[{i}]' should be an object")
                    num(t, "min_detectable", f"detection_power.features.{design}.terms[{i}]", path)
    b = d.get("bins")
    if b is not None:
        expect(isinstance(b, dict), path, "'bins' should be an object")
        for name, lst in b.items():
            expect(lst is None or isinstance(lst, list), path, f"'bins.{name}' should be a list")
            for i, e in enumerate(lst or []):
                expect(isinstance(e, dict), path, f"'bins.{name}[{i}]' should be an object")
                for k in ("lo", "hi", "count", "nis_mean", "mean_norm_innovation"):
                    num(e, k, f"bins.{name}[{i}]", path)
    c = d.get("cusum")
    if c is not None:
        expect(isinstance(c, dict), path, "'cusum' should be an object")
        al = c.get("alarms") or []
        expect(isinstance(al, list), path, "'cusum.alarms' should be a list")
        for i, a in enumerate(al):
            expect(isinstance(a, dict), path, f"'cusum.alarms[{i}]' should be an object")
            for k in ("t", "x", "y"):
                num(a, k, f"cusum.alarms[{i}]", path)
    m = d.get("map")
    if m is not None:
        expect(isinstance(m, dict), path, "'map' should be an object")
        walls = m.get("walls") or []
        expect(isinstance(walls, list) and all(isinstance(w, list) and len(w) == 4 and all(is_num(x) for x in w)
                                               for w in walls), path,
               "'map.walls' should be a list of [x1, y1, x2, y2]")
    check_discovery(d, path)
    check_map_misfit(d, path)


def _features(lst, where, path):
    expect(lst is None or isinstance(lst, list), path, f"'{where}' should be a list")
    for i, f in enumerate(lst or []):
        expect(isinstance(f, dict), path, f"'{where}[{i}]' should be an object")
        for k in ("coef", "sigma"):
            num(f, k, f"{where}[{i}]", path)
        for k in ("name", "frame", "component", "words", "with"):
            expect(f.get(k) is None or isinstance(f[k], str), path, f"'{where}[{i}].{k}' should be a string")


def check_discovery(d, path):
    """The keys of discovery, change points and --with auto; each may be absent (an older
    odoerr) or null."""
    u = d.get("unexplained")
    if u is not None:
        expect(isinstance(u, dict), path, "'unexplained' should be null or an object")
        num(u, "explained_fraction", "unexplained", path)
        _features(u.get("features"), "unexplained.features", path)
        _features(u.get("baseline_features"), "unexplained.baseline_features", path)
        for k in ("motion", "beam"):
            expect(u.get(k) is None or isinstance(u[k], dict), path, f"'unexplained.{k}' should be an object")
    cps = d.get("change_points")
    expect(cps is None or isinstance(cps, list), path, "'change_points' should be a list")
    for i, c in enumerate(cps or []):
        expect(isinstance(c, dict), path, f"'change_points[{i}]' should be an object")
        for k in ("t", "t_lo", "t_hi", "statistic", "critical_0.1pct"):
            num(c, k, f"change_points[{i}]", path)
    a = d.get("auto")
    if a is not None:
        expect(isinstance(a, dict), path, "'auto' should be null or an object")
        for k in ("steps", "tried", "final_with"):
            expect(a.get(k) is None or isinstance(a[k], list), path, f"'auto.{k}' should be a list")
        for i, st in enumerate(a.get("steps") or []):
            expect(isinstance(st, dict), path, f"'auto.steps[{i}]' should be an object")
            num(st, "score_z", f"auto.steps[{i}]", path)
            num(st, "explained_fraction", f"auto.steps[{i}]", path)
            h = st.get("heldout")
            expect(h is None or isinstance(h, dict), path, f"'auto.steps[{i}].heldout' should be an object")
        for i, st in enumerate(a.get("tried") or []):
            expect(isinstance(st, dict), path, f"'auto.tried[{i}]' should be an object")
    for i, r in enumerate(d.get("ranking") or []):
        ex = r.get("explains")
        expect(ex is None or isinstance(ex, dict), path, f"'ranking[{i}].explains' should be an object")
        for k in ("motion", "beam", "total"):
            num(ex, k, f"ranking[{i}].explains", path)


def _is_xy(v, n):
    return isinstance(v, list) and len(v) == n and all(is_num(x) for x in v)


def check_map_misfit(d, path):
    """The key 'map_misfit' (where the map is wrong); absent (an older odoerr) or null is fine."""
    m = d.get("map_misfit")
    if m is None:
        return
    expect(isinstance(m, dict), path, "'map_misfit' should be null or an object")
    for k in ("cell_m", "cells_tested", "t_critical", "family_alpha"):
        num(m, k, "map_misfit", path)
    g = m.get("grid")
    expect(g is None or isinstance(g, dict), path, "'map_misfit.grid' should be an object")
    for k in ("x0", "y0", "nx", "ny"):
        num(g, k, "map_misfit.grid", path)
    regs = m.get("regions")
    expect(regs is None or isinstance(regs, list), path, "'map_misfit.regions' should be a list")
    for i, r in enumerate(regs or []):
        w = f"map_misfit.regions[{i}]"
        expect(isinstance(r, dict), path, f"'{w}' should be an object")
        for k in ("x", "y", "beams", "mean_norm", "scans"):
            num(r, k, w, path)
        expect(r.get("sign") in (None, "short", "long"), path, f"'{w}.sign' should be \"short\" or \"long\"")
        expect(r.get("extent_m") is None or _is_xy(r["extent_m"], 2), path, f"'{w}.extent_m' should be [w, h]")
        sf = r.get("seen_from")
        expect(sf is None or (isinstance(sf, list) and all(_is_xy(p, 2) for p in sf)), path,
               f"'{w}.seen_from' should be a list of [x, y]")
        expect(r.get("candidate_segment") is None or _is_xy(r["candidate_segment"], 4), path,
               f"'{w}.candidate_segment' should be null or [x1, y1, x2, y2]")
    for k in ("grid_csv", "region_beams"):
        expect(m.get(k) is None or isinstance(m[k], str), path, f"'map_misfit.{k}' should be a string")
    rw = m.get("ranking_with_region_beams")
    expect(rw is None or (isinstance(rw, list) and all(isinstance(r, dict) and isinstance(r.get("effect"), str)
                                                       for r in rw)),
           path, "'map_misfit.ranking_with_region_beams' should be null or a list of {effect, significant, p_value}")


def read_map_grid(outdir, d):
    """map_grid.csv (x,y,count,mean_norm,rms_norm,t,region) when diagnose.json names it and it
    is there; None otherwise (the section says so)."""
    m = d.get("map_misfit")
    name = m.get("grid_csv") if isinstance(m, dict) else None
    if not name:
        return None
    path = os.path.join(outdir, os.path.basename(name))
    if not os.path.isfile(path):
        return None
    return read_csv(path, ["x", "y", "count", "mean_norm", "rms_norm", "t", "region"])


def read_discovery_csv(path):
    """A discovery CSV (t,row,y,fit, then a column and its partial residual per selected
    term): (columns, terms), terms the names 'frame/component/name'; None when absent."""
    if not os.path.isfile(path):
        return None
    try:
        with open(path, newline="", encoding="utf-8") as f:
            header = [h.strip() for h in next(csv.reader(f), [])]
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise InputError(f"{path}: cannot read: {e}")
    terms = [h for h in header if h not in ("t", "row", "y", "fit") and not h.startswith("partial_")]
    lacking = [f"partial_{h}" for h in terms if f"partial_{h}" not in header]
    if lacking:
        raise InputError(f"{path}: header lacks column(s) {', '.join(lacking)} (header is: {','.join(header)})")
    cols = read_csv(path, ["t", "row", "y", "fit"] + [c for h in terms for c in (h, f"partial_{h}")])
    return cols, terms


def load_inputs(d):
    if not os.path.isdir(d):
        raise InputError(f"{d}: not a directory (expected the output directory of odoerr diagnose)")
    p = lambda name: os.path.join(d, name)
    diag = read_json(p("diagnose.json"))
    check_diagnose(diag, p("diagnose.json"))
    scans = read_csv(p("scans.csv"), ["t", "dist_m", "x", "y", "theta", "dof", "nis_sum", "band_lo",
                                      "band_hi", "along_m", "cross_m", "heading_rad"])
    beams = read_csv(p("beams.csv"), ["t", "beam", "hit_x", "hit_y", "innovation_m", "nis", "status"],
                     str_columns=("status",))
    traj = read_csv(p("trajectory.csv"), ["t", "x", "y", "theta", "truth_x", "truth_y", "truth_theta"])
    held = {}
    if diag.get("heldout") is not None:
        for k in ("before", "after"):
            f = p(f"heldout_{k}.csv")
            if os.path.isfile(f):
                held[k] = read_csv(f, ["t", "nis", "pose_err_m"])
    disc = {k: read_discovery_csv(p(f"discovery_{k}.csv")) for k in ("motion", "beam")}
    return diag, scans, beams, traj, held, disc

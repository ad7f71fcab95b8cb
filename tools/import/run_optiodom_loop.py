#!/usr/bin/env python3
"""run_optiodom_loop.py: the diagnose loop on every OptiOdom run, and a cross-path-type check.

Usage (from the repository root; the interpreter needs only the standard library):
    /usr/bin/python3 tools/import/run_optiodom_loop.py OUT_DIR \
        [--odoerr BIN] [--data DIR] [--threads 1] [--nice 19] [--min-kept 3] [--no-cross]

What it does (docs/real-data.md reports its output):
1. Every run CSV under DATA/{circular,square,ivanjko}/SET/ is imported with
   tools/import/optiodom_to_odolog.py (mocap pose fixes once a second, the importer's
   default, as tests/diagnose/realdata.sh does) to OUT_DIR/logs/, and diagnosed with
       nice -n NICE odoerr diagnose LOG --json OUT_DIR/auto/NAME.json --with auto --threads T
2. Cross-path-type check. For each path type P, every token that `--with auto` kept
   (auto.final_with) on at least --min-kept runs of P is added alone, with
       odoerr diagnose LOG --with TOKEN
   to every run of the OTHER path types (OUT_DIR/cross/). The coefficients are re-fitted
   on each run's own data (cross-validated over time); what transfers is the form.
3. Square runs: the catalogue's wheel_backlash alone, and on top of feature:ds@cross, whose
   increment is paired block by block from diagnose's per-scan held-out files
   (OUT_DIR/backlash/; diagnose compares only against the model without --with).
--no-cross leaves out 2 and 3. --tables-only rewrites tables.md from summary.json.
Written to OUT_DIR (by optiodom_loop_tables.py):
   runs.csv      one row per run: path type, set, run, duration, travel, rotation, verdict,
                 named effects, discovered features, change points, auto steps, drive
                 parameters, seconds
   steps.csv     one row per kept --with auto step
   cross.csv     one row per (source path type, token, target run)
   summary.json  all of it, plus each run's excitation warnings, its set's metadata
                 `imarkers`, and the wheel_backlash check
   tables.md     the tables of docs/real-data.md
--data defaults to optiodom-diff in the data folder ($ODOERR_DATA, else ../shared/data from
the repository root; import_common.data_dir()). It needs every run: the sample in tests/data
is not used.
Exit status: 0 on success, 77 when the data set is absent (the message names ODOERR_DATA),
2 on a bad option or a missing odoerr binary, 1 when a run fails.
"""

import argparse
import csv
import glob
import json
import math
import os
import statistics
import subprocess
import sys

import import_common
from optiodom_loop_tables import tables_md, write_outputs

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PATH_TYPES = import_common.OPTIODOM_PATH_TYPES
# Nominal robot (the data set's README): one tick of wheel travel, wheelbase.
TICK_M = math.pi * 0.084 / (43.7 * 64)
WHEELBASE_M = 0.200
WARMUP_S = 10.0  # diagnose's warm-up: no residual segment and no held-out block before it


def die(msg, code):
    print("run_optiodom_loop: " + msg, file=sys.stderr)
    sys.exit(code)


def read_run(path):
    """The run's rows: [(t, x, y, theta, nR, nL)]."""
    rows = []
    with open(path, encoding="utf-8-sig") as f:
        for line in f:
            line = line.strip()
            if line:
                rows.append(tuple(float(v) for v in line.split(",")[:6]))
    return rows


def set_imarkers(set_dir):
    """The `imarkers` row of the set's metadata file, as written (e.g. "4,1"); the data set's
    README does not say what it means."""
    for path in glob.glob(os.path.join(set_dir, "*_metadata.csv")):
        with open(path, encoding="utf-8-sig") as f:
            for line in f:
                cells = [c for c in line.strip().split(",") if c != ""]
                if cells and cells[0] == "imarkers":
                    return ",".join(cells[1:])
    return None


def describe(rows):
    """Duration, travel, rotation and speed from the wheel ticks (nominal constants); the
    per-cycle increments (rho, th, dt, s_abs at the cycle's start) for the drift conversion."""
    cycles, s_abs, rot, back, net_th = [], 0.0, 0.0, 0.0, 0.0
    for p, q in zip(rows, rows[1:]):
        r, l = q[4] * TICK_M, q[5] * TICK_M
        rho, th, dt = 0.5 * (r + l), (r - l) / WHEELBASE_M, q[0] - p[0]
        cycles.append((q[0], rho, th, dt, s_abs))
        s_abs += abs(rho)
        rot += abs(th)
        net_th += th
        if rho < 0:
            back += -rho
    dur = rows[-1][0] - rows[0][0]
    kind = "rotation" if s_abs < 0.1 else ("turning" if rot > math.radians(90) else "straight")
    return {"duration_s": dur, "travel_m": s_abs, "backward_m": back, "rotation_deg": math.degrees(rot),
            "net_rotation_deg": math.degrees(net_th), "mean_speed_mps": s_abs / dur if dur > 0 else None,
            "motion": kind}, cycles


def feature_value(name, rho, th, dt, s_abs):
    """The motion features of core/include/odoerr/effects/features.hpp that depend on the
    increment alone (None for the heading- and position-dependent ones)."""
    a = abs(rho)
    inv = 1.0 / dt if dt > 0 else 0.0
    half_d = 0.5 * WHEELBASE_M
    return {
        "ds": rho, "abs_ds": a, "dth": th, "abs_dth": abs(th),
        "ds_R": rho + th * half_d, "ds_L": rho - th * half_d,
        "ds_R_speed": (rho + th * half_d) * abs(rho + th * half_d) * inv,
        "ds_L_speed": (rho - th * half_d) * abs(rho - th * half_d) * inv,
        "v_w": rho * th * inv, "v2": rho * a * inv, "w2": th * abs(th) * inv,
        "s_ds": s_abs * a, "dt": dt,
    }.get(name)


def cross_drift_per_m(features, cycles):
    """The sideways displacement (left positive) that the discovered `cross` terms make over
    the analysed part of the run (after the warm-up), per metre of travel there. None when
    no cross term was found, the travel is under 0.1 m, or a term depends on pose."""
    terms = [f for f in features if f["frame"] == "robot" and f["component"] == "cross"]
    if not terms:
        return None
    used = [c for c in cycles if c[0] >= WARMUP_S]
    travel = sum(abs(c[1]) for c in used)
    if travel < 0.1:
        return None
    total = 0.0
    for f in terms:
        vals = [feature_value(f["name"], c[1], c[2], c[3], c[4]) for c in used]
        if any(v is None for v in vals):
            return None
        total += f["coef"] * sum(vals)
    return total / travel


def odoerr_diagnose(args, log, out_json, with_, out_dir=None):
    cmd = ["nice", "-n", str(args.nice), args.odoerr, "diagnose", log, "--json", out_json,
           "--with", with_, "--threads", str(args.threads)]
    if out_dir:
        cmd += ["--out", out_dir]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        die("failed (%d): %s\n%s" % (r.returncode, " ".join(cmd), r.stderr.strip()), 1)
    with open(out_json) as f:
        return json.load(f)


def z(paired, key):
    v = (paired or {}).get(key) or {}
    return v.get("change_z")


def summarise_heldout(h, paired):
    """The held-out numbers of one comparison (auto step or a plain --with)."""
    before, after = (h or {}).get("before") or {}, (h or {}).get("after") or {}
    pe = (paired or {}).get("pose_err_m") or {}
    return {"pose_z": z(paired, "pose_err_m"), "nll_z": z(paired, "nll"),
            "blocks": pe.get("blocks"), "blocks_better": pe.get("blocks_better"),
            "pose_rmse_before_m": before.get("pose_rmse_m"), "pose_rmse_after_m": after.get("pose_rmse_m"),
            "nll_before": before.get("nll_mean"), "nll_after": after.get("nll_mean"),
            "folds_failed": (h or {}).get("folds_failed"), "note": (h or {}).get("note")}


def run_record(ptype, set_id, run_no, csv_path, j, desc, cycles):
    u = j.get("unexplained") or {}
    feats = [{"name": f["name"], "frame": f["frame"], "component": f["component"], "coef": f["coef"],
              "sigma": f["sigma"], "words": f["words"], "with": f.get("with")} for f in u.get("features") or []]
    auto = j.get("auto") or {}
    steps = []
    for s in auto.get("steps") or []:
        d = summarise_heldout(s.get("heldout"), s.get("paired"))
        d.update({"added": s.get("added"), "estimate": s.get("estimate"),
                  "explained_fraction": s.get("explained_fraction")})
        steps.append(d)
    tried = [{"step": t.get("step"), "added": t.get("added"), "kept": t.get("kept"),
              "pose_z": z(t.get("paired"), "pose_err_m"), "nll_z": z(t.get("paired"), "nll")}
             for t in auto.get("tried") or []]
    named = [{"effect": r["effect"], "estimate": r.get("estimate"), "sigma": r.get("sigma")}
             for r in j.get("ranking") or [] if r.get("significant")]
    motion = u.get("motion") or {}
    return {
        "path_type": ptype, "set": set_id, "run": run_no,
        "source": os.path.relpath(csv_path, os.path.dirname(os.path.dirname(os.path.dirname(csv_path)))),
        **desc,
        "verdict": j.get("verdict"), "named": named,
        "top_ranked": ((j.get("ranking") or [{}])[0]).get("effect"),
        "segments": motion.get("segments"), "features": feats,
        "features_explain": motion.get("features_explain"),
        "cross_drift_per_m": cross_drift_per_m(feats, cycles),
        "change_points": j.get("change_points") or [],
        "auto_final_with": auto.get("final_with") or [], "auto_steps": steps, "auto_tried": tried,
        "parameters": {k: {"estimate": v.get("estimate"), "sigma": v.get("sigma")}
                       for k, v in ((j.get("baseline") or {}).get("parameters") or {}).items()},
        "excitation_warnings": (j.get("excitation") or {}).get("warnings") or [],
        "seconds": j.get("seconds"),
    }


def read_heldout_csv(path):
    with open(path) as f:
        return [(float(r["t"]), float(r["pose_err_m"])) for r in csv.DictReader(f) if r["pose_err_m"] not in ("", "nan")]


def paired_block_z(blocks, before, after):
    """Each block's mean pose error, after minus before, over the blocks both predicted; the
    mean change over its standard error (the definition of diagnose's `paired.change_z`)."""
    d = []
    for t0, t1 in blocks:
        b = [e for t, e in before if t0 <= t < t1]
        a = [e for t, e in after if t0 <= t < t1]
        if b and a:
            d.append(sum(a) / len(a) - sum(b) / len(b))
    if len(d) < 2:
        return None, len(d), 0
    sd = statistics.stdev(d)
    better = sum(1 for x in d if x < 0)
    return (statistics.mean(d) / (sd / math.sqrt(len(d))) if sd > 0 else None), len(d), better


def backlash_check(args, out, runs):
    """Square runs: the catalogue's wheel_backlash (a) alone against the model as it is, and (b)
    on top of the sideways drift `ds@cross`: the second increment is paired block by block from
    the per-scan held-out files (diagnose itself compares only against the model without --with)."""
    res = []
    for rec in runs:
        if rec["path_type"] != "square":
            continue
        base = os.path.join(out, "backlash", rec["name"])
        for sub in ("wb", "ds", "wb_ds"):
            os.makedirs(os.path.join(base, sub), exist_ok=True)
        ja = odoerr_diagnose(args, rec["log"], os.path.join(base, "wb", "d.json"), "wheel_backlash")
        jb = odoerr_diagnose(args, rec["log"], os.path.join(base, "ds", "d.json"), "feature:ds@cross",
                             os.path.join(base, "ds"))
        jc = odoerr_diagnose(args, rec["log"], os.path.join(base, "wb_ds", "d.json"),
                             "wheel_backlash,feature:ds@cross", os.path.join(base, "wb_ds"))
        ha, hb, hc = ja.get("heldout") or {}, jb.get("heldout") or {}, jc.get("heldout") or {}
        a = summarise_heldout(ha, ha.get("paired"))
        est = [f["after_estimate"].get("wheel_backlash") for f in ha.get("fits") or [] if f.get("used")]
        est = [e for e in est if e]
        b_before = read_heldout_csv(os.path.join(base, "ds", "heldout_before.csv"))
        b_after = read_heldout_csv(os.path.join(base, "ds", "heldout_after.csv"))
        c_after = read_heldout_csv(os.path.join(base, "wb_ds", "heldout_after.csv"))
        check_z, _, _ = paired_block_z(hb.get("blocks") or [], b_before, b_after)
        inc_z, inc_n, inc_better = paired_block_z(hb.get("blocks") or [], b_after, c_after)
        res.append({"run": rec["name"], "direction": "CW" if rec["net_rotation_deg"] < 0 else "CCW",
                    "wb_pose_z": a["pose_z"], "wb_nll_z": a["nll_z"],
                    "wb_rmse_before_m": a["pose_rmse_before_m"], "wb_rmse_after_m": a["pose_rmse_after_m"],
                    "b_R": statistics.median(e[0] for e in est) if est else None,
                    "b_L": statistics.median(e[1] for e in est) if est else None,
                    "ds_rmse_after_m": (hb.get("after") or {}).get("pose_rmse_m"),
                    "ds_pose_z_tool": z(hb.get("paired"), "pose_err_m"), "ds_pose_z_script": check_z,
                    "wb_ds_rmse_after_m": (hc.get("after") or {}).get("pose_rmse_m"),
                    "wb_ds_pose_z_vs_base": z(hc.get("paired"), "pose_err_m"),
                    "increment_z": inc_z, "increment_blocks": inc_n, "increment_blocks_better": inc_better})
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out_dir")
    ap.add_argument("--odoerr", default=os.path.join(ROOT, "build/host/tools/odoerr/odoerr"))
    ap.add_argument("--data", default=os.path.join(import_common.data_dir(), "optiodom-diff"))
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--nice", type=int, default=19)
    ap.add_argument("--min-kept", type=int, default=3,
                    help="cross check: a token kept by --with auto on at least this many runs of a path type")
    ap.add_argument("--no-cross", action="store_true", help="leave out the cross-path-type check")
    ap.add_argument("--tables-only", action="store_true",
                    help="rewrite OUT_DIR/tables.md from OUT_DIR/summary.json without running anything")
    args = ap.parse_args()
    if args.tables_only:
        with open(os.path.join(args.out_dir, "summary.json")) as f:
            sj = json.load(f)
        with open(os.path.join(args.out_dir, "tables.md"), "w") as f:
            f.write(tables_md(sj["runs"], sj["cross"], sj.get("backlash") or []))
        return 0

    if not os.path.isdir(args.data):
        print(import_common.skip_message("the OptiOdom loop", os.path.normpath(args.data)))
        sys.exit(77)
    if not (os.path.isfile(args.odoerr) and os.access(args.odoerr, os.X_OK)):
        die("no odoerr binary at %s (build it, or pass --odoerr BIN)" % args.odoerr, 2)
    importer = os.path.join(ROOT, "tools", "import", "optiodom_to_odolog.py")
    out = os.path.abspath(args.out_dir)
    for sub in ("logs", "auto", "cross"):
        os.makedirs(os.path.join(out, sub), exist_ok=True)

    runs = []
    for ptype in PATH_TYPES:
        for csv_path in sorted(glob.glob(os.path.join(args.data, ptype, "*", "*_run-*.csv"))):
            set_id = os.path.basename(os.path.dirname(csv_path))
            run_no = int(os.path.basename(csv_path).rsplit("-", 1)[1].split(".")[0])
            name = "%s_%s_run-%02d" % (ptype, set_id, run_no)
            log = os.path.join(out, "logs", name + ".odolog")
            r = subprocess.run([sys.executable, importer, csv_path, "--out", log],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            if r.returncode != 0:
                die("import failed: %s\n%s" % (csv_path, r.stderr.strip()), 1)
            j = odoerr_diagnose(args, log, os.path.join(out, "auto", name + ".json"), "auto")
            desc, cycles = describe(read_run(csv_path))
            rec = run_record(ptype, set_id, run_no, csv_path, j, desc, cycles)
            rec["name"], rec["log"] = name, log
            rec["imarkers"] = set_imarkers(os.path.dirname(csv_path))
            runs.append(rec)
            print("%s: %s; kept %s" % (name, rec["verdict"], ",".join(rec["auto_final_with"]) or "nothing"),
                  flush=True)

    cross = []
    if not args.no_cross:
        for src in PATH_TYPES:
            counts = {}
            for rec in runs:
                if rec["path_type"] == src:
                    for tok in rec["auto_final_with"]:
                        counts[tok] = counts.get(tok, 0) + 1
            tokens = sorted((t for t, n in counts.items() if n >= args.min_kept), key=lambda t: (-counts[t], t))
            for tok in tokens:
                for rec in runs:
                    if rec["path_type"] == src:
                        continue
                    safe = tok.replace("feature:", "").replace("@", "-").replace(",", "+")
                    oj = os.path.join(out, "cross", "%s__%s__%s.json" % (src, safe, rec["name"]))
                    j = odoerr_diagnose(args, rec["log"], oj, tok)
                    h = j.get("heldout")
                    d = summarise_heldout(h, (h or {}).get("paired"))
                    d.update({"source_type": src, "token": tok, "kept_on_source_runs": counts[tok],
                              "target": rec["name"], "target_type": rec["path_type"],
                              "target_motion": rec["motion"] + ("" if rec["motion"] != "straight" else
                                                                         " %.1f m" % (0.5 * round(2 * rec["travel_m"]))), "target_own_auto": rec["auto_final_with"],
                              "estimates": [f.get("after_estimate") for f in (h or {}).get("fits") or []
                                            if f.get("used")]})
                    cross.append(d)
            print("cross: %s -> others: %d tokens kept on >= %d %s runs" % (src, len(tokens), args.min_kept, src),
                  flush=True)

    backlash = [] if args.no_cross else backlash_check(args, out, runs)
    write_outputs(out, runs, cross, args, backlash)
    return 0


if __name__ == "__main__":
    sys.exit(main())

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
Written to OUT_DIR:
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

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PATH_TYPES = ("circular", "square", "ivanjko")
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


def fnum(v, fmt="%.4f"):
    return "" if v is None else fmt % v


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


def write_outputs(out, runs, cross, args, backlash):
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump({"runs": runs, "cross": cross, "backlash": backlash,
                   "options": {"threads": args.threads, "min_kept": args.min_kept}}, f, indent=1)
    cols = ["path_type", "set", "run", "motion", "duration_s", "travel_m", "rotation_deg", "net_rotation_deg",
            "mean_speed_mps", "verdict", "named", "segments", "features", "cross_drift_per_m", "change_points",
            "auto_final_with", "auto_steps_kept", "first_step_pose_z", "first_step_nll_z",
            "pose_rmse_before_m", "pose_rmse_after_m", "delta_R", "delta_L", "delta_d", "seconds"]
    with open(os.path.join(out, "runs.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in runs:
            p = r["parameters"]
            st = r["auto_steps"]
            w.writerow([r["path_type"], r["set"], r["run"], r["motion"], fnum(r["duration_s"], "%.2f"),
                        fnum(r["travel_m"], "%.3f"), fnum(r["rotation_deg"], "%.1f"), fnum(r["net_rotation_deg"], "%.1f"),
                        fnum(r["mean_speed_mps"]), r["verdict"], ";".join(n["effect"] for n in r["named"]),
                        r["segments"], ";".join("%s@%s=%.6g+-%.2g" % (x["name"], x["component"], x["coef"], x["sigma"])
                                                for x in r["features"]),
                        fnum(r["cross_drift_per_m"], "%.5f"),
                        ";".join("t=%.1f %s" % (c["t"], c["what"]) for c in r["change_points"]),
                        ",".join(r["auto_final_with"]), len(st),
                        fnum(st[0]["pose_z"], "%.2f") if st else "", fnum(st[0]["nll_z"], "%.2f") if st else "",
                        fnum(st[0]["pose_rmse_before_m"], "%.5f") if st else "",
                        fnum(st[-1]["pose_rmse_after_m"], "%.5f") if st else "",
                        *(fnum((p.get(k) or {}).get("estimate"), "%.5f") for k in ("delta_R", "delta_L", "delta_d")),
                        fnum(r["seconds"], "%.3f")])
    with open(os.path.join(out, "steps.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["path_type", "set", "run", "step", "added", "pose_z", "nll_z", "blocks", "blocks_better",
                    "pose_rmse_before_m", "pose_rmse_after_m", "nll_before", "nll_after", "folds_failed"])
        for r in runs:
            for i, s in enumerate(r["auto_steps"]):
                w.writerow([r["path_type"], r["set"], r["run"], i, s["added"], fnum(s["pose_z"], "%.2f"),
                            fnum(s["nll_z"], "%.2f"), s["blocks"], s["blocks_better"],
                            fnum(s["pose_rmse_before_m"], "%.5f"), fnum(s["pose_rmse_after_m"], "%.5f"),
                            fnum(s["nll_before"]), fnum(s["nll_after"]), s["folds_failed"]])
    with open(os.path.join(out, "cross.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["source_type", "token", "kept_on_source_runs", "target", "target_type", "target_motion",
                    "blocks", "blocks_better", "pose_z", "nll_z", "pose_rmse_before_m", "pose_rmse_after_m",
                    "folds_failed", "note", "target_own_auto"])
        for c in cross:
            w.writerow([c["source_type"], c["token"], c["kept_on_source_runs"], c["target"], c["target_type"],
                        c["target_motion"], c["blocks"], c["blocks_better"], fnum(c["pose_z"], "%.2f"),
                        fnum(c["nll_z"], "%.2f"), fnum(c["pose_rmse_before_m"], "%.5f"),
                        fnum(c["pose_rmse_after_m"], "%.5f"), c["folds_failed"], c["note"] or "",
                        ",".join(c["target_own_auto"])])
    with open(os.path.join(out, "tables.md"), "w") as f:
        f.write(tables_md(runs, cross, backlash))


def med(xs, fmt):
    xs = [x for x in xs if x is not None]
    return fmt % statistics.median(xs) if xs else "n/a"


def rng(xs, fmt):
    xs = [x for x in xs if x is not None]
    return ("%s to %s" % (fmt % min(xs), fmt % max(xs))) if xs else "n/a"


def tables_md(runs, cross, backlash=()):
    L = []
    # 1. Per path type.
    L.append("### Per path type\n")
    L.append("| path type | runs | motion | with residual segments | features found | `--with auto` kept a step "
             "| first step pose z (median, range) | held-out pose RMSE before → after (median, mm) "
             "| change points (the scan needs 40 residual segments) |")
    L.append("|---|---|---|---|---|---|---|---|---|")
    for pt in PATH_TYPES:
        for motion in ("turning", "straight", "rotation"):
            rs = [r for r in runs if r["path_type"] == pt and r["motion"] == motion]
            if not rs:
                continue
            seg = [r for r in rs if (r["segments"] or 0) > 0]
            found = [r for r in rs if r["features"]]
            kept = [r for r in rs if r["auto_steps"]]
            z1 = [r["auto_steps"][0]["pose_z"] for r in kept]
            b = [1e3 * r["auto_steps"][0]["pose_rmse_before_m"] for r in kept
                 if r["auto_steps"][0]["pose_rmse_before_m"] is not None]
            a = [1e3 * r["auto_steps"][-1]["pose_rmse_after_m"] for r in kept
                 if r["auto_steps"][-1]["pose_rmse_after_m"] is not None]
            cps = sum(len(r["change_points"]) for r in rs)
            scanned = sum(1 for r in rs if (r["segments"] or 0) >= 40)  # the scan needs 40 segments
            cp_txt = (str(cps) if cps else "none found") + (" (%d runs scanned)" % scanned) if scanned else \
                "not scanned (under 40 segments)"
            L.append("| %s | %d | %s, %s s, %s m | %d | %d | %d | %s | %s → %s | %s |" % (
                pt, len(rs), motion, rng([r["duration_s"] for r in rs], "%.0f"),
                rng([r["travel_m"] for r in rs], "%.2f"), len(seg), len(found), len(kept),
                ("%s (%s)" % (med(z1, "%.1f"), rng(z1, "%.1f"))) if z1 else "no step kept",
                med(b, "%.1f") if b else "—", med(a, "%.1f") if a else "—", cp_txt))
    L.append("")
    # 2. Discovered features by path type.
    L.append("### What discovery found (the model's residual features, `unexplained.features`)\n")
    L.append("| path type | feature (target) | runs | coefficient range | sign |")
    L.append("|---|---|---|---|---|")
    for pt in PATH_TYPES:
        tally = {}
        for r in runs:
            if r["path_type"] != pt:
                continue
            for x in r["features"]:
                tally.setdefault("%s@%s" % (x["name"], x["component"]), []).append(x["coef"])
        for k, v in sorted(tally.items(), key=lambda kv: (-len(kv[1]), kv[0])):
            sign = "+" if all(c > 0 for c in v) else ("−" if all(c < 0 for c in v) else "mixed")
            L.append("| %s | `%s` | %d | %s | %s |" % (pt, k, len(v), rng(v, "%.4g"), sign))
    L.append("")
    # 3. The sideways drift in one unit.
    L.append("### The sideways drift, in one unit\n")
    L.append("The `cross` terms found, converted to the sideways displacement they make per metre of "
             "travel over the analysed part of each run (left positive; `cross_drift_per_m`).\n")
    L.append("| path type | set | runs with a cross term | drift per m of travel, each run (mm/m) | median (mm/m) |")
    L.append("|---|---|---|---|---|")
    for pt in PATH_TYPES:
        for s in sorted({r["set"] for r in runs if r["path_type"] == pt}):
            rs = [r for r in runs if r["path_type"] == pt and r["set"] == s]
            d = [r["cross_drift_per_m"] for r in rs if r["cross_drift_per_m"] is not None]
            if not d:
                continue
            L.append("| %s | %s | %d of %d | %s | %s |" % (
                pt, s, len(d), len(rs), ", ".join("%+.1f" % (1e3 * x) for x in d), med([1e3 * x for x in d], "%+.1f")))
    L.append("")
    L.append("By turn direction (the sign of the run's net rotation; CCW = positive) and recording day "
             "(the set id's first 8 digits, ddmmyyyy):\n")
    L.append("| path type | day | direction | runs with a cross term | median drift (mm/m) | range (mm/m) "
             "| mean curvature (rad/m) |")
    L.append("|---|---|---|---|---|---|---|")
    for pt in ("circular", "square"):
        for day in sorted({r["set"][:8] for r in runs if r["path_type"] == pt}):
            for dname, sgn in (("CW", -1), ("CCW", 1)):
                rs = [r for r in runs if r["path_type"] == pt and r["set"][:8] == day
                      and r["net_rotation_deg"] * sgn > 0 and r["cross_drift_per_m"] is not None]
                if not rs:
                    continue
                d = [1e3 * r["cross_drift_per_m"] for r in rs]
                k = [math.radians(r["net_rotation_deg"]) / r["travel_m"] for r in rs]
                L.append("| %s | %s | %s | %d | %s | %s | %s |" % (pt, day, dname, len(rs), med(d, "%+.1f"),
                                                                   rng(d, "%+.1f"), med(k, "%+.2f")))
    L.append("")
    L.append("### Drive parameters (`baseline.parameters`), median and range over the runs\n")
    L.append("| path type | motion | runs | δ_R | δ_L | δ_d |")
    L.append("|---|---|---|---|---|---|")
    for pt in PATH_TYPES:
        for motion in ("turning", "straight", "rotation"):
            rs = [r for r in runs if r["path_type"] == pt and r["motion"] == motion]
            if not rs:
                continue
            cells = []
            for k in ("delta_R", "delta_L", "delta_d"):
                v = [(r["parameters"].get(k) or {}).get("estimate") for r in rs]
                cells.append("%s (%s)" % (med(v, "%.4f"), rng(v, "%.4f")))
            L.append("| %s | %s | %d | %s |" % (pt, motion, len(rs), " | ".join(cells)))
    L.append("| authors' calibration (README) | | | 0.99544 | 0.99610 | 1.00192 |")
    L.append("")
    # 4. Per run.
    L.append("### Every run\n")
    L.append("| run | motion, s, m | verdict | discovered (coef ± sigma) | `auto.final_with` | pose z / NLL z per step "
             "| pose RMSE before → after (mm) | δ_R, δ_L, δ_d | s |")
    L.append("|---|---|---|---|---|---|---|---|---|")
    for r in runs:
        feats = "; ".join("`%s@%s` %.3g ± %.2g" % (x["name"], x["component"], x["coef"], x["sigma"]) for x in r["features"])
        if not feats:
            feats = "nothing (no residual segment)" if not r["segments"] else "nothing"
        if r["named"]:
            feats = "named: %s; %s" % (", ".join(n["effect"] for n in r["named"]), feats)
        st = r["auto_steps"]
        zs = "; ".join("%s / %s" % (fnum(s["pose_z"], "%.1f"), fnum(s["nll_z"], "%.1f")) for s in st)
        rm = ("%.1f → %.1f" % (1e3 * st[0]["pose_rmse_before_m"], 1e3 * st[-1]["pose_rmse_after_m"])) if st else ""
        p = r["parameters"]
        L.append("| %s %s r%02d | %s, %.0f, %.2f | %s | %s | %s | %s | %s | %s | %.2f |" % (
            r["path_type"], r["set"], r["run"], r["motion"], r["duration_s"], r["travel_m"], r["verdict"], feats,
            " ".join("`%s`" % t.replace("feature:", "") for t in r["auto_final_with"]) or "—", zs or "—", rm or "—",
            ", ".join(fnum((p.get(k) or {}).get("estimate"), "%.4f") for k in ("delta_R", "delta_L", "delta_d")),
            r["seconds"] or 0))
    L.append("")
    # 5. Cross-path-type.
    if cross:
        L.append("### Cross-path-type: a form kept on one path type, tested on the others\n")
        L.append("| chosen on (runs kept) | token | tested on | runs | with held-out blocks | pose z ≤ −2 | NLL z ≤ −2 "
                 "| either rises z ≥ +2 | held-out blocks per run | pose z median (range) | pose RMSE before → after, median (mm) |")
        L.append("|---|---|---|---|---|---|---|---|---|---|---|")
        keys = []
        for c in cross:
            k = (c["source_type"], c["token"], c["target_type"], c["target_motion"])
            if k not in keys:
                keys.append(k)
        no_block = {}
        for k in keys:
            cs = [c for c in cross if (c["source_type"], c["token"], c["target_type"], c["target_motion"]) == k]
            ev = [c for c in cs if (c["blocks"] or 0) > 0 and c["pose_z"] is not None]
            if not ev:
                no_block.setdefault((k[2], k[3]), len(cs))
                continue
            pz = [c["pose_z"] for c in ev]
            fall_p = sum(1 for c in ev if c["pose_z"] <= -2)
            fall_n = sum(1 for c in ev if c["nll_z"] is not None and c["nll_z"] <= -2)
            rise = sum(1 for c in ev if (c["pose_z"] >= 2) or (c["nll_z"] is not None and c["nll_z"] >= 2))
            b = [1e3 * c["pose_rmse_before_m"] for c in ev if c["pose_rmse_before_m"] is not None]
            a = [1e3 * c["pose_rmse_after_m"] for c in ev if c["pose_rmse_after_m"] is not None]
            L.append("| %s (%d) | `%s` | %s %s | %d | %d | %s | %s | %s | %s | %s | %s |" % (
                k[0], cs[0]["kept_on_source_runs"], k[1].replace("feature:", ""), k[2], k[3], len(cs), len(ev),
                fall_p if ev else "—", fall_n if ev else "—", rise if ev else "—",
                rng([c["blocks"] for c in ev], "%d") if ev else "0",
                ("%s (%s)" % (med(pz, "%.1f"), rng(pz, "%.1f"))) if ev else "no held-out block",
                ("%s → %s" % (med(b, "%.1f"), med(a, "%.1f"))) if b and a else "n/a"))
        L.append("")
        for (tt, tm), n in no_block.items():
            L.append("Not in the table: the %d %s %s runs, which have no held-out block (no comparison "
                     "is possible there).\n" % (n, tt, tm))
        # Which single form predicts best, per target run.
        L.append("### Which form predicts best on each run (lowest held-out pose RMSE among the tokens "
                 "tested on it; ties count for each)\n")
        L.append("| tested on | runs | wins per token |")
        L.append("|---|---|---|")
        groups = {}
        for c in cross:
            if (c["blocks"] or 0) > 0 and c["pose_rmse_after_m"] is not None:
                groups.setdefault((c["target_type"], c["target_motion"]), {}).setdefault(c["target"], []).append(c)
        for (tt, tm), byrun in groups.items():
            wins = {}
            for cs in byrun.values():
                best = min(c["pose_rmse_after_m"] for c in cs)
                for c in cs:
                    if c["pose_rmse_after_m"] <= best + 1e-12:
                        t = c["token"].replace("feature:", "")
                        wins[t] = wins.get(t, 0) + 1
            L.append("| %s %s | %d | %s |" % (tt, tm, len(byrun), ", ".join(
                "`%s` %d" % kv for kv in sorted(wins.items(), key=lambda kv: -kv[1]))))
        L.append("")
        # One form on every run: the sideways drift as `ds@cross`, re-fitted per run.
        L.append("### One form on every run: `ds@cross` re-fitted on each run's own data\n")
        L.append("The coefficient (m of sideways travel, left positive, per m of travel; shown in mm/m) that "
                 "the held-out comparison's fits found, the median of a run's fold fits, then the median "
                 "and range over the runs.\n")
        L.append("| path type | motion | day | metadata `imarkers` | direction | runs | median (mm/m) | range (mm/m) |")
        L.append("|---|---|---|---|---|---|---|---|")
        rows, seen = {}, set()
        for c in cross:
            if c["token"] != "feature:ds@cross" or not c["estimates"] or c["target"] in seen:
                continue  # the fit on a run does not depend on where the token was chosen
            seen.add(c["target"])
            v = sorted(e["feature_motion"][0] for e in c["estimates"] if e and e.get("feature_motion"))
            if not v:
                continue
            run = next(r for r in runs if r["name"] == c["target"])
            dname = "CW" if run["net_rotation_deg"] < -45 else ("CCW" if run["net_rotation_deg"] > 45 else "—")
            rows.setdefault((run["path_type"], c["target_motion"], run["set"][:8], run.get("imarkers") or "?", dname),
                            []).append(
                1e3 * statistics.median(v))
        for k in sorted(rows):
            L.append("| %s | %s | %s | %s | %s | %d | %s | %s |" % (*k, len(rows[k]), med(rows[k], "%+.1f"),
                                                               rng(rows[k], "%+.1f")))
        L.append("")
    if backlash:
        L.append("### Square runs: the catalogue's `wheel_backlash`\n")
        L.append("(a) `--with wheel_backlash` against the model as it is (diagnose's paired z); (b) on top of "
                 "`ds@cross`: held-out pose RMSE with `ds@cross` alone and with both, and the increment's "
                 "paired z over the blocks, computed by the script from the per-scan held-out files "
                 "(`check z` is the same computation for `ds@cross` against the model as it is, which must "
                 "equal diagnose's own z).\n")
        L.append("| run | dir | b_R, b_L (mm, median of fold fits) | (a) pose z / NLL z | (a) RMSE before → after (mm) "
                 "| (b) RMSE ds@cross → + wheel_backlash (mm) | increment z (blocks better) | check z: tool / script |")
        L.append("|---|---|---|---|---|---|---|---|")
        for b in backlash:
            L.append("| %s | %s | %s, %s | %s / %s | %s → %s | %s → %s | %s (%d of %d) | %s / %s |" % (
                b["run"].replace("square_", "").replace("_run-", " r"), b["direction"],
                fnum(b["b_R"] and 1e3 * b["b_R"], "%.1f"), fnum(b["b_L"] and 1e3 * b["b_L"], "%.1f"),
                fnum(b["wb_pose_z"], "%.1f"), fnum(b["wb_nll_z"], "%.1f"),
                fnum(b["wb_rmse_before_m"] and 1e3 * b["wb_rmse_before_m"], "%.2f"),
                fnum(b["wb_rmse_after_m"] and 1e3 * b["wb_rmse_after_m"], "%.2f"),
                fnum(b["ds_rmse_after_m"] and 1e3 * b["ds_rmse_after_m"], "%.2f"),
                fnum(b["wb_ds_rmse_after_m"] and 1e3 * b["wb_ds_rmse_after_m"], "%.2f"),
                fnum(b["increment_z"], "%.1f"), b["increment_blocks_better"], b["increment_blocks"],
                fnum(b["ds_pose_z_tool"], "%.2f"), fnum(b["ds_pose_z_script"], "%.2f")))
        L.append("")
    return "\n".join(L) + "\n"


if __name__ == "__main__":
    sys.exit(main())

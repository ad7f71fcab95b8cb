"""optiodom_loop_tables.py: what run_optiodom_loop.py writes to OUT_DIR: summary.json,
runs.csv, steps.csv, cross.csv and tables.md (the tables of docs/real-data.md), from the
records the loop collected (run_optiodom_loop.py's docstring lists the columns' meaning)."""

import csv
import json
import math
import os
import statistics

from import_common import OPTIODOM_PATH_TYPES as PATH_TYPES


def fnum(v, fmt="%.4f"):
    return "" if v is None else fmt % v


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


def by_type_and_motion(runs):
    """(path type, motion, its runs) for each pair that has runs, in the tables' order."""
    for pt in PATH_TYPES:
        for motion in ("turning", "straight", "rotation"):
            rs = [r for r in runs if r["path_type"] == pt and r["motion"] == motion]
            if rs:
                yield pt, motion, rs


def tables_md(runs, cross, backlash=()):
    L = []
    # 1. Per path type.
    L.append("### Per path type\n")
    L.append("| path type | runs | motion | with residual segments | features found | `--with auto` kept a step "
             "| first step pose z (median, range) | held-out pose RMSE before → after (median, mm) "
             "| change points (the scan needs 40 residual segments) |")
    L.append("|---|---|---|---|---|---|---|---|---|")
    for pt, motion, rs in by_type_and_motion(runs):
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
        cp_txt = ("%s (%d runs scanned)" % (cps or "none found", scanned) if scanned
                  else "not scanned (under 40 segments)")
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
    for pt, motion, rs in by_type_and_motion(runs):
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


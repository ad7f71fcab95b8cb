#!/usr/bin/env python3
"""Checks an `odoerr paper` output directory: summary.json has exactly the documented shape,
and (with --acceptance) the 30 m figures lie in the ranges of the issue's acceptance; with
--k-acceptance, K meets issue 15's acceptance at 30 m from both starts: mean within 5 % of the
truth, accuracy within 1.5x bound_pct (K's with delta unknown, as the AKF estimates it),
reported sigma within 1.5x of the spread."""
import argparse
import json
import math
import os
import sys

SYNC = ["delta_rho", "E_theta", "K_rho", "K_theta"]
DIFF = ["delta_R", "delta_L", "delta_d", "K_w"]
fails = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        fails.append(what)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--drive", required=True, choices=["sync", "diff"])
    ap.add_argument("--runs", type=int, required=True)
    ap.add_argument("--acceptance", action="store_true")
    ap.add_argument("--k-acceptance", action="store_true", help="issue 15's acceptance for K")
    ap.add_argument("--plots", action="store_true", help="also require the PNG figures")
    ap.add_argument("--max-pos-err", type=float, help="every run's position error at its end within this (m): none lost")
    a = ap.parse_args()
    with open(os.path.join(a.dir, "summary.json")) as f:
        s = json.load(f)
    names = SYNC if a.drive == "sync" else DIFF
    keys = {"drive", "runs", "of", "path", "radius_m", "wall_time_s", "bound", "cases"}
    check(isinstance(s.get("wall_time_s"), (int, float)) and s["wall_time_s"] >= 0, "wall_time_s a duration")
    check(set(s) == (keys | {"ml"} if s.get("of") == "ml" else keys), "top-level keys")
    if s.get("of") == "ml":
        check(set(s["ml"]) == {"every", "solve_iters", "reset_log", "inflate", "inflate_held", "inflate_cap", "start_inflate_cap", "form", "discount",
                                "discount_above", "credit", "reset_keep", "shift", "deflate", "heading_scale"}
              and s["ml"]["form"] in ("pose", "scan", "beam") and s["ml"]["shift"] in ("scale", "line"),
              "ml settings")
    check(s["path"] in ("circle", "eight"), "path is circle or eight")
    check(0 < s["radius_m"] <= (5 if s["path"] == "circle" else 2.5), "radius inside the room")
    check(s["of"] in ("paper", "ml"), "of is paper or ml")
    check(s["drive"] == a.drive and s["runs"] == a.runs, "drive and runs")
    check([c["init"] for c in s["cases"]] == ["small", "large"], "cases small, large")
    for c in s["cases"]:
        check(set(c) == {"init", "checkpoints"}, "case keys")
        check([cp["distance_m"] for cp in c["checkpoints"]] == [5.0, 10.0, 20.0, 30.0], "checkpoints")
        for cp in c["checkpoints"]:
            check(set(cp) == {"distance_m", "params", "pose_rms"}, "checkpoint keys")
            check(sorted(cp["params"]) == sorted(names), "parameter names")
            for v in cp["params"].values():
                check(set(v) == {"true", "mean", "accuracy_pct", "bound_pct", "bound_pct_joint", "bound_pct_known", "rmse",
                                    "sigma_mean", "sigma_ratio"},
                      "parameter keys")
                check(all(math.isfinite(x) for k, x in v.items() if k != "sigma_ratio"), "finite values")
                # sigma honesty: mean reported sigma over the spread across runs (null: no spread)
                sd = v["accuracy_pct"] / 100 * abs(v["mean"])
                if sd > 0:
                    check(v["sigma_ratio"] is not None and abs(v["sigma_ratio"] - v["sigma_mean"] / sd) <= 1e-6 * v["sigma_ratio"],
                          "sigma_ratio = sigma_mean / spread")
                check(v["sigma_mean"] >= 0, "sigma_mean not negative")
                check(v["bound_pct"] > 0 and v["bound_pct_joint"] > 0 and v["bound_pct_known"] > 0, "positive bounds")
            check(set(cp["pose_rms"]) == {"position_m", "orientation_rad"}, "pose_rms keys")
    csv = os.path.join(a.dir, f"paper_{a.drive}.csv")
    check(os.path.getsize(csv) > 1000, "CSV written")
    # runs_<drive>.csv: one row per run and start, each run's last record
    with open(os.path.join(a.dir, f"runs_{a.drive}.csv")) as f:
        lines = f.read().splitlines()
    head = lines[0].split(",")
    check(head[:3] == ["init", "run", "seed"] and head[3:3 + len(names)] == names, "runs CSV header")
    check(len(lines) == 1 + 2 * a.runs, f"runs CSV rows {len(lines) - 1} (2 x {a.runs})")
    for ln in lines[1:]:
        cells = ln.split(",")
        check(len(cells) == len(head) and all(math.isfinite(float(x)) for x in cells[3:]), "runs CSV row")
    if a.max_pos_err is not None:
        ip = head.index("pos_err_m")
        for ln in lines[1:]:
            cells = ln.split(",")
            check(float(cells[ip]) <= a.max_pos_err,
                  f"[{cells[0]}] seed {cells[2]}: position error {float(cells[ip]):.3f} m (at most {a.max_pos_err} m)")
    for c in s["cases"]:
        # the summary's mean at 30 m is the mean of the runs' last values
        rows = [ln.split(",") for ln in lines[1:] if ln.startswith(c["init"] + ",")]
        n0 = names[0]
        mu = sum(float(r[3]) for r in rows) / len(rows)
        check(abs(mu - c["checkpoints"][-1]["params"][n0]["mean"]) <= 1e-6 * abs(mu), "runs CSV agrees with the summary")
    if a.plots:
        fig = "fig1_sync.png" if a.drive == "sync" else "fig2_diff.png"
        for png in (fig, f"pose_{a.drive}.png"):
            p = os.path.join(a.dir, png)
            check(os.path.exists(p) and open(p, "rb").read(8) == b"\x89PNG\r\n\x1a\n", png + " is a PNG")
    if a.acceptance:
        deg = math.pi / 180
        for c in s["cases"]:
            cp = c["checkpoints"][-1]
            p = cp["params"]
            pos, ori = cp["pose_rms"]["position_m"], cp["pose_rms"]["orientation_rad"]
            tag = f"[{c['init']}] "
            if a.drive == "sync":
                check(abs(p["delta_rho"]["mean"] - 1.1) <= 0.003, tag + f"delta_rho mean {p['delta_rho']['mean']:.4f}")
                check(p["delta_rho"]["accuracy_pct"] <= 0.9, tag + f"delta_rho accuracy {p['delta_rho']['accuracy_pct']:.2f} %")
                et = p["E_theta"]["mean"] / deg
                check(abs(et - 1.0) <= 0.08, tag + f"E_theta mean {et:.3f} deg/m")
                check(15 <= p["E_theta"]["accuracy_pct"] <= 25, tag + f"E_theta accuracy {p['E_theta']['accuracy_pct']:.1f} %")
                check(pos <= 0.007 and ori <= 0.12 * deg, tag + f"pose RMS {pos*100:.3f} cm {ori/deg:.3f} deg")
            else:
                for n, t in (("delta_R", 1.1), ("delta_L", 0.9)):
                    check(abs(p[n]["mean"] / t - 1) <= 0.005, tag + f"{n} mean {p[n]['mean']:.4f}")
                    check(p[n]["accuracy_pct"] <= 1.5, tag + f"{n} accuracy {p[n]['accuracy_pct']:.2f} %")
                check(5 <= p["delta_d"]["accuracy_pct"] <= 30, tag + f"delta_d accuracy {p['delta_d']['accuracy_pct']:.1f} % (large: not separable on a circle)")
                check(pos <= 0.006 and ori <= 0.12 * deg, tag + f"pose RMS {pos*100:.3f} cm {ori/deg:.3f} deg")
            for n in names[-2:] if a.drive == "sync" else names[-1:]:
                r = p[n]["mean"] / p[n]["true"]
                check(0.1 < r < 3.0, tag + f"{n} {r:.2f}x truth (paper's OF: slow and biased, reported)")
            # The bound (odoerr bound) at 30 m: the AKF is efficient for the systematic
            # parameters, so their spread over runs sits at the bound (0.7-1.5x: 100 runs give
            # the spread to about 7 %); K's bound near the independent numpy oracle's figures.
            for n in names[:-2] if a.drive == "sync" else names[:-1]:
                q = p[n]["accuracy_pct"] / p[n]["bound_pct"]
                check(0.7 <= q <= 1.5, tag + f"{n} accuracy {q:.2f}x its bound {p[n]['bound_pct']:.3g} %")
            # The oracle held delta known: bound_pct_known. bound_pct (delta unknown, as the
            # AKF estimates it) is never below it.
            ranges = {"K_rho": (6, 11), "K_theta": (3, 6), "K_w": (2, 4.5)}
            for n in names[-2:] if a.drive == "sync" else names[-1:]:
                lo, hi = ranges[n]
                bk = p[n]["bound_pct_known"]
                check(lo <= bk <= hi, tag + f"{n} bound with delta known {bk:.2f} % (oracle range {lo}-{hi} %)")
                check(p[n]["bound_pct"] >= 0.99 * bk, tag + f"{n} bound {p[n]['bound_pct']:.2f} % not below {bk:.2f} %")
        # Speed is reported, not asserted (a timed check fails on a loaded machine, and
        # benchmarks measure it: docs/performance.md).
        print(f"wall time {s['wall_time_s']} s for {a.runs} runs x 2 starts")
    if a.k_acceptance:
        for c in s["cases"]:
            p = c["checkpoints"][-1]["params"]
            tag = f"[{c['init']}] "
            for n in names[-2:] if a.drive == "sync" else names[-1:]:
                v = p[n]
                r = v["mean"] / v["true"]
                # K's bound_pct holds delta unknown, as the AKF estimates it; the bound with
                # delta known leaves out K_w's coupling to delta_d through the heading noise
                # (docs/nonsystematic.md, "K with delta unknown").
                bound = v["bound_pct"]
                q = v["accuracy_pct"] / bound
                check(abs(r - 1) <= 0.05, tag + f"{n} mean {r:.3f}x the truth (within 5 %)")
                check(q <= 1.5, tag + f"{n} accuracy {v['accuracy_pct']:.2f} % = {q:.2f}x its bound {bound:.2f} % (within 1.5x)")
                sr = v["sigma_ratio"]
                check(sr is not None and 1 / 1.5 <= sr <= 1.5, tag + f"{n} sigma {sr}x the spread (within 1.5x)")
    print(f"{len(fails)} failed" if fails else "all checks passed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())

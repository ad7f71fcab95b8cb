#!/usr/bin/env python3
"""beams_vs_estimate.py: the estimate against the number of beams the filter fuses per scan
(docs/performance.md, "Beams used").

For each map (the room and the synthetic office of firmware/maps) and seed, one drive with
the 181-beam laser is simulated once (`odoerr sim --map`), then replayed with each beam
count (`odoerr replay --beams-used N`; 0 = all 181). Prints a Markdown table: pose and
heading RMSE against truth, and the error of the systematic parameters in units of their
own sigma, averaged over seeds.

Usage: beams_vs_estimate.py ODOERR_BINARY FIRMWARE_MAPS_BUILD_DIR [--seeds N] [--steps N]
  (FIRMWARE_MAPS_BUILD_DIR: build/host/firmware/maps, where the office map is generated)
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

BEAMS = [0, 90, 48, 36, 24, 20, 12, 6]


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"beams_vs_estimate: {' '.join(cmd)} failed: {r.stderr[-400:]}")


def truth_params(log):
    with open(log) as f:
        for line in f:
            if line.startswith("meta truth"):
                return {k: float(v) for k, v in (kv.split("=") for kv in line.split()[2:])}
    sys.exit(f"beams_vs_estimate: {log} has no 'meta truth' line")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("odoerr")
    ap.add_argument("maps_dir")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--steps", type=int, default=6000)
    a = ap.parse_args()
    src = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "firmware", "maps")
    maps = {"room": (os.path.join(src, "room.odomap"), os.path.join(src, "room.path")),
            "office": (os.path.join(a.maps_dir, "office.odomap"), os.path.join(a.maps_dir, "office.path"))}
    work = tempfile.mkdtemp(prefix="beams_")
    print("| map | beams used per scan | pose RMSE (mm) | heading RMSE (mrad) | max abs error of delta_R, delta_L, delta_d (sigma) | beams gated (%) |")
    print("|---|---|---|---|---|---|")
    for name, (mp, path) in maps.items():
        rows = {b: [] for b in BEAMS}
        for seed in range(1, a.seeds + 1):
            log = os.path.join(work, f"{name}_{seed}.odolog")
            run([a.odoerr, "sim", "--map", mp, "--path", path, "--loop", "--steps", str(a.steps),
                 "--seed", str(seed), "--out", log])
            truth = truth_params(log)
            for b in BEAMS:
                out = os.path.join(work, f"{name}_{seed}_{b}")
                run([a.odoerr, "replay", log, "--out", out, "--beams-used", str(b)])
                d = json.load(open(os.path.join(out, "replay.json")))
                z = max(abs(d["final"][k]["estimate"] - truth[k]) / d["final"][k]["sigma"]
                        for k in ("delta_R", "delta_L", "delta_d"))
                gated = d["beams_gated"] / max(1, d["beams_used"] + d["beams_gated"])
                rows[b].append((d["pose_rmse_m"], d["heading_rmse_rad"], z, gated))
        for b in BEAMS:
            r = rows[b]
            n = len(r)
            print(f"| {name} | {b if b else 181} | {1e3 * sum(x[0] for x in r) / n:.1f} | "
                  f"{1e3 * sum(x[1] for x in r) / n:.2f} | {max(x[2] for x in r):.1f} | {100 * sum(x[3] for x in r) / n:.2f} |")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Checks diagnose's detection power (docs/diagnostics.md, "Detection power") by simulation.

    check_power.py ODOERR WORKDIR [--drive diff] [--seeds 1,2,...] [--families turn_slip,...]
                   [--multiples 0.5,1,2] [--json OUT]

For each seed, a clean `odoerr sim --scenario excite` drive is diagnosed; its
detection_power gives each family's smallest detectable size (80 % power) for the first
parameter. The same drive (same seed, same motion) is then simulated with that family's
first parameter at a multiple of the size, and diagnosed. Detected: the verdict is no longer
"consistent" (the claim the size bounds); the fraction of seeds detected, per multiple, is the
measured power. At 1x it should be near the stated power; well below 1x rarely detected, well
above almost always. Identified: the family is named, or is in the confusable group of an
effect named (range_bias, range_scale and wall_offset explain each other on these drives).

Checks (exit 1 when one fails): the clean drives name nothing and say "consistent: nothing
larger than"; at the largest multiple (>= 2) every family is detected and identified on at
least 80 % of the seeds; at the smallest (<= 0.5) detected on at most 40 %. Prints one line
per run and a table.
"""
import argparse
import json
import os
import subprocess
import sys


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("command failed (%d): %s\n%s" % (r.returncode, " ".join(cmd), r.stderr))
    return r


def diagnose(odoerr, log):
    out = log + ".json"
    run([odoerr, "diagnose", log, "--json", out])
    with open(out) as f:
        return json.load(f)


def first_mde(j, family):
    for f in j["detection_power"]["families"]:
        if f["family"] == family:
            for p in f["parameters"]:
                return p["min_detectable"], len(f["parameters"])
    return None, 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("odoerr")
    ap.add_argument("workdir")
    ap.add_argument("--drive", default="diff", choices=["diff", "sync"])
    ap.add_argument("--seeds", default="1,2,3,4,5,6,7,8,9,10")
    ap.add_argument("--families", default="turn_slip,backlash,speed_scale,range_bias")
    ap.add_argument("--multiples", default="0.5,1,2")
    ap.add_argument("--json", help="write the measured table here")
    a = ap.parse_args()
    seeds = [int(s) for s in a.seeds.split(",")]
    fams = a.families.split(",")
    mults = [float(m) for m in a.multiples.split(",")]
    os.makedirs(a.workdir, exist_ok=True)
    fails = []
    named = {(f, m): 0 for f in fams for m in mults}
    ident = {(f, m): 0 for f in fams for m in mults}
    tried = {(f, m): 0 for f in fams for m in mults}
    for s in seeds:
        clean = os.path.join(a.workdir, f"clean-{a.drive}-{s}.odolog")
        run([a.odoerr, "sim", "--scenario", "excite", "--drive", a.drive, "--seed", str(s), "--out", clean])
        j = diagnose(a.odoerr, clean)
        sig = [r["effect"] for r in j["ranking"] if r["significant"]]
        detail = j.get("verdict_detail", "")
        print(f"clean seed {s}: verdict {j['verdict']}, named {sig or 'none'}; {detail[:100]}...")
        if j["verdict"] != "consistent" or not detail.startswith("consistent: nothing larger than"):
            fails.append(f"clean seed {s}: verdict {j['verdict']}, detail '{detail[:60]}'")
            continue
        for fam in fams:
            mde, n = first_mde(j, fam)
            if mde is None:
                print(f"  {fam}: not excited on seed {s}")
                continue
            for m in mults:
                vals = [m * mde] + [0.0] * (n - 1)
                log = os.path.join(a.workdir, f"{fam}-{m:g}-{a.drive}-{s}.odolog")
                run([a.odoerr, "sim", "--drive", a.drive, "--seed", str(s), "--effect",
                     fam + "=" + ",".join(f"{v:.6g}" for v in vals), "--out", log])
                jj = diagnose(a.odoerr, log)
                row = next(r for r in jj["ranking"] if r["effect"] == fam)
                detected = jj["verdict"] != "consistent"
                idf = row["significant"] or any(r["significant"] and fam in r["confused_with"] for r in jj["ranking"])
                tried[(fam, m)] += 1
                named[(fam, m)] += 1 if detected else 0
                ident[(fam, m)] += 1 if idf else 0
                print(f"  {fam} {m:g}x ({vals[0]:.4g}): verdict {jj['verdict']}, identified {idf}, "
                      f"estimate {row['estimate'][0]:.4g} +- {row['sigma'][0]:.2g}")
    print("\nfamily      " + "".join(f"{m:>8g}x" for m in mults) + "   (fraction of seeds detected / identified)")
    table = {}
    for fam in fams:
        fr = [named[(fam, m)] / tried[(fam, m)] if tried[(fam, m)] else float("nan") for m in mults]
        fi = [ident[(fam, m)] / tried[(fam, m)] if tried[(fam, m)] else float("nan") for m in mults]
        table[fam] = {"detected": dict(zip([f"{m:g}" for m in mults], fr)),
                      "identified": dict(zip([f"{m:g}" for m in mults], fi)), "seeds": tried[(fam, mults[0])]}
        print(f"{fam:12s}" + "".join(f"{x:5.2f}/{y:4.2f}" for x, y in zip(fr, fi)) +
              f"   (of {tried[(fam, mults[0])]} seeds)")
        lo, hi = min(mults), max(mults)
        if hi >= 2 and tried[(fam, hi)] and min(named[(fam, hi)], ident[(fam, hi)]) / tried[(fam, hi)] < 0.8:
            fails.append(f"{fam}: detected on {named[(fam, hi)]}, identified on {ident[(fam, hi)]} of "
                         f"{tried[(fam, hi)]} seeds at {hi:g}x the stated size")
        if lo <= 0.5 and tried[(fam, lo)] and named[(fam, lo)] / tried[(fam, lo)] > 0.4:
            fails.append(f"{fam}: detected on {named[(fam, lo)]} of {tried[(fam, lo)]} seeds at {lo:g}x the stated size")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"drive": a.drive, "seeds": seeds, "power_named": table}, f, indent=2)
    for x in fails:
        print("FAIL: " + x)
    print(f"check_power: {'FAIL' if fails else 'ok'}")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Impossible and empty logs through the host tools (docs/odolog.md, "Plausibility";
docs/diagnostics.md, "Empty data").

  check_impossible.py ODOERR WORKDIR

1. A 2-minute simulated drive (excite, seed 5) and the same drive with the right wheel's
   count jumping by 1,000,000 ticks (77 m) at its middle `enc` record, the later counts
   carried on from there: the jump is rejected, once, at that line (replay.json,
   diagnose's JSON and verdict_caveats, both printed summaries); the replay's pose RMSE
   stays within 1.5x of the clean drive's; diagnose names no effect the clean drive does
   not name.
2. The same drive with one record at the integer limits (A = 2^63 - 1, B = -2^63): both
   channels rejected at its line; every parameter sigma the replay prints is below 100
   (the map is 10 m across).
3. The drive with every range of every scan `nan`: diagnose's verdict is "insufficient
   data" with what is missing, exit status 3, no NIS band.

Prints one line per check; exits 1 when one fails.
"""
import json
import os
import subprocess
import sys


def run(cmd, expect=0):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != expect:
        sys.exit("exit %d (expected %d): %s\n%s" % (r.returncode, expect, " ".join(cmd), r.stderr[-2000:]))
    return r


def rewrite(src, dst, edit):
    """Copies an odolog, passing each `enc` record's (index, line number, fields) to edit."""
    with open(src) as f:
        lines = f.readlines()
    enc = [i for i, s in enumerate(lines) if s.startswith("enc ")]
    out = []
    for i, s in enumerate(lines):
        if s.startswith("enc "):
            f = s.split()
            s = edit(enc.index(i), i + 1, f, len(enc)) or s
        out.append(s)
    with open(dst, "w") as f:
        f.writelines(out)


def main():
    odoerr, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    fails = []

    def check(what, ok, detail=""):
        print(("ok   " if ok else "FAIL ") + what + (": " + detail if detail else ""))
        if not ok:
            fails.append(what)

    clean = os.path.join(work, "clean.odolog")
    run([odoerr, "sim", "--scenario", "excite", "--drive", "diff", "--minutes", "2", "--seed", "5", "--out", clean])

    # 1. the 77 m jump
    jump = os.path.join(work, "jump.odolog")
    where = {}

    def add_jump(k, line, f, n):
        if k >= n // 2:
            where.setdefault("line", line)
            return "enc %s %d %s\n" % (f[1], int(f[2]) + 1000000, f[3])
        return None
    rewrite(clean, jump, add_jump)
    reps = {}
    for name, log in (("clean", clean), ("jump", jump)):
        r = run([odoerr, "replay", log, "--out", os.path.join(work, "rp-" + name)])
        with open(os.path.join(work, "rp-" + name, "replay.json")) as f:
            reps[name] = (json.load(f), r.stderr)
    rej = reps["jump"][0]["encoder_rejections"]
    first = rej["first"][0] if rej["first"] else {}
    check("jump: one increment rejected, channel A, at its line",
          rej["count"] == 1 and first.get("channel") == "A" and first.get("line") == where["line"],
          "count %d, first %s, jump at line %d" % (rej["count"], first, where["line"]))
    check("jump: the replay's summary says so", "1 encoder increment rejected" in reps["jump"][1],
          reps["jump"][1].strip().splitlines()[-1] if reps["jump"][1].strip() else "")
    check("clean: nothing rejected", reps["clean"][0]["encoder_rejections"]["count"] == 0)
    a, b = reps["clean"][0]["pose_rmse_m"], reps["jump"][0]["pose_rmse_m"]
    check("jump: the pose RMSE within 1.5x of the clean drive's", b <= 1.5 * a, "%.4f m against %.4f m" % (b, a))
    dg = {}
    for name, log in (("clean", clean), ("jump", jump)):
        r = run([odoerr, "diagnose", log, "--json", os.path.join(work, name + ".json")])
        with open(os.path.join(work, name + ".json")) as f:
            dg[name] = (json.load(f), r.stderr)
    named = {k: sorted(x["effect"] for x in v[0]["ranking"] if x["significant"]) for k, v in dg.items()}
    check("jump: diagnose names nothing the clean drive does not", set(named["jump"]) <= set(named["clean"]),
          "jump %s, clean %s" % (named["jump"], named["clean"]))
    cav = dg["jump"][0].get("verdict_caveats", [])
    check("jump: diagnose reports the rejection (JSON, caveats, printed)",
          dg["jump"][0]["encoder_rejections"]["count"] == 1 and len(cav) == 1 and "rejected" in cav[0]
          and "but: 1 encoder increment rejected" in dg["jump"][1], "; ".join(cav))

    # 2. the integer limits
    lim = os.path.join(work, "limits.odolog")

    def add_limits(k, line, f, n):
        if k == n // 3:
            where["limits"] = line
            return "enc %s 9223372036854775807 -9223372036854775808\n" % f[1]
        return None
    rewrite(clean, lim, add_limits)
    r = run([odoerr, "replay", lim, "--out", os.path.join(work, "rp-limits")])
    with open(os.path.join(work, "rp-limits", "replay.json")) as f:
        rl = json.load(f)
    lines = sorted({x["line"] for x in rl["encoder_rejections"]["first"]})
    # the record itself (both channels) and the next one (back from the limits: both again)
    check("limits: both channels rejected at the record's line",
          rl["encoder_rejections"]["count"] >= 2 and lines[0] == where["limits"],
          "lines %s, the record at %d" % (lines, where["limits"]))
    sig = [float(s.split("+-")[1]) for s in r.stdout.splitlines() if "+-" in s]
    check("limits: every printed sigma below 100", bool(sig) and max(sig) < 100, "largest %.3g" % max(sig or [0]))

    # 3. no usable beam
    blind = os.path.join(work, "blind.odolog")
    with open(clean) as f, open(blind, "w") as g:
        for s in f:
            if s.startswith("scan "):
                p = s.split()
                s = " ".join(p[:2] + ["nan"] * (len(p) - 2)) + "\n"
            g.write(s)
    r = run([odoerr, "diagnose", blind, "--json", os.path.join(work, "blind.json")], expect=3)
    with open(os.path.join(work, "blind.json")) as f:
        jb = json.load(f)
    check("no beam: verdict insufficient data, with what is missing",
          jb["verdict"] == "insufficient data" and jb.get("verdict_missing") and "missing:" in r.stderr,
          "%s; %s" % (jb["verdict"], jb.get("verdict_missing")))
    check("no beam: no NIS band computed from nothing", jb["tests"].get("nis_band") is None,
          str(jb["tests"].get("nis_band")))
    print("%d failed" % len(fails) if fails else "all passed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())

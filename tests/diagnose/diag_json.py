"""Shared by the statistical checks that drive the independent simulator and `odoerr
diagnose` (check_discovery.py, check_map.py): running commands, reading diagnose's JSON
with a clear message for a missing key, and the small text helpers."""
import json
import subprocess
import time


class Missing(Exception):
    """A key the contract promises is not in the JSON."""


def need(obj, *keys):
    """obj[k1][k2]...; raises Missing('k1.k2[0]...') naming the first key not there."""
    cur, path = obj, ""
    for k in keys:
        path += "[%d]" % k if isinstance(k, int) else ("." if path else "") + str(k)
        try:
            cur = cur[k]
        except (KeyError, IndexError, TypeError):
            raise Missing(path)
    return cur


def fmt(v, spec=".3g"):
    if v is None:
        return "None"
    if isinstance(v, bool):
        return str(v)
    return format(v, spec) if isinstance(v, (int, float)) else str(v)


def run(cmd):
    """(ok, seconds, stderr tail)."""
    t0 = time.perf_counter()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as e:
        return False, 0.0, str(e)
    tail = " | ".join(r.stderr.strip().splitlines()[-2:])
    return r.returncode == 0, time.perf_counter() - t0, tail if r.returncode else ""


def diagnose(args, log, out, extra=()):
    """(json or None, seconds, error text)."""
    ok, secs, err = run([args.odoerr, "diagnose", log, "--json", out, *extra])
    if not ok:
        return None, secs, "diagnose %s failed: %s" % (" ".join(extra), err)
    try:
        with open(out) as f:
            return json.load(f), secs, ""
    except (OSError, ValueError) as e:
        return None, secs, "diagnose wrote no readable JSON (%s)" % e


def named_rows(j):
    """[(effect, kind)] of the significant ranking rows."""
    out = []
    for i, _ in enumerate(need(j, "ranking")):
        if need(j, "ranking", i, "significant") is True:
            out.append((need(j, "ranking", i, "effect"), need(j, "ranking", i, "kind")))
    return out


def feature_text(f):
    if not isinstance(f, dict):
        return repr(f)
    return "%s/%s %s %s+-%s" % (f.get("frame"), f.get("component"), f.get("name"),
                                fmt(f.get("coef")), fmt(f.get("sigma")))


def seed_list(text):
    """'21,22,30-35' -> [21, 22, 30, 31, ..., 35]."""
    out = []
    for part in text.split(","):
        if "-" in part.strip()[1:]:
            a, b = part.split("-", 1)
            out += list(range(int(a), int(b) + 1))
        elif part.strip():
            out.append(int(part))
    return out


def common_args(ap, default_pysim, cases, what):
    """The arguments every simulator-driven check takes: ODOERR OUTDIR, the seeds, the
    simulator and its interpreter, and --only over `cases` (and clean)."""
    import sys
    ap.add_argument("odoerr")
    ap.add_argument("outdir")
    ap.add_argument("--seeds", default="21,22", help="seeds of the %s" % what)
    ap.add_argument("--clean-seeds", default="21-30", help="seeds of the clean drives")
    ap.add_argument("--pysim", default=default_pysim)
    ap.add_argument("--python", default=sys.executable or "/usr/bin/python3")
    ap.add_argument("--only", default=None,
                    help="comma-separated case names (%s, clean)" % ", ".join(cases))

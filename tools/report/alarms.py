"""CUSUM alarms grouped for the figures. A drive where the NIS stays high (a door open that
the map has closed, a missing effect) raises an alarm every few scans: hundreds of them,
which drawn one by one hide the path and cost seconds of drawing each. They are grouped into
clusters, each drawn once: at its first alarm, with the stretch of drive it covers, and only
the first LABELLED clusters are labelled (A1..., with their number of alarms)."""
import math

from report_io import is_num

GAP_S = 3.0        # an alarm joins its predecessor's cluster when it comes at most this later...
JUMP_M = 2.0       # ...at most this far from it, and with the same direction
LABELLED = 5       # clusters labelled on the figures


def cluster_alarms(alarms, gap_s=GAP_S, jump_m=JUMP_M):
    """The alarms (dicts with t, x, y and direction "up" / "down"; those without a numeric
    t, x and y are left out) in time order, chained into clusters: an alarm joins the current
    cluster when it has the cluster's direction and comes at most gap_s after, and at most
    jump_m from, the cluster's last alarm. Returns clusters in time order, each a dict:
    n (alarms), t0, t1 (first and last alarm's time), x, y (the first alarm's place),
    x1, y1 (the last alarm's), direction."""
    al = sorted((a for a in alarms if isinstance(a, dict) and all(is_num(a.get(k)) for k in ("t", "x", "y"))),
                key=lambda a: a["t"])
    out = []
    for a in al:
        d = "down" if a.get("direction") == "down" else "up"
        c = out[-1] if out else None
        if (c is not None and c["direction"] == d and a["t"] - c["t1"] <= gap_s
                and math.hypot(a["x"] - c["x1"], a["y"] - c["y1"]) <= jump_m):
            c["n"] += 1
            c["t1"], c["x1"], c["y1"] = float(a["t"]), float(a["x"]), float(a["y"])
        else:
            out.append({"n": 1, "t0": float(a["t"]), "t1": float(a["t"]), "x": float(a["x"]), "y": float(a["y"]),
                        "x1": float(a["x"]), "y1": float(a["y"]), "direction": d})
    return out


def label(k, c):
    """The label of cluster k (0-based): 'A1' for a single alarm, 'A1 ×37' for a cluster."""
    return f"A{k + 1}" + (f" ×{c['n']}" if c["n"] > 1 else "")


def plural(n, word):
    return f"{n:,} {word}{'' if n == 1 else 's'}"


def summary(clusters, n_alarms):
    """Two sentences on the alarms and their clusters for a caption."""
    if not n_alarms:
        return "There were no CUSUM alarms: the NIS never drifted for long."
    nc = len(clusters)
    big = max(range(nc), key=lambda k: clusters[k]["n"])
    cb = clusters[big]
    s = (f"{plural(n_alarms, 'CUSUM alarm')} in {plural(nc, 'cluster')} (an alarm less than {GAP_S:g} s and {JUMP_M:g} m "
         f"after the previous one, in the same direction, joins its cluster): places where the NIS drifted up (▲) "
         f"or down (▼) for long enough to be a change, not noise. Each cluster is drawn once, at its first alarm, "
         f"with the stretch of drive its alarms cover")
    if nc > LABELLED:
        s += f"; the first {LABELLED} are labelled A1…A{LABELLED} with their number of alarms"
    elif nc > 1:
        s += "; labelled A1… in time order with their number of alarms"
    else:
        s += ", labelled A1 with its number of alarms"
    if cb["n"] > 1 and nc > 1:
        s += (f". The largest, A{big + 1}, holds {cb['n']:,} alarms from t = {cb['t0']:.1f} to {cb['t1']:.1f} s")
    elif cb["n"] > 1:
        s += f", from t = {cb['t0']:.1f} to {cb['t1']:.1f} s"
    return s + "."

#!/usr/bin/python3
"""Tests of the report's alarm clusters (tools/report/alarms.py, plots.fig_trajectory / fig_nis)
and its headline (tools/report/headline.py), without a browser and in a few seconds.

  test_alarms_headline.py [REPORT_DIR]      (default: tools/report of this checkout)

Checked:
  * cluster_alarms: alarms less than 3 s and 2 m after the previous one, in the same direction,
    form one cluster; a gap in time, a jump in space or a change of direction starts another;
    alarms without a place are left out;
  * the trajectory figure draws each cluster once (one triangle per cluster) and labels at most
    alarms.LABELLED of them, with their count ("A4 ×94"); the NIS figure labels as many; the
    number of artists of both figures does not grow with the number of alarms (274 or 2,740
    alarms in the same seven clusters: the same artists), which is what keeps them fast;
  * the headline names what was found before what was not: the named effects, the regions
    where the map is wrong (their count and the largest, by beams), the structure left
    unexplained; with no region it says the ranges agree with the map; a diagnose.json without
    map_misfit (an older odoerr) says nothing about the map; with nothing found, so.
Prints one line per check and "alarms_headline: N passed, M failed"; exit 0 only when none failed.
"""
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPORT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "..", "..", "tools", "report")
sys.path.insert(0, os.path.abspath(REPORT))

import numpy as np  # noqa: E402

passed = failed = 0


def check(name, cond, detail=""):
    global passed, failed
    if cond:
        passed += 1
        print(f"ok: {name}")
    else:
        failed += 1
        print(f"FAIL: {name}{': ' + str(detail) if detail else ''}")


def run(name, f):
    """A check that may raise (e.g. an old module without the function): counted as failed."""
    try:
        f()
    except Exception as e:  # noqa: BLE001
        check(name, False, f"{type(e).__name__}: {e}")


def burst(t0, n, x0, y0, dt=0.1, dx=0.05, direction="up"):
    return [{"t": t0 + i * dt, "x": x0 + i * dx, "y": y0, "direction": direction} for i in range(n)]


def seven_bursts(scale=1):
    """Seven clusters along a straight drive at 0.5 m/s; scale multiplies the alarms of each
    (dt and dx shrink so that each burst covers the same time and ground)."""
    al = []
    for k, (t0, n, d) in enumerate([(5, 15, "up"), (20, 38, "up"), (40, 22, "up"), (60, 94, "up"),
                                     (90, 53, "down"), (120, 45, "up"), (150, 7, "up")]):
        m = n * scale
        al += burst(t0, m, 0.5 * t0, 1.0 + 0.1 * k, dt=0.1 / scale, dx=0.05 / scale, direction=d)
    return al


def test_clusters():
    from alarms import cluster_alarms
    check("no alarm: no cluster", cluster_alarms([]) == [])
    c = cluster_alarms(burst(10, 20, 1, 1) + burst(30, 5, 1, 1))
    check("two bursts 18 s apart: two clusters of 20 and 5", [x["n"] for x in c] == [20, 5], c)
    check("a cluster spans its first to its last alarm", abs(c[0]["t0"] - 10) < 1e-9 and abs(c[0]["t1"] - 11.9) < 1e-9
          and c[0]["x"] == 1 and abs(c[0]["x1"] - 1.95) < 1e-9, c[0])
    c = cluster_alarms([{"t": 0, "x": 0, "y": 0}, {"t": 2.9, "x": 0, "y": 0}, {"t": 6.0, "x": 0, "y": 0}])
    check("2.9 s apart: one cluster; 3.1 s: another", [x["n"] for x in c] == [2, 1], c)
    c = cluster_alarms([{"t": 0, "x": 0, "y": 0}, {"t": 0.1, "x": 2.5, "y": 0}, {"t": 0.2, "x": 2.6, "y": 0}])
    check("2.5 m apart in 0.1 s: another cluster", [x["n"] for x in c] == [1, 2], c)
    c = cluster_alarms(burst(0, 3, 0, 0) + burst(0.3, 3, 0.15, 0, direction="down"))
    check("a change of direction starts a cluster", [(x["n"], x["direction"]) for x in c] == [(3, "up"), (3, "down")], c)
    c = cluster_alarms([{"t": 1, "x": None, "y": 0}, {"t": 0, "x": 1, "y": 1}, {"t": "late", "x": 1, "y": 1}])
    check("alarms without a numeric t, x, y are left out", [x["n"] for x in c] == [1], c)
    c = cluster_alarms(list(reversed(seven_bursts())))
    check("274 alarms in seven bursts (given in any order): 7 clusters in time order",
          [x["n"] for x in c] == [15, 38, 22, 94, 53, 45, 7], [x["n"] for x in c])


def traj_scans():
    t = np.arange(0, 160, 0.1)
    x, y = 0.5 * t, 1.0 + 0.0 * t
    traj = {"t": t, "x": x, "y": y, "theta": 0 * t, "truth_x": x, "truth_y": y, "truth_theta": 0 * t}
    rng = np.random.default_rng(1)
    dof = np.full(t.size, 30.0)
    scans = {"t": t, "dist_m": 0.5 * t, "dof": dof, "nis_sum": dof * rng.chisquare(30, t.size) / 30,
             "band_lo": dof * 0.6, "band_hi": dof * 1.5, "along_m": 0 * t, "cross_m": 0 * t, "heading_rad": 0 * t}
    return traj, scans


def alarm_labels(ax):
    return [x.get_text() for x in ax.texts if re.match(r"A\d+( ×\d+)?$", x.get_text())]


def n_artists(fig):
    return sum(len(a.lines) + len(a.collections) + len(a.texts) + len(a.patches) for a in fig.axes)


def test_figures():
    from alarms import LABELLED, cluster_alarms
    import plots
    plt = plots.setup_matplotlib()
    walls = [[0, 0, 100, 0], [100, 0, 100, 10], [100, 10, 0, 10], [0, 10, 0, 0]]
    traj, scans = traj_scans()
    al = seven_bursts()
    cl = cluster_alarms(al)
    fig = plots.fig_trajectory(plt, traj, walls, cl, True)
    ax = fig.axes[0]
    labels = alarm_labels(ax)
    check(f"trajectory: {LABELLED} clusters labelled of 7, with their counts",
          labels == ["A1 ×15", "A2 ×38", "A3 ×22", "A4 ×94", "A5 ×53"][:LABELLED] and LABELLED <= 5, labels)
    pts = sum(len(c.get_offsets()) for c in ax.collections if c.get_offsets() is not None
              and len(c.get_offsets()) and getattr(c, "get_paths", None) and type(c).__name__ == "PathCollection")
    check("trajectory: one triangle per cluster (7), not one per alarm (274)", pts == 7, pts)
    n1 = n_artists(fig)
    plt.close(fig)
    fig = plots.fig_trajectory(plt, traj, walls, cluster_alarms(seven_bursts(10)), True)
    n2 = n_artists(fig)
    plt.close(fig)
    check("trajectory: as many artists for 2,740 alarms as for 274", n1 == n2, (n1, n2))
    fig, _, _ = plots.fig_nis(plt, scans, cl, ())
    labels = alarm_labels(fig.axes[0])
    check(f"NIS: {LABELLED} clusters labelled", len(labels) == LABELLED and labels[0] == "A1 ×15", labels)
    n1 = n_artists(fig)
    plt.close(fig)
    fig, _, _ = plots.fig_nis(plt, scans, cluster_alarms(seven_bursts(10)), ())
    n2 = n_artists(fig)
    plt.close(fig)
    check("NIS: as many artists for 2,740 alarms as for 274", n1 == n2, (n1, n2))


def region(x, y, sign, beams):
    return {"x": x, "y": y, "sign": sign, "beams": beams, "extent_m": [0.5, 0.5], "mean_norm": -3.0, "scans": 50,
            "seen_from": [], "candidate_segment": None}


def plain(html):
    return re.sub(r"<[^>]+>", "", html).replace("&#x27;", "'").replace("&amp;", "&")


def test_headline():
    from headline import headline_html
    d = {"verdict": "inconsistent", "ranking": [{"effect": "turn_slip", "significant": False}],
         "map_misfit": {"regions": [region(1.5, 3.75, "long", 4802), region(7.04, 3.14, "short", 11509)]},
         "unexplained": {"features": []}, "change_points": []}
    h = plain(headline_html(d))
    check("headline: the map regions first, with their count and the largest",
          h.startswith("Found: 2 regions where the map is wrong, the largest R2 at (7.04, 3.14) m, 11,509 beams, "
                       "short — something the map lacks."), h)
    check("headline: then what was not found",
          h.index("No catalogue effect is named") > h.index("regions where the map is wrong")
          and "nothing is left unexplained and there is no change point." in h, h)
    check("headline: one or two sentences", len(re.findall(r"\.(\s|$)", h)) <= 2, h)
    d["ranking"][0]["significant"] = True
    d["unexplained"]["features"] = [{"words": "the robot drifts toward +x", "name": "abs_ds"}, {"name": "x"}]
    h = plain(headline_html(d))
    check("headline: named effects, then the map, then what is unexplained",
          h.index("named effect: turn_slip") < h.index("2 regions") < h.index("structure no catalogue effect explains: "
                                                                               "the robot drifts toward +x and 1 more term"), h)
    d["map_misfit"]["regions"] = []
    h = plain(headline_html(d))
    check("headline: no region: the ranges agree with the map, said after what was found",
          "where the map is wrong" not in h and h.index("The ranges agree with the map everywhere it was seen")
          > h.index("named effect"), h)
    del d["map_misfit"]
    h = plain(headline_html(d))
    check("headline: no map_misfit (an older odoerr): nothing about the map", "map" not in h, h)
    e = {"verdict": "inconsistent", "ranking": [], "map_misfit": {"regions": []}, "unexplained": {"features": []},
         "change_points": []}
    h = plain(headline_html(e))
    check("headline: nothing found, said so", h.startswith("Nothing specific found: no catalogue effect is named"), h)
    e["verdict"] = "consistent"
    h = plain(headline_html(e))
    check("headline: consistent and nothing found", h.startswith("The model explains this log: "), h)
    e["verdict_caveats"] = ["1 encoder increment rejected as impossible for the drive (the first at x.odolog:12)"]
    h = plain(headline_html(e))
    check("headline: a caveat closes it", h.startswith("The model explains this log: ") and
          h.endswith("But: 1 encoder increment rejected as impossible for the drive (the first at x.odolog:12)."), h)
    n = {"verdict": "insufficient data", "verdict_missing": ["0 beams of 1200 scans were predicted against the map"],
         "ranking": [], "map_misfit": {"regions": []}, "unexplained": {"features": []}, "change_points": []}
    h = plain(headline_html(n))
    check("headline: no verdict: what was missing, and nothing found or not found",
          h == "No verdict: insufficient data. 0 beams of 1200 scans were predicted against the map.", h)


if __name__ == "__main__":
    for name, f in (("clusters", test_clusters), ("figures", test_figures), ("headline", test_headline)):
        run(name, f)
    print(f"alarms_headline: {passed} passed, {failed} failed")
    sys.exit(1 if failed else 0)

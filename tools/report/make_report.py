#!/usr/bin/python3
"""Turn what `odoerr diagnose` wrote into DIR into one self-contained page, DIR/report.html.

usage: make_report.py DIR [--out FILE] [--max-points N]

Reads DIR/diagnose.json, scans.csv, beams.csv, trajectory.csv and, when the held-out check
ran, heldout_before.csv / heldout_after.csv, and discovery_motion.csv / discovery_beam.csv when
present, and map_grid.csv when diagnose.json's map_misfit names it. Writes one HTML file
with inline CSS and every
plot embedded as a base64 PNG: no JavaScript, no external links, readable offline.

Exit status: 0 written; 1 an input file is missing or malformed (one line on stderr that
names the file, and the line or key when there is one); 2 bad command line.
Needs numpy, matplotlib (Agg backend) and Jinja2. The code is split by responsibility:
report_io.py (inputs), fmt.py (numbers, tables), plots.py / plots_discovery.py (figures),
sections.py (tables of tests, ranking, held-out...), discovery.py + templates/ (discovery,
change points, --with auto), map_misfit.py + plots_map.py (where the map is wrong).
"""
import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fmt import E, fnum, figure  # noqa: E402
from plots import (BIN_ORDER, setup_matplotlib, png_uri, fig_trajectory,  # noqa: E402
                   fig_truth_error, fig_nis, fig_residual_map, fig_beams, fig_bins, fig_ranking,
                   fig_heldout)
from report_io import InputError, is_num, load_inputs, read_map_grid  # noqa: E402
from map_misfit import map_misfit_section  # noqa: E402
from alarms import cluster_alarms, plural as alarm_plural, summary as alarm_summary  # noqa: E402
from headline import headline_html  # noqa: E402
from discovery import discovery_sections  # noqa: E402
from sections import (tests_section, ranking_section, heldout_table, excitation_section, power_section,  # noqa: E402
                      bins_table)

PROG = "make_report"
with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "report.css"), encoding="utf-8") as _f:
    CSS = _f.read()


def build(args):
    t_start = time.monotonic()
    d, scans, beams, traj, held, disc = load_inputs(args.dir)
    grid = read_map_grid(args.dir, d)
    plt = setup_matplotlib()
    rng = np.random.default_rng(0)
    walls = (d.get("map") or {}).get("walls") or []
    alarms = [a for a in ((d.get("cusum") or {}).get("alarms") or [])
              if is_num(a.get("t")) and is_num(a.get("x")) and is_num(a.get("y"))]
    clusters = cluster_alarms(alarms)
    has_truth = bool(len(traj["t"]) and np.isfinite(traj["truth_x"]).any() and np.isfinite(traj["truth_y"]).any())
    cps = [c for c in (d.get("change_points") or []) if isinstance(c, dict) and is_num(c.get("t"))]
    n_imgs = 0
    s = []
    verdict = d["verdict"]
    vcls = {"consistent": "v-ok", "inconsistent": "v-bad"}.get(verdict, "v-other")
    vtext = {
        "consistent": "The filter's errors are the size and shape its model predicts: the odometry model "
                      "explains this log.",
        "inconsistent": "The errors are larger or more structured than the model allows: something physical "
                        "is missing from the odometry or laser model, or the map is not the building. The "
                        "sections below say where: the effect ranking, the map errors, what discovery finds "
                        "left unexplained.",
        "insufficient data": "No verdict: the statistical tests had too little data (the headline says what was "
                             "missing). Nothing below is evidence either way.",
    }.get(verdict, "")
    dist_total = float(np.nanmax(scans["dist_m"])) if len(scans["dist_m"]) and np.isfinite(scans["dist_m"]).any() else None
    n_used = int((beams["status"] == "used").sum())
    s.append("<h1>odoerr diagnose report</h1>")
    s.append("<table class='kv'><tbody>"
             f"<tr><td>log</td><td><code>{E(d['log'])}</code></td></tr>"
             f"<tr><td>drive</td><td>{E(d['drive'])} "
             f"{'(differential)' if d['drive'] == 'diff' else '(synchronous)' if d['drive'] == 'sync' else ''}</td></tr>"
             f"<tr><td>data</td><td>{len(scans['t'])} scans, {len(beams['t'])} predicted beams "
             f"({n_used} used), {fnum(dist_total, 4, 'm') if dist_total is not None else '—'} driven</td></tr>"
             "</tbody></table>")
    s.append(f"<p><span class='verdict {vcls}'>{E(verdict.upper())}</span></p>")
    s.append(headline_html(d))
    s.append(f"<p class='cap'>{E(vtext)}</p>")
    s.append("<nav><a href='#tests'>Tests</a><a href='#trajectory'>Trajectory</a><a href='#nis'>NIS</a>"
             "<a href='#residuals'>Residual map</a><a href='#map-misfit'>Map errors</a><a href='#beams'>Per beam</a><a href='#bins'>Bins</a>"
             "<a href='#ranking'>Effects</a><a href='#unexplained'>Unexplained</a><a href='#changes'>Change points</a>"
             "<a href='#auto'>Auto</a><a href='#heldout'>Held-out</a><a href='#excitation'>Excitation</a><a href='#power'>Power</a></nav>")

    s.append("<h2 id='tests'>Consistency tests</h2>")
    s.append("<p class='cap'>Each test asks whether the filter's innovations (measured minus predicted "
             "laser ranges) behave as its own uncertainty says they should.</p>")
    tests_html = tests_section(d, plt)
    n_imgs += tests_html.count("<img ")
    s.append(tests_html)

    s.append("<h2 id='trajectory'>Trajectory on the map</h2>")
    if len(traj["t"]):
        cap = ("The estimated path (blue) over the map's walls (black)"
               + (", with the true path dashed in orange" if has_truth else "; the log has no truth")
               + ". " + alarm_summary(clusters, len(alarms)))
        s.append(figure(png_uri(plt, fig_trajectory(plt, traj, walls, clusters, has_truth)),
                        "trajectory on the map", E(cap)))
        n_imgs += 1
        if has_truth:
            s.append(figure(png_uri(plt, fig_truth_error(plt, traj, cps)), "error against truth",
                            "How far the estimate is from the truth along the drive: position error in cm "
                            "(top) and heading error in degrees (bottom)."))
            n_imgs += 1
    else:
        s.append("<p class='note'>trajectory.csv has no rows.</p>")
    if not walls:
        s.append("<p class='note'>diagnose.json has no map walls.</p>")

    s.append("<h2 id='nis'>NIS per scan along the drive</h2>")
    if len(scans["t"]):
        fig, n_out, n_good = fig_nis(plt, scans, clusters, cps)
        s.append(figure(png_uri(plt, fig), "NIS per scan against distance",
                        E(f"Top: each dot is one scan's normalised innovation squared divided by its number "
                          f"of beams; it should scatter around 1 inside the green band. {n_out} of {n_good} "
                          f"scans are outside it (red); runs of them, or a running mean (black) away from 1, "
                          f"point to a systematic error at that part of the drive. Below: the pose "
                          f"correction each scan made, in the robot frame; corrections that repeat with the "
                          f"same sign show what the odometry gets wrong (e.g. cross-track in every turn). "
                          + (f"Dotted lines: the {alarm_plural(len(clusters), 'cluster')} of CUSUM alarms at their "
                             f"first alarm, a purple band to their last (A1… as on the map)." if clusters else "")
                          + (f" Orange: the {len(cps)} change point(s) C1… (line: most likely time; band: its "
                             f"interval; see Change points below)." if cps else ""))))
        n_imgs += 1
    else:
        s.append("<p class='note'>scans.csv has no rows: nothing to plot.</p>")

    s.append("<h2 id='residuals'>Residual map</h2>")
    if len(beams["t"]) and (beams["status"] == "used").any():
        fig, nu, nshown, vmax, cvmax = fig_residual_map(plt, beams, walls, traj, args.max_points, rng)
        s.append(figure(png_uri(plt, fig), "residual map",
                        E(f"Where the used beams hit the map, coloured by their innovation (measured minus "
                          f"predicted range): red means the laser measured farther than the map predicts, "
                          f"blue nearer. Left: individual beams (scale ±{vmax:.3g} mm, the 98th percentile; "
                          + (f"{nshown} of {nu} drawn" if nshown < nu else f"all {nu} drawn")
                          + f"). Right: the same averaged over small cells, which removes the noise "
                          f"(scale ±{cvmax:.3g} mm). A wall that is red or blue all along is probably not "
                          f"where the map says; everything shifted one way suggests a range bias; colour "
                          f"that changes with where the robot was points to the odometry.")))
        n_imgs += 1
    else:
        s.append("<p class='note'>beams.csv has no used beams: nothing to plot.</p>")

    mm_html, n_mm = map_misfit_section(d, grid, traj, plt)
    s.append(mm_html)
    n_imgs += n_mm

    s.append("<h2 id='beams'>Residuals per beam</h2>")
    if len(beams["t"]) and np.isfinite(beams["beam"]).any():
        fig, nb = fig_beams(plt, beams)
        s.append(figure(png_uri(plt, fig), "per-beam residuals",
                        E(f"For each of the {nb} beams of the scanner (index 0 = first beam of a scan): the mean "
                          f"innovation with ±2 standard errors (top), the mean NIS (middle, 1 expected) and the "
                          f"share of its predictions not used (bottom). A smooth trend across the beams points "
                          f"to the laser (mounting yaw or offset, range scale); a single odd beam to a fault "
                          f"or an obstacle.")))
        n_imgs += 1
    else:
        s.append("<p class='note'>beams.csv has no rows: nothing to plot.</p>")

    s.append("<h2 id='bins'>Innovations binned by driving conditions</h2>")
    bins = d.get("bins") or {}
    names = [n for n in BIN_ORDER if bins.get(n)] + sorted(n for n in bins if n not in BIN_ORDER and bins.get(n))
    empty = [n for n in BIN_ORDER if n in bins and not bins.get(n)]
    empty += sorted(n for n in bins if n not in BIN_ORDER and not bins.get(n))
    if names:
        s.append(figure(png_uri(plt, fig_bins(plt, bins, names)), "binned NIS and innovation",
                        E("Beams grouped by the conditions when they were taken. In each panel, top: the mean "
                          "NIS of the bin (1 expected, green line); bottom: the mean innovation divided by its "
                          "sigma (0 expected), with the grey bar showing what chance allows for the bin's beam "
                          "count if beams were independent. Red marks a bin outside that range. A trend with "
                          "turn rate or v·ω suggests slip; with speed, a speed-dependent scale; right after a "
                          "reversal, backlash; in one map cell, a floor region or a wrong wall. Bins with fewer "
                          "than 30 beams are labelled n=.")))
        n_imgs += 1
        s.append("<details><summary>Numbers per bin, with the mean pose corrections</summary>"
                 + bins_table(bins, names) + "</details>")
    else:
        s.append("<p class='note'>diagnose.json has no bins.</p>")
    if empty:
        s.append(f"<p class='note'>No data for: {E(', '.join(empty))}"
                 + (" (the wheel angle exists only for a synchronous drive)." if "wheel_angle" in empty
                    and d["drive"] == "diff" else ".") + "</p>")

    s.append("<h2 id='ranking'>Effect ranking</h2>")
    if d["ranking"]:
        s.append(figure(png_uri(plt, fig_ranking(plt, d["ranking"])), "BIC gain per effect",
                        E("How much adding each candidate effect to the model improves it, after the BIC "
                          "penalty for its extra parameters: above 0 the data favour the effect. Red bars are "
                          "significant.")))
        n_imgs += 1
        s.append("<p class='cap'>Each candidate physical effect, fitted to this log one at a time, best first. "
                 "Significant rows are highlighted. <i>params</i>: how many of its parameters the log informs; "
                 "<i>detectable</i>: whether this drive could reveal the effect at all; <i>confused with</i>: "
                 "effects this log cannot tell apart from it.</p>")
        s.append(ranking_section(d["ranking"]))
    else:
        s.append("<p class='note'>The ranking is empty.</p>")

    disc_html, n_disc = discovery_sections(d, disc, scans, plt, rng)
    s.append(disc_html)
    n_imgs += n_disc

    s.append("<h2 id='heldout'>Held-out check</h2>")
    h = d.get("heldout")
    if h is None:
        s.append("<p class='note'>No held-out check was run (heldout is null).</p>")
    else:
        wn = h.get("with") or []
        bl = h.get("blocks") or []
        folds = h.get("folds")
        span = f"{bl[0][0]:.4g}–{bl[-1][1]:.4g} s" if bl else "none"
        s.append(f"<p class='cap'>Cross-validated: the drive ({E(span)}) was cut into {len(bl)} block(s)"
                 + (f" in {int(folds)} folds" if is_num(folds) else "") +
                 f". Each block was held out once: the model, before and with <b>{E(', '.join(wn) or 'no effect')}</b>, "
                 f"was fitted on the other folds' data and then predicted the block it had not seen. If the "
                 f"effects are real, the held-out predictions get better too: smaller errors and NLL, NIS "
                 f"closer to 1.</p>")
        ff = h.get("folds_failed") or []
        if ff:
            s.append(f"<p class='note bad'>Left out of the comparison: fold(s) {E(', '.join(str(f) for f in ff))}. "
                     f"There the fit lost the robot while it dead-reckoned through a held-out block, so its "
                     f"parameters mean nothing. If this happens often, the drive has long stretches where the "
                     f"laser cannot relocalise the robot.</p>")
        s.append(heldout_table(h))
        if held:
            s.append(figure(png_uri(plt, fig_heldout(plt, held, bl, cps)), "held-out before and after",
                            E("Before (red) and after (blue) adding the effects: the held-out scans' NIS per "
                              "beam (top, 1 expected)" + (" and its pose error against the truth (bottom)"
                                                          if len(held) and any(np.isfinite(held[k]['pose_err_m']).any() for k in held)
                                                          else "") + ", averaged over each held-out block.")))
            n_imgs += 1
        else:
            s.append("<p class='note'>heldout_before.csv / heldout_after.csv are not in the directory: "
                     "no per-scan plot.</p>")

    s.append("<h2 id='excitation'>Excitation: what this drive can determine</h2>")
    s.append("<p class='cap'>For each parameter, the smallest sigma this drive could give it (achievable) "
             "against what was known before (prior). A parameter is determined when the drive pins it down well "
             "below its prior; undetermined ones are highlighted, and the warnings say what driving would fix "
             "that.</p>")
    s.append(excitation_section(d.get("excitation")))

    s.append("<h2 id='power'>Detection power: what this drive could not have missed</h2>")
    s.append("<p class='cap'>For each effect the ranking tests, the smallest size this drive would have revealed "
             "at the ranking's own threshold, with the power stated (from the sigma the effect's run achieved; "
             "conservative where parameters are correlated). A consistent verdict means nothing larger than these; "
             "a family the drive does not excite is said so.</p>")
    s.append(power_section(d.get("detection_power")))

    elapsed = time.monotonic() - t_start
    s.append(f"<p class='small' style='margin-top:40px'>Made by tools/report/make_report.py from "
             f"{E(os.path.abspath(args.dir))} in {elapsed:.1f} s; {n_imgs} figures.</p>")
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>odoerr diagnose: {E(verdict)} — {E(os.path.basename(d['log']))}</title>"
            f"<style>{CSS}</style></head><body><main>" + "\n".join(s) + "</main></body></html>\n")
    return page, n_imgs


def main(argv=None):
    ap = argparse.ArgumentParser(prog=PROG, description="Write DIR/report.html from the files "
                                 "`odoerr diagnose` wrote into DIR.")
    ap.add_argument("dir", metavar="DIR", help="output directory of odoerr diagnose")
    ap.add_argument("--out", "-o", help="where to write the page (default DIR/report.html)")
    ap.add_argument("--max-points", type=int, default=40000,
                    help="at most this many beams drawn on the residual map (default 40000)")
    args = ap.parse_args(argv)
    if args.max_points < 100:
        ap.error("--max-points must be at least 100")
    t0 = time.monotonic()
    try:
        page, n_imgs = build(args)
    except InputError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 1
    out = args.out or os.path.join(args.dir, "report.html")
    tmp = out + ".tmp"
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(page)
        os.replace(tmp, out)
    except OSError as e:
        print(f"{PROG}: error: cannot write {out}: {e}", file=sys.stderr)
        return 1
    print(f"{PROG}: wrote {out} ({len(page) / 1e6:.1f} MB, {n_imgs} figures) in {time.monotonic() - t0:.1f} s",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

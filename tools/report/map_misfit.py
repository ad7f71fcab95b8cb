"""The section 'Where the map is wrong': diagnose.json's map_misfit and map_grid.csv, rendered
with templates/map_misfit.html.j2. Without the key (an older odoerr) the section says that the
check was not run."""
import math

from discovery import jinja_env
from fmt import fnum, peq
from plots import png_uri
from plots_map import FADE_BELOW, HIDE_BELOW, fig_map_misfit
from report_io import is_num

WHAT = {"short": "something the map lacks",
        "long": "a wall gone, a door open or a wall drawn too near"}


def xy(x, y):
    return f"({x:.2f}, {y:.2f}) m".replace("-", "−")


KIND = {"persistent": "the map is wrong here: every pass disagrees",
        "changed": "the place changed during the drive (a door opened or closed, something moved in or out)",
        "transient": "something that comes and goes (people walking by, a trolley): not the map's fault",
        "intermittent": "disagrees on some passes only"}


def when(h):
    """The region's history (diagnose.json map_misfit.regions[i].history) in words."""
    if not isinstance(h, dict) or not h.get("kind"):
        return "—"
    seen, dis = h.get("seen") or {}, h.get("disagreed") or {}
    t1, t2 = seen.get("t_first"), seen.get("t_last")
    span = f"{t1:.1f}–{t2:.1f} s" if is_num(t1) and is_num(t2) else "—"
    s = (f"seen by {fnum(seen.get('scans'))} scans, {span}; "
         f"disagreed in {fnum(dis.get('scans'))}"
         + (f" ({100 * dis['share']:.0f} %)" if is_num(dis.get("share")) else ""))
    ch = h.get("change")
    if isinstance(ch, dict) and is_num(ch.get("t")):
        s += (f"; changed at {ch['t']:.1f} s ({100 * ch['share_before']:.0f} % of the scans before, "
              f"{100 * ch['share_after']:.0f} % after)")
    return s


def region_row(k, r):
    seg = r.get("candidate_segment")
    ext = r.get("extent_m") or []
    row = {"n": k + 1, "sign": r.get("sign") or "?", "what": WHAT.get(r.get("sign"), "—"),
           "pos": xy(r.get("x"), r.get("y")) if is_num(r.get("x")) and is_num(r.get("y")) else "—",
           "extent": f"{ext[0]:.2f} × {ext[1]:.2f} m" if len(ext) == 2 else "—",
           "beams": fnum(r.get("beams")), "scans": fnum(r.get("scans")),
           "z": f"{r['mean_norm']:+.2f}".replace("-", "−") if is_num(r.get("mean_norm")) else "—",
           "seg": None, "seg_len": None,
           "kind": (r.get("history") or {}).get("kind") or "—",
           "kind_text": KIND.get((r.get("history") or {}).get("kind"), "not in this diagnose.json"),
           "when": when(r.get("history"))}
    if seg:
        row["seg"] = f"{xy(seg[0], seg[1])[:-2]} → {xy(seg[2], seg[3])}"
        row["seg_len"] = f"{math.hypot(seg[2] - seg[0], seg[3] - seg[1]):.2f} m"
    return row


def ranking_line(d, m, regs):
    """What the ranking did with the beams that end in a region, and what it names with them."""
    rb = m.get("region_beams") or ""
    n = int(sum(r.get("beams") or 0 for r in regs if is_num(r.get("beams"))))
    if rb.startswith("kept"):
        return (f"The effect ranking above kept the {n:,} beams that end in the region(s) "
                f"(--map-beams keep): a map error may show there as an effect such as wall_offset.")
    rw = m.get("ranking_with_region_beams")
    if not isinstance(rw, list):
        return ""
    named = [r["effect"] for r in d.get("ranking") or [] if r.get("significant")]
    with_ = [r for r in rw if r.get("significant")]
    names = ", ".join(f"{r['effect']} (p {peq(r['p_value']).replace('&lt;', '<') if is_num(r.get('p_value')) else '—'})"
                      for r in with_)
    s = (f"The effect ranking above left out the {n:,} beams that end in the region(s): they say where the map "
         f"is wrong, not how the robot moves. ")
    if not with_:
        return s + ("With them, the ranking names no effect either." if not named else
                    f"With them, it names no effect; without them it names {', '.join(named)}.")
    same = [r["effect"] for r in with_] == named
    return s + f"With them, it names {names}" + (" — the same as without them." if same else
                                                 (f"; without them it names {', '.join(named)}." if named else
                                                  "; without them it names none."))


def map_misfit_section(d, grid, traj, plt):
    """HTML of the section and the number of figures in it."""
    m = d.get("map_misfit")
    walls = (d.get("map") or {}).get("walls") or []
    ctx = {"ran": isinstance(m, dict)}
    fig = None
    if ctx["ran"]:
        regs = [r for r in (m.get("regions") or []) if isinstance(r, dict)]
        tc = m.get("t_critical")
        ctx.update({
            "regions": [region_row(k, r) for k, r in enumerate(regs)],
            "cells": fnum(m.get("cells_tested")), "t_crit": fnum(tc, 3),
            "alpha": fnum(100 * m["family_alpha"], 3) + " %" if is_num(m.get("family_alpha")) else "—",
            "cell": fnum(100 * m["cell_m"], 3) if is_num(m.get("cell_m")) else "—",
            "ranking_line": ranking_line(d, m, regs) if regs else "",
            "grid_note": "", "n_short": sum(r.get("sign") == "short" for r in regs),
            "n_long": sum(r.get("sign") == "long" for r in regs)})
        if grid is None and m.get("grid_csv"):
            ctx["grid_note"] = (f"{m['grid_csv']} is not in the directory: the figure shows the regions only, "
                                f"not the residual of every cell.")
        elif grid is None:
            ctx["grid_note"] = ("diagnose was run without --out, so there is no map_grid.csv: the figure shows the "
                                "regions only.")
        if (walls or regs or grid is not None):
            f, vmax, n_drawn = fig_map_misfit(plt, m, grid, walls, traj)
            cap = ("The map's walls (black) and the estimated path (grey)"
                   + (f"; over them every {ctx['cell']} cm cell of the grid that beams ended in, coloured by the "
                      f"mean normalised residual z of its beams (measured minus predicted range over its sigma; "
                      f"scale ±{vmax:.2g}): blue where the laser measured shorter than the map says, red longer, "
                      f"white where they agree. {n_drawn} cells drawn; cells with fewer than {FADE_BELOW} beams are "
                      f"pale, with fewer than {HIDE_BELOW} left out" if grid is not None else "")
                   + (". Black outlines: the regions the test flags, labelled R1… with their sign (short: something "
                      "the map lacks; long: something the map has that is not there); dashed green: the candidate "
                      "segment, where the beams' real end points lie; purple dots: a few robot positions each "
                      "region was seen from." if regs else ". No region was flagged."))
            fig = {"uri": png_uri(plt, f), "alt": "map with the residual grid and the regions where the map is wrong",
                   "caption": cap}
    ctx["fig"] = fig
    html = jinja_env().get_template("map_misfit.html.j2").render(m=ctx)
    return html, 1 if fig else 0

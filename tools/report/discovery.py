"""The sections on discovery ('unexplained'), change points and `--with auto`: their context
from diagnose.json and the discovery CSVs, rendered with templates/discovery.html.j2.

Every key may be missing (a diagnose.json of an older odoerr): the section then says that it
was not run."""
import os

import numpy as np

from fmt import fnum, pm
from plots import png_uri
from plots_discovery import fig_partial
from report_io import is_num

TEMPLATES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "templates")


def jinja_env():
    try:
        import jinja2
    except ImportError:
        raise SystemExit("make_report: error: needs Jinja2 (Debian: python3-jinja2; scripts/deps.sh installs it)")
    return jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES), autoescape=True,
                              trim_blocks=True, lstrip_blocks=True, undefined=jinja2.StrictUndefined)


def term_name(f):
    return "/".join(str(f.get(k) or "?") for k in ("frame", "component", "name"))


def feature_row(f):
    c, s = f.get("coef"), f.get("sigma")
    z = f"{c / s:+.1f}" if is_num(c) and is_num(s) and s > 0 else "—"
    return {"words": f.get("words") or term_name(f), "term": term_name(f), "pm": pm(c, s), "z": z,
            "with": f.get("with") or "—", "coef": c, "sigma": s}


def breakable(s):
    """A --with token that may wrap after its commas and before an '@' (zero-width spaces)."""
    return str(s).replace(",", ",\u200b").replace("@", "\u200b@")


def pct(v):
    return "—" if not is_num(v) else f"{100 * v:.0f} %"


def unexplained_ctx(d, disc, plt, rng):
    if "unexplained" not in d or d["unexplained"] is None:
        return {"ran": False}
    u = d["unexplained"]
    feats = [feature_row(f) for f in (u.get("features") or []) if isinstance(f, dict)]
    base = [feature_row(f) for f in (u.get("baseline_features") or []) if isinstance(f, dict)]
    sig = bool(u.get("significant"))
    named = [r["effect"] for r in d.get("ranking") or [] if r.get("significant")]
    ef = u.get("explained_fraction")
    if not is_num(ef):
        explained = ("The baseline's residuals show no structured misfit, so there is nothing for a named effect "
                     "to explain.")
    elif not named:
        explained = (f"No effect of the catalogue is named, so they explain {pct(ef)} of the misfit the "
                     f"baseline's residuals show.")
    else:
        explained = (f"The named effect(s) ({', '.join(named)}) explain {pct(ef)} of the misfit the baseline's "
                     f"residuals show" + ("; the terms below describe the rest." if sig else "."))
    same = [b["term"] for b in base] == [f["term"] for f in feats]
    if not base:
        base_text = "The baseline's residuals (before any named effect) depended on nothing in the library either." \
            if not feats else ""
    elif same:
        base_text = "The baseline's residuals, before any named effect was added, depended on the same terms."
    else:
        base_text = "Before the named effects were added, the baseline's residuals depended on:"
    sizes = []
    for k, lab in (("motion", "motion"), ("beam", "beam")):
        q = u.get(k)
        if not isinstance(q, dict):
            continue
        n = q.get("segments") if k == "motion" else q.get("beams")
        seg = f" of {fnum(q.get('segment_s'), 2)} s" if k == "motion" and is_num(q.get("segment_s")) else ""
        unit = "segments" if k == "motion" else "beams"
        sizes.append(f"{lab} residuals: {fnum(n, 0)} {unit}{seg}, the selected terms take "
                     f"{pct(q.get('features_explain'))} of their cross-validated sum of squares")
    plots, notes = [], []
    words = {f["term"]: f for f in base}
    words.update({f["term"]: f for f in feats})
    for kind in ("motion", "beam"):
        got = disc.get(kind)
        if got is None:
            if u.get(kind) is not None:
                notes.append(f"discovery_{kind}.csv is not in the directory: no partial-residual plots of the "
                             f"{kind} terms.")
            continue
        cols, terms = got
        for term in terms:
            f = words.get(term, {"words": term, "coef": None, "sigma": None, "term": term})
            x, p = cols[term], cols[f"partial_{term}"]
            fig = fig_partial(plt, x, p, f["coef"], f["sigma"], term, rng)
            plots.append({"uri": png_uri(plt, fig), "alt": f"partial residual against {term}",
                          "caption": f"{f['words']} — {kind} residuals, {int(np.isfinite(x).sum())} rows"
                                     + (" (every 8th beam)" if kind == "beam" else "") + "."})
    if feats and not plots and not notes:
        notes.append("The discovery CSVs have no column for the selected terms: no partial-residual plots.")
    withs = [f["with"] for f in feats if f["with"] != "—"]
    return {"ran": True, "significant": sig,
            "headline": "Something is left that no named effect explains" if sig else "Nothing is left unexplained",
            "note": u.get("note") or "", "explained_text": explained, "features": feats,
            "with_all": ",".join(withs) if len(withs) > 1 else "", "baseline": base, "baseline_same": same,
            "baseline_text": base_text, "sizes_text": ("; ".join(sizes) + ".") if sizes else "",
            "plots": plots, "plot_notes": notes}


def change_points_ctx(d, scans):
    if "change_points" not in d or d["change_points"] is None:
        return {"ran": False, "points": []}
    pts = []
    t_s, dist = scans["t"], scans["dist_m"]
    for c in d["change_points"]:
        t = c.get("t")
        dd = None
        if is_num(t) and len(t_s) > 1 and np.isfinite(dist).any():
            dd = fnum(float(np.interp(t, t_s, dist)), 3, "m")
        rem = c.get("remains_with_named")
        pts.append({"t": fnum(t, 4), "t_lo": fnum(c.get("t_lo"), 4), "t_hi": fnum(c.get("t_hi"), 4), "dist": dd,
                    "what": (c.get("what") or "the drive parameters change").rstrip("."),
                    "statistic": fnum(c.get("statistic"), 3), "critical": fnum(c.get("critical_0.1pct"), 3),
                    "residual": c.get("residual") or "motion",
                    "remains": ("It is still there with the named effects in the model: they do not explain it."
                                if rem else "It is gone once the named effects are in the model."
                                if rem is not None else "")})
    return {"ran": True, "points": pts}


def paired_ctx(p):
    out = {}
    for k in ("pose_err_m", "nll", "nis"):
        q = (p or {}).get(k)
        if isinstance(q, dict) and is_num(q.get("change_z")):
            better = (f"{int(q['blocks_better'])}/{int(q['blocks'])}"
                      if is_num(q.get("blocks_better")) and is_num(q.get("blocks")) else "")
            out[k] = {"z": f"{q['change_z']:+.1f}".replace("-", "−"), "better": better}
        else:
            out[k] = None
    return out


def before_after(h, key, scale, unit, sig=3):
    b = ((h or {}).get("before") or {}).get(key)
    a = ((h or {}).get("after") or {}).get(key)
    if not is_num(b) and not is_num(a):
        return "—"
    f = lambda v: fnum(v * scale, sig) if is_num(v) else "—"
    return f"{f(b)} → {f(a)}{(' ' + unit) if unit else ''}"


def left_text(x):
    if isinstance(x, dict):
        return x.get("words") or term_name(x)
    return str(x)


def auto_ctx(d):
    a = d.get("auto")
    if not isinstance(a, dict):
        return {"ran": False}
    steps = []
    for s in a.get("steps") or []:
        h = s.get("heldout") or {}
        est = s.get("estimate")
        est_l = []
        if isinstance(est, dict):
            for k, v in est.items():
                vals = v if isinstance(v, list) else [v]
                est_l.append(f"{k}: " + ", ".join(fnum(x, 3) for x in vals))
        ff = h.get("folds_failed") or []
        steps.append({"added": breakable(s.get("added") or "?"),
                      "pose": before_after(h, "pose_rmse_m", 100.0, "cm"),
                      "nll": before_after(h, "nll_mean", 1.0, "", 4),
                      "paired": paired_ctx(s.get("paired")), "estimate": est_l,
                      "explained": pct(s.get("explained_fraction")),
                      "left": [left_text(x) for x in (s.get("left") or [])],
                      "folds_failed": ", ".join(str(x) for x in ff)})
    not_kept = [{"step": (t.get("step") + 1) if is_num(t.get("step")) else "?",
                 "added": breakable(t.get("added") or "?"),
                 "paired": paired_ctx(t.get("paired"))}
                for t in a.get("tried") or [] if isinstance(t, dict) and not t.get("kept")]
    fw = a.get("final_with") or []
    return {"ran": True, "steps": steps, "not_kept": not_kept, "final_with": ",".join(str(x) for x in fw),
            "rule": (a.get("rule") or "").rstrip(".")}


def discovery_sections(d, disc, scans, plt, rng):
    """HTML of the three sections and the number of figures in it."""
    u = unexplained_ctx(d, disc, plt, rng)
    html = jinja_env().get_template("discovery.html.j2").render(
        u=u, c=change_points_ctx(d, scans), a=auto_ctx(d))
    return html, len(u.get("plots") or [])

"""HTML of the report's tables: tests, ranking, held-out, excitation, detection power, bins."""
import math

import numpy as np

from fmt import E, fnum, pm, fp, peq, fpct, fedge, table
from plots import BIN_LABEL, png_uri
from plots_discovery import fig_per_beam_t
from report_io import is_num


def estimate_cell(r):
    est, sg = r.get("estimate"), r.get("sigma")
    est = est if isinstance(est, list) else ([] if est is None else [est])
    sg = sg if isinstance(sg, list) else ([] if sg is None else [sg])
    if not est:
        return "—"
    pairs = [(e, sg[i] if i < len(sg) else None) for i, e in enumerate(est)]

    def one(i, e, s):
        lab = f"[{i}] " if len(pairs) > 1 else ""
        return f"{lab}{pm(e, s)}"
    if len(pairs) <= 3:
        return "<br>".join(one(i, e, s) for i, (e, s) in enumerate(pairs))
    z = [abs(e) / s if (is_num(e) and is_num(s) and s > 0) else 0.0 for e, s in pairs]
    top = [i for i in np.argsort(z)[::-1][:3] if z[i] > 2.0]
    head = "<br>".join(one(i, *pairs[i]) for i in sorted(top))
    rest = (f"{len(pairs)} values; " + ("the others" if top else "all") + " within 2σ of 0")
    full = "<br>".join(one(i, e, s) for i, (e, s) in enumerate(pairs))
    return (f"{head}{'<br>' if head else ''}<span class='small'>{rest}</span>"
            f"<details><summary class='small'>all values</summary><span class='small'>{full}</span></details>")


def summary_html(v, depth=0):
    """A nested JSON value as a small readable summary (never a JSON dump): numbers formatted,
    objects as 'key: value' lines, long lists shortened."""
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if is_num(v):
        return fnum(v, 4)
    if isinstance(v, str):
        return E(v)
    if isinstance(v, dict):
        if depth >= 2:
            return E(", ".join(f"{k}: {summary_html(x, 9)}" for k, x in v.items()))
        return ("<ul class='kvl'>" + "".join(f"<li><span class='k'>{E(str(k).replace('_', ' '))}</span> "
                                             f"{summary_html(x, depth + 1)}</li>" for k, x in v.items())
                + "</ul>")
    if isinstance(v, list):
        if all(is_num(x) for x in v):
            head = ", ".join(fnum(x, 3) for x in v[:6])
            return f"{len(v)} values: {head}{', …' if len(v) > 6 else ''}"
        return f"{len(v)} entries"
    return E(str(v))


def per_beam_cell(pb, max_t, plt):
    """The per-beam test: a small plot of t by beam and the beams beyond |t| = 3 in words."""
    rows = [e for e in pb if isinstance(e, dict)]
    ts = [(e.get("beam", i), e.get("t")) for i, e in enumerate(rows) if is_num(e.get("t"))]
    far = [(b, t) for b, t in ts if abs(t) > 3]
    txt = f"{len(rows)} beams"
    if ts:
        bmax, tmax = max(ts, key=lambda x: abs(x[1]))
        txt += f"; largest |t| = {abs(tmax):.1f} (beam {fnum(bmax, 0)})"
    if max_t is not None and not ts:
        txt += f"; largest |t| = {fnum(max_t, 3)}"
    txt += ("; beyond |t| 3: " + ", ".join(f"{fnum(b, 0)} ({t:+.1f})" for b, t in far[:8])
            + (f" and {len(far) - 8} more" if len(far) > 8 else "")) if far else "; none beyond |t| 3"
    img = ""
    if plt is not None and ts:
        img = (f'<img class="spark" src="{png_uri(plt, fig_per_beam_t(plt, rows))}" '
               f'alt="t statistic per beam">')
    return img + f"<div class='small'>{E(txt)}</div>"


def pose_correction_cell(pc):
    unit = {"along_m": ("along track", 1000.0, "mm"), "cross_m": ("cross track (left +)", 1000.0, "mm"),
            "heading_rad": ("heading", 1000.0, "mrad")}
    lines = []
    for k, q in pc.items():
        lab, sc, u = unit.get(k, (k.replace("_", " "), 1.0, ""))
        if not isinstance(q, dict):
            lines.append(f"<li><span class='k'>{E(lab)}</span> {summary_html(q)}</li>")
            continue
        m, r, t = q.get("mean"), q.get("rms"), q.get("t")
        flag = " <span class='bad'>biased</span>" if is_num(t) and abs(t) > 3 else ""
        lines.append(f"<li><span class='k'>{E(lab)}</span> mean {fnum(m * sc if is_num(m) else None, 3, u)}, "
                     f"RMS {fnum(r * sc if is_num(r) else None, 3, u)}, t {fnum(t, 2)}{flag}</li>")
    return "<ul class='kvl'>" + "".join(lines) + "</ul>"


def observables_cell(ob):
    lines = []
    if is_num(ob.get("updates")):
        lines.append(f"<li>{fnum(ob['updates'], 0)} updates</li>")
    for k, q in ob.items():
        if k == "updates":
            continue
        if q is None:
            lines.append(f"<li><span class='k'>{E(k)}</span> not observed</li>")
        elif isinstance(q, dict):
            lines.append(f"<li><span class='k'>{E(k)}</span> mean {fnum(q.get('mean_norm'), 3)}, "
                         f"mean square {fnum(q.get('mean_square_norm'), 3)}</li>")
        else:
            lines.append(f"<li><span class='k'>{E(k)}</span> {summary_html(q, 2)}</li>")
    return "<ul class='kvl'>" + "".join(lines) + "</ul>"


def tests_section(d, plt=None):
    t = d["tests"]
    rows = []
    band = t.get("nis_band")
    nm = t.get("nis_mean")
    if is_num(nm):
        inside = band is not None and band[0] <= nm <= band[1]
        flag = ("" if band is None else
                ("<span class='ok'>inside</span>" if inside else "<span class='bad'>outside</span>"))
        unc = t.get("nis_mean_uncapped")
        rows.append(["Mean NIS per beam", fnum(nm, 4) + (f"<div class='small'>uncapped {fnum(unc, 4)}</div>"
                                                         if is_num(unc) else ""),
                     f"{fnum(band[0], 4)} – {fnum(band[1], 4)} {flag}" if band else "about 1",
                     "1 when the filter's predicted uncertainty matches its real errors; above 1 it is "
                     "over-confident, below 1 too cautious. Each beam's NIS is capped at 25 so that a few "
                     "outliers do not dominate; the uncapped mean shows them."])
    if is_num(t.get("scans_outside_band_frac")):
        rows.append(["Scans outside their 95 % band", fpct(t["scans_outside_band_frac"]), "about 5 %",
                     "Share of scans whose summed NIS falls outside the chi-square band for their beam count."])
    if is_num(t.get("windowed_nis_outside_frac")):
        ws = t.get("windowed_nis_scans")
        rows.append([f"Windows{f' of {fnum(ws, 0)} scans' if is_num(ws) else ''} outside their band",
                     fpct(t["windowed_nis_outside_frac"]), "about 5 %",
                     "The same over sliding windows of scans: catches slow drifts that single scans hide."])
    lb = t.get("ljung_box")
    if isinstance(lb, dict):
        p = lb.get("p_value")
        flag = "" if not is_num(p) else (" <span class='bad'>correlated</span>" if p < 0.05
                                          else " <span class='ok'>no evidence</span>")
        rows.append([f"Ljung–Box whiteness ({fnum(lb.get('lags'), 0)} lags)",
                     f"Q = {fnum(lb.get('q'), 4)}, p {peq(p)}", f"p ≥ 0.05{flag}",
                     "Tests whether successive innovations are correlated in time; a small p means errors "
                     "repeat from scan to scan, the sign of a systematic effect."])
    if isinstance(t.get("per_beam"), list):
        rows.append(["Mean innovation per beam", (per_beam_cell(t["per_beam"], t.get("per_beam_max_abs_t"), plt),
                                                  "val"),
                     "|t| ≲ 3",
                     "For each beam index, the mean of its normalised innovations (ν/√S) over its standard "
                     "error. A beam far from 0 is biased: a trend across beams points to the laser (mount "
                     "yaw, angle scale), one odd beam to a fault or an obstacle."])
    elif is_num(t.get("per_beam_max_abs_t")):
        rows.append(["Largest |t| of a beam's mean innovation", fnum(t["per_beam_max_abs_t"], 3), "|t| ≲ 3",
                     "How far the most biased beam index is from an unbiased mean, in standard errors."])
    if isinstance(t.get("pose_correction"), dict):
        rows.append(["Pose correction per scan update", (pose_correction_cell(t["pose_correction"]), "val"),
                     "mean ≈ 0 (|t| ≲ 3)",
                     "How much each scan moved the pose estimate, in the robot frame. A correction that has "
                     "the same sign on average (large |t|) is something the odometry gets wrong every time."])
    if isinstance(t.get("of_observables"), dict):
        rows.append(["The OF's observables", (observables_cell(t["of_observables"]), "val"),
                     "mean 0, mean square 1",
                     "The odometry filter's observables minus their predicted means, normalised: a mean away "
                     "from 0 or a mean square away from 1 is a misfit of the OF's model."])
    for k, lab, what in (("nees_pose", "NEES of the pose", "pose"),
                         ("nees_params", "NEES of the parameters", "parameter")):
        if k in t:
            v = t[k]
            dof = t.get(f"{k}_dof")
            rows.append([lab, fnum(v, 4) if is_num(v) else "— (no truth in the log)",
                         f"about {fnum(dof, 0)} (its dimension)" if is_num(dof) else "about its dimension",
                         f"Squared {what} error against the truth, scaled by the filter's covariance."])
    if "nis_consistent" in t:
        v = t["nis_consistent"]
        rows.append(["NIS consistent", "—" if v is None else ("<span class='ok'>yes</span>" if v
                                                               else "<span class='bad'>no</span>"), "yes",
                     "Whether the mean NIS is inside its band."])
    counts = [(k, lab) for k, lab in (("innovations", "innovations"), ("scans", "scans"),
                                      ("beams_gated", "beams gated")) if is_num(t.get(k))]
    known = {"nis_mean", "nis_mean_uncapped", "nis_band", "scans_outside_band_frac", "windowed_nis_outside_frac",
             "windowed_nis_scans", "ljung_box", "per_beam", "per_beam_max_abs_t", "pose_correction",
             "of_observables", "nees_pose", "nees_params", "nees_pose_dof", "nees_params_dof", "nis_consistent"}
    known |= {k for k, _ in counts}
    for k, v in t.items():
        if k in known:
            continue
        rows.append([E(k.replace("_", " ")), (summary_html(v), "val" if not is_num(v) else "n"), "", ""])
    out = table(["test", "value", "expected", ("what it means", "expl")], rows, num_cols=(1,))
    if counts:
        out += ("<p class='small'>Computed on " + ", ".join(f"{fnum(t[k], 0)} {lab}" for k, lab in counts)
                + ".</p>")
    return out


def explains_cell(ex):
    """The share of discovery's misfit an effect explains: total, then motion / beam."""
    if not isinstance(ex, dict):
        return "—"
    tot = ex.get("total")
    parts = []
    for k in ("motion", "beam"):
        v = ex.get(k)
        parts.append(f"{k} {'—' if not is_num(v) else f'{100 * v:.0f} %'}")
    return ((f"<b>{100 * tot:.0f} %</b>" if is_num(tot) else "—")
            + f"<div class='small'>{' · '.join(parts)}</div>")


def ranking_section(ranking):
    rows, cls = [], []
    for i, r in enumerate(ranking):
        sig = bool(r.get("significant"))
        cls.append("sig" if sig else "")
        det = r.get("detectable")
        cw = r.get("confused_with") or []
        why = r.get("not_named_because")
        eff = f"{E(r['effect'])}<br><span class='small'>{E(str(r.get('description') or ''))}</span>"
        if why:
            eff += f"<div class='small notnamed'>not named: {E(str(why))}</div>"
        rows.append([
            str(i + 1),
            (eff, "eff"),
            "<span class='badge b-yes'>yes</span>" if sig else "<span class='badge b-no'>no</span>",
            f"{fnum(r.get('delta_loglik'), 4)}<div class='small'>{fnum(r.get('bic_gain'), 4)}</div>",
            fp(r.get("p_value")),
            fnum(r.get("informed_params"), 0),
            (estimate_cell(r), "n"),
            (explains_cell(r.get("explains")), "r"),
            "yes" if det else ("—" if det is None else "<span class='bad'>no</span>"),
            E(", ".join(cw)) if cw else "—",
        ])
    return table(["#", ("effect", "eff"), "significant", "Δ log-lik<div class='small'>BIC gain</div>", "p",
                  "params", "estimate ± σ", "explains<div class='small'>of the misfit</div>", "detectable",
                  "confused with"], rows, cls, num_cols=(0, 3, 4, 5))


def heldout_table(h):
    b, a = h["before"], h["after"]
    spec = [("nis_mean", "Mean NIS per beam", 1.0, "", 3),
            ("nll_mean", "Predictive NLL per innovation", 1.0, "", 4),
            ("innovation_rms_m", "Innovation RMS (beams inside the gate)", 1000.0, "mm", 3),
            ("pose_rmse_m", "Pose RMSE against truth", 100.0, "cm", 3),
            ("heading_rmse_rad", "Heading RMSE against truth", 180.0 / math.pi, "°", 3)]
    keys = [s[0] for s in spec] + [k for k in list(b) + list(a) if k not in [s[0] for s in spec]]
    rows = []
    seen = set()
    for k in keys:
        if k in seen:
            continue
        seen.add(k)
        s = next((x for x in spec if x[0] == k), (k, k.replace("_", " "), 1.0, "", 4))
        vb, va = b.get(k), a.get(k)
        if vb is None and va is None and k in ("pose_rmse_m", "heading_rmse_rad"):
            rows.append([s[1], "—", "—", "no truth in the log"])
            continue
        ch = "—"
        if is_num(vb) and is_num(va) and vb != 0:
            better = abs(va - 1.0) < abs(vb - 1.0) if k == "nis_mean" else va < vb
            # the NLL is a log: its change is a difference, not a percentage
            txt = f"{va - vb:+.4f}" if k == "nll_mean" else f"{100.0 * (va - vb) / abs(vb):+.1f} %"
            ch = f"<span class='{'ok' if better else 'bad'}'>{txt}</span>"
        f = lambda v: fnum(v * s[2], s[4], s[3]) if is_num(v) else "—"
        rows.append([s[1], f(vb), f(va), ch])
    out = table(["metric", "before", "after", "change"], rows, num_cols=(1, 2, 3))
    pr = h.get("paired") or {}
    lines = []
    for k, label in (("pose_err_m", "pose error"), ("nll", "NLL"), ("nis", "NIS")):
        q = pr.get(k)
        if isinstance(q, dict) and is_num(q.get("blocks")) and q["blocks"] > 0 and is_num(q.get("change_z")):
            lines.append(f"{label}: better in {int(q['blocks_better'])} of {int(q['blocks'])} blocks, "
                         f"paired z {q['change_z']:+.1f}")
    if lines:
        out += ("<p class='note'>Block by block (after minus before; z below −2 is a consistent fall): "
                + E("; ".join(lines)) + ".</p>")
    return out


def excitation_section(ex):
    if not ex:
        return "<p class='note'>No excitation analysis in diagnose.json.</p>"
    ps = ex.get("parameters") or []
    out = []
    if ps:
        rows, cls = [], []
        for p in ps:
            sa, pr = p.get("sigma_achievable"), p.get("prior_sigma")
            ratio = sa / pr if is_num(sa) and is_num(pr) and pr > 0 else None
            det = p.get("determined")
            cls.append("" if det or det is None else "undet")
            rows.append([E(str(p.get("name", "?"))), fnum(sa, 3), fnum(pr, 3),
                         "—" if ratio is None else f"{ratio:.2g}",
                         "—" if det is None else ("<span class='ok'>yes</span>" if det
                                                  else "<span class='bad'>no</span>")])
        out.append(table(["parameter", "achievable σ", "prior σ", "achievable / prior", "determined"],
                         rows, cls, num_cols=(1, 2, 3)))
    else:
        out.append("<p class='note'>No parameters listed.</p>")
    w = ex.get("warnings") or []
    out.append("<h3>Warnings about this drive</h3>")
    if w:
        out.append("<ul class='warn'>" + "".join(f"<li>{E(str(x))}</li>" for x in w) + "</ul>")
    else:
        out.append("<p class='note'>None: the drive excites every parameter enough.</p>")
    return "".join(out)


def power_section(dp):
    """The detection power: per family and parameter, the smallest size this drive would have
    revealed at the ranking's threshold, or why it could not."""
    if not dp:
        return "<p class='note'>No detection power in diagnose.json (an older odoerr): not run.</p>"
    rows, cls = [], []
    for f in dp.get("families") or []:
        for p in f.get("parameters") or []:
            mde, ref = p.get("min_detectable"), p.get("reference_size")
            excited = is_num(mde)
            cls.append("" if excited else "undet")
            rows.append([E(f"{f.get('family', '?')}.{p.get('name', '?')}"), E(str(f.get("kind", ""))),
                         fnum(mde, 3) if excited else "—", fnum(ref, 3),
                         f"{mde / ref:.2g}" if excited and is_num(ref) and ref > 0 else "—",
                         "" if excited else E(str(p.get("why", "not excited")))])
    if not rows:
        return "<p class='note'>No effect family listed.</p>"
    pw = dp.get("power")
    head = f"smallest detectable ({100 * pw:.0f} % power)" if is_num(pw) else "smallest detectable"
    out = table(["family.parameter", "kind", head, "reference size", "detectable / reference", "why not"],
                rows, cls, num_cols=(2, 3, 4))
    feats = dp.get("features")
    if not isinstance(feats, dict):
        return out + "<p class='note'>No feature terms in detection_power (an older odoerr).</p>"
    rows, cls = [], []
    for design in ("motion", "beam"):
        for t in (feats.get(design) or {}).get("terms") or []:
            mde = t.get("min_detectable")
            cls.append("" if is_num(mde) else "undet")
            rows.append([E(str(t.get("term", "?"))), E(design), fnum(mde, 3) if is_num(mde) else "—",
                         E(str(t.get("unit", ""))), "" if is_num(mde) else E(str(t.get("why", "not excited")))])
    out += ("<h3>The feature library's terms</h3><p class='cap'>" + E(str(feats.get("rule", ""))) +
            ": the smallest coefficient each term would have shown.</p>")
    return out + (table(["term", "residual", head, "unit", "why not"], rows, cls, num_cols=(2,)) if rows
                  else "<p class='note'>No feature terms (no rows to regress).</p>")


def bins_table(bins, names):
    parts = []
    for name in names:
        rows = []
        for e in bins[name]:
            rows.append([f"{fedge(e.get('lo'))} – {fedge(e.get('hi'))}", fnum(e.get("count"), 0),
                         fnum(e.get("nis_mean"), 3), fnum(e.get("mean_norm_innovation"), 3),
                         fnum(None if e.get("along_mean_m") is None else 1000 * e["along_mean_m"], 3),
                         fnum(None if e.get("cross_mean_m") is None else 1000 * e["cross_mean_m"], 3),
                         fnum(None if e.get("heading_mean_rad") is None else 1000 * e["heading_mean_rad"], 3)])
        lab, unit = BIN_LABEL.get(name, (name, ""))
        parts.append(f"<h3>{E(lab)} ({E(unit)})</h3>" + table(
            ["bin", "beams", "NIS mean", "mean norm. innovation", "along corr. (mm)", "cross corr. (mm)",
             "heading corr. (mrad)"], rows, num_cols=(1, 2, 3, 4, 5, 6)))
    return "".join(parts)

"""HTML of the report's tables: tests, ranking, held-out, excitation, bins."""
import json
import math

import numpy as np

from fmt import E, fnum, pm, fp, peq, fpct, fedge, table
from plots import BIN_LABEL
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


def tests_section(d):
    t = d["tests"]
    rows = []
    band = t.get("nis_band")
    nm = t.get("nis_mean")
    if is_num(nm):
        inside = band is not None and band[0] <= nm <= band[1]
        flag = ("" if band is None else
                ("<span class='ok'>inside</span>" if inside else "<span class='bad'>outside</span>"))
        rows.append(["Mean NIS per beam", fnum(nm, 4),
                     f"{fnum(band[0], 4)} – {fnum(band[1], 4)} {flag}" if band else "about 1",
                     "1 when the filter's predicted uncertainty matches its real errors; above 1 it is "
                     "over-confident, below 1 too cautious."])
    if is_num(t.get("scans_outside_band_frac")):
        rows.append(["Scans outside their 95 % band", fpct(t["scans_outside_band_frac"]), "about 5 %",
                     "Share of scans whose summed NIS falls outside the chi-square band for their beam count."])
    if is_num(t.get("windowed_nis_outside_frac")):
        rows.append(["Windows outside their band", fpct(t["windowed_nis_outside_frac"]), "about 5 %",
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
    for k, lab, what in (("nees_pose", "NEES of the pose", "pose"),
                         ("nees_params", "NEES of the parameters", "parameter")):
        if k in t:
            v = t[k]
            rows.append([lab, fnum(v, 4) if is_num(v) else "— (no truth in the log)", "about its dimension",
                         f"Squared {what} error against the truth, scaled by the filter's covariance."])
    known = {"nis_mean", "nis_band", "scans_outside_band_frac", "windowed_nis_outside_frac", "ljung_box",
             "nees_pose", "nees_params"}
    for k, v in t.items():
        if k in known:
            continue
        val = fnum(v, 4) if is_num(v) else E(json.dumps(v)[:120])
        rows.append([E(k.replace("_", " ")), val, "", ""])
    return table(["test", "value", "expected", "what it means"], rows, num_cols=(1,))


def ranking_section(ranking):
    rows, cls = [], []
    for i, r in enumerate(ranking):
        sig = bool(r.get("significant"))
        cls.append("sig" if sig else "")
        det = r.get("detectable")
        cw = r.get("confused_with") or []
        rows.append([
            str(i + 1),
            (f"{E(r['effect'])}<br><span class='small'>{E(str(r.get('description') or ''))}</span>", "eff"),
            "<span class='badge b-yes'>yes</span>" if sig else "<span class='badge b-no'>no</span>",
            fnum(r.get("delta_loglik"), 4), fnum(r.get("bic_gain"), 4), fp(r.get("p_value")),
            fnum(r.get("informed_params"), 0),
            (estimate_cell(r), "n"),
            "yes" if det else ("—" if det is None else "<span class='bad'>no</span>"),
            E(", ".join(cw)) if cw else "—",
        ])
    return table(["#", "effect", "significant", "Δ log-lik", "BIC gain", "p", "params", "estimate ± σ",
                  "detectable", "confused with"], rows, cls, num_cols=(0, 3, 4, 5, 6))


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

"""The report's headline: one or two sentences under the verdict that name what diagnose
found first (named effects, regions where the map is wrong, structure no catalogue effect
explains, change points) and only then what it looked for and did not find. An analysis
that diagnose.json does not hold (an older odoerr) is left out of both."""
from fmt import E, fnum
from report_io import is_num

MAP_WHAT = {"short": "something the map lacks", "long": "a wall gone, a door open or a wall drawn too near"}


def _xy(r):
    if is_num(r.get("x")) and is_num(r.get("y")):
        return f" at ({r['x']:.2f}, {r['y']:.2f}) m".replace("-", "−")
    return ""


def _region(k, r):
    """'R2 at (7.04, 3.14) m, 11,509 beams, short — something the map lacks'."""
    sign = r.get("sign") or "?"
    what = MAP_WHAT.get(sign)
    beams = f", {int(r['beams']):,} beams" if is_num(r.get("beams")) else ""
    return f"R{k + 1}{_xy(r)}{beams}, {sign}{f' — {what}' if what else ''}"


def _join(parts):
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def headline(d):
    """(found, not_found): lists of (html, plain text) items, found first in the order above."""
    found, missing = [], []
    named = [r["effect"] for r in d.get("ranking") or [] if isinstance(r, dict) and r.get("significant")]
    if named:
        t = f"named effect{'s' if len(named) > 1 else ''}: {', '.join(named)}"
        found.append((f"<a href='#ranking'>{E(t.split(':')[0])}</a>: <b>{E(', '.join(named))}</b>", t))
    else:
        missing.append(("no catalogue effect is named",) * 2)
    m = d.get("map_misfit")
    if isinstance(m, dict):
        regs = [r for r in m.get("regions") or [] if isinstance(r, dict)]
        if regs:
            big = max(range(len(regs)), key=lambda k: regs[k].get("beams") if is_num(regs[k].get("beams")) else -1)
            lead = f"{len(regs)} region{'s' if len(regs) > 1 else ''} where the map is wrong"
            rest = (f": {_region(big, regs[big])}" if len(regs) == 1 else f", the largest {_region(big, regs[big])}")
            found.append((f"<a href='#map-misfit'>{E(lead)}</a>{E(rest)}", f"{lead}{rest}"))
        else:
            missing.append(("the ranges agree with the map everywhere it was seen",) * 2)
    u = d.get("unexplained")
    if isinstance(u, dict):
        feats = [f for f in u.get("features") or [] if isinstance(f, dict)]
        if feats:
            w = str(feats[0].get("words") or feats[0].get("name") or "?")
            more = f" and {len(feats) - 1} more term{'s' if len(feats) > 2 else ''}" if len(feats) > 1 else ""
            lead = "structure no catalogue effect explains"
            found.append((f"<a href='#unexplained'>{E(lead)}</a>: {E(w)}{E(more)}", f"{lead}: {w}{more}"))
        else:
            missing.append(("nothing is left unexplained",) * 2)
    if "change_points" in d and isinstance(d.get("change_points"), list):
        cps = [c for c in d["change_points"] if isinstance(c, dict) and is_num(c.get("t"))]
        if cps:
            lead = f"{len(cps)} change point{'s' if len(cps) > 1 else ''}"
            at = "at t = " + ", ".join(fnum(c["t"], 4) for c in cps[:3]) + (" …" if len(cps) > 3 else "") + " s"
            found.append((f"<a href='#changes'>{E(lead)}</a> {E(at)}", f"{lead} {at}"))
        else:
            missing.append(("there is no change point",) * 2)
    return found, missing


def headline_html(d):
    """The headline paragraph (id 'headline'). With no verdict (insufficient data) it says
    what was missing and nothing else; what the verdict rests on that the reader must know
    (diagnose's verdict_caveats: encoder increments rejected) closes it."""
    caveats = [c for c in d.get("verdict_caveats") or [] if isinstance(c, str)]
    but = f" <b>But:</b> {E('; '.join(caveats))}." if caveats else ""
    if d.get("verdict") == "insufficient data":
        miss = "; ".join(m for m in d.get("verdict_missing") or [] if isinstance(m, str)) or "no test had data"
        return f"<p class='headline' id='headline'><b>No verdict: insufficient data.</b> {E(miss)}.{but}</p>"
    found, missing = headline(d)
    s = []
    if found:
        s.append("<b>Found:</b> " + "; ".join(h for h, _ in found) + ".")
        if missing:
            txt = _join([t for _, t in missing])
            s.append(E(txt[0].upper() + txt[1:]) + ".")
    elif missing:
        lead = "The model explains this log" if d.get("verdict") == "consistent" else "<b>Nothing specific found</b>"
        s.append(f"{lead}: {E(_join([t for _, t in missing]))}.")
    detail = d.get("verdict_detail")
    if d.get("verdict") == "consistent" and isinstance(detail, str) and detail.startswith("consistent: "):
        rest = detail[len("consistent: "):]
        s.append(f"<a href='#power'>{E(rest[0].upper() + rest[1:])}</a>.")
    return f"<p class='headline' id='headline'>{' '.join(s)}{but}</p>" if s or but else ""

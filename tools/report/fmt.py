"""Formatting numbers and small HTML pieces (tables, figures) for the report."""
import html
import math

from report_io import is_num

E = html.escape


def fnum(v, sig=3, unit=""):
    """v with sig significant digits (integers as they are); '—' for null / nan."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "—"
    v = float(v)
    a = abs(v)
    if v == int(v) and a < 1e15 and (a >= 1 or v == 0):
        s = f"{int(v)}"
    elif a >= 1e6 or a < 1e-4:
        s = f"{v:.{max(sig - 1, 1)}e}"
    else:
        s = f"{v:.{max(0, sig - 1 - int(math.floor(math.log10(a))))}f}"
        if "." in s:
            s = s.rstrip("0").rstrip(".")
    return s + (f" {unit}" if unit else "")


def pm(e, s):
    """'estimate ± sigma', sigma to 2 significant digits and the estimate to the same decimal."""
    if not is_num(e):
        return "—"
    if not is_num(s) or not math.isfinite(s) or s <= 0:
        return f"{fnum(e, 3)} ± {fnum(s, 2)}"
    if s >= 1e6 or s < 1e-6 or abs(e) >= 1e6:
        return f"{e:.2e} ± {s:.1e}"
    dec = max(0, 1 - int(math.floor(math.log10(s))))
    return f"{e:.{dec}f} ± {s:.{dec}f}"


def fp(v):
    """A p-value."""
    if v is None or not math.isfinite(v):
        return "—"
    if v < 1e-4:
        return "&lt; 0.0001" if v > 0 else "&lt; 1e-300"
    return f"{v:.4f}".rstrip("0").rstrip(".") if v < 0.1 else f"{v:.2f}"


def peq(v):
    """'= 0.03' or '< 0.0001'."""
    s = fp(v)
    return s if s.startswith("&lt;") else "= " + s


def fpct(v):
    return "—" if v is None else f"{100 * v:.1f} %"


def fedge(v):
    if v is None or not math.isfinite(v) or abs(v) >= 1e6:
        return "∞" if (v is None or v > 0) else "−∞"
    return f"{v:.3g}".replace("-", "−")


def table(headers, rows, row_classes=None, num_cols=()):
    """An HTML table. A header may be (text, class): the class goes on that column's cells
    (e.g. 'expl' for a column of sentences, which gets a minimum width). A cell may be
    (html, class). Wrapped in a div that scrolls sideways on a narrow screen."""
    col_cls = [x[1] if isinstance(x, tuple) else "" for x in headers]
    h = "".join(f'<th class="{x[1]}">{x[0]}</th>' if isinstance(x, tuple) else f"<th>{x}</th>" for x in headers)
    body = []
    for i, r in enumerate(rows):
        cls = f' class="{row_classes[i]}"' if row_classes and row_classes[i] else ""
        tds = []
        for j, cell in enumerate(r):
            cc = col_cls[j] if j < len(col_cls) else ""
            if isinstance(cell, tuple):          # (html, td class)
                tds.append(f'<td class="{cell[1]}">{cell[0]}</td>')
            elif j in num_cols:
                tds.append(f'<td class="n">{cell}</td>')
            else:
                tds.append(f'<td class="{cc}">{cell}</td>' if cc else f"<td>{cell}</td>")
        body.append(f"<tr{cls}>{''.join(tds)}</tr>")
    return f"<div class='tw'><table><thead><tr>{h}</tr></thead><tbody>{''.join(body)}</tbody></table></div>"


def figure(uri, alt, caption):
    return (f'<figure><img src="{uri}" alt="{E(alt)}"><figcaption>{caption}</figcaption></figure>')

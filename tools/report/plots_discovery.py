"""Figures of discovery and change points: partial residuals against a feature, change-point
marks on time-based plots, and the small per-beam plot of the tests table."""
import numpy as np

from plots import C_BAD, C_EST, C_NONSIG  # noqa: F401

def fig_partial(plt, x, p, coef, sigma, title, rng, max_scatter=3000, n_bins=12):
    """The partial residual of one selected term (the response less every other term's part)
    against the term's column, both standardised: a random subsample of the rows, the mean per
    equal-width bin with +-2 standard errors, and the fitted line of slope coef (+-2 sigma)."""
    ok = np.isfinite(x) & np.isfinite(p)
    x, p = x[ok], p[ok]
    fig, ax = plt.subplots(figsize=(5.8, 3.9), layout="constrained")
    ax.set_title(title, fontsize=9.5)
    ax.set_xlabel("the term's column (its effect with coefficient 1, standardised)")
    ax.set_ylabel("partial residual (standardised)")
    if x.size < 3:
        ax.text(0.5, 0.5, "no rows", transform=ax.transAxes, ha="center")
        return fig
    idx = rng.choice(x.size, max_scatter, replace=False) if x.size > max_scatter else np.arange(x.size)
    ax.scatter(x[idx], p[idx], s=5, color=C_NONSIG, alpha=0.45, lw=0,
               label=f"rows ({idx.size} of {x.size})" if idx.size < x.size else f"rows ({x.size})")
    lo, hi = np.percentile(x, [0.5, 99.5])
    if hi <= lo:
        lo, hi = float(x.min()), float(x.max()) + 1e-12
    edges = np.linspace(lo, hi, n_bins + 1)
    b = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, n_bins - 1)
    inside = (x >= lo) & (x <= hi)
    mids, means, ses = [], [], []
    for k in range(n_bins):
        m = inside & (b == k)
        if m.sum() >= 8:
            mids.append(float(np.mean(x[m])))
            means.append(float(np.mean(p[m])))
            ses.append(float(np.std(p[m], ddof=1) / np.sqrt(m.sum())))
    if mids:
        ax.errorbar(mids, means, yerr=2 * np.array(ses), fmt="o", ms=5, color=C_EST, ecolor=C_EST,
                    elinewidth=1.6, capsize=3, zorder=4, label="mean per bin ± 2 s.e.")
    xs = np.linspace(lo, hi, 50)
    if coef is not None:
        ax.plot(xs, coef * xs, color=C_BAD, lw=1.8, zorder=5, label=f"fitted: slope {coef:.3g}")
        if sigma is not None and sigma > 0:
            ax.fill_between(xs, (coef - 2 * sigma) * xs, (coef + 2 * sigma) * xs, color=C_BAD, alpha=0.15,
                            lw=0, zorder=3)
    ax.axhline(0, color="#444", lw=0.7)
    ylo, yhi = np.percentile(p, [1, 99])
    if means:
        ylo = min(ylo, min(means) - 2 * max(ses))
        yhi = max(yhi, max(means) + 2 * max(ses))
    if coef is not None:
        ylo, yhi = min(ylo, coef * lo, coef * hi), max(yhi, coef * lo, coef * hi)
    pad = 0.08 * (yhi - ylo if yhi > ylo else 1.0)
    ax.set_ylim(ylo - pad, yhi + pad)
    ax.set_xlim(lo - 0.03 * (hi - lo), hi + 0.03 * (hi - lo))
    ax.legend(loc="best", frameon=True, framealpha=0.85, fontsize=8)
    return fig


def fig_per_beam_t(plt, per_beam):
    """Small bar plot of each beam's t statistic (mean normalised innovation over its
    standard error), the bars beyond |t| = 3 in red."""
    beam = np.array([e.get("beam", i) for i, e in enumerate(per_beam)], float)
    t = np.array([e.get("t") if isinstance(e.get("t"), (int, float)) else np.nan for e in per_beam], float)
    fig, ax = plt.subplots(figsize=(5.2, 1.7), layout="constrained")
    far = np.abs(t) > 3
    ax.bar(beam, np.nan_to_num(t), width=0.85, color=np.where(far, C_BAD, C_EST))
    for y in (-3, 3):
        ax.axhline(y, color="#555", lw=0.7, ls="--")
    ax.axhline(0, color="#444", lw=0.6)
    ax.set_xlabel("beam index", fontsize=8)
    ax.set_ylabel("t", fontsize=8)
    ax.tick_params(labelsize=7.5)
    ax.set_xlim(beam.min() - 0.6 if beam.size else -0.6, beam.max() + 0.6 if beam.size else 0.6)
    return fig

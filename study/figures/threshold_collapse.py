"""The ``Q m1 ~ m`` scaling: minimum thresholds for many ``Q`` and ``M`` on one curve.

At resonance ``w^2 G = -i Q``, so ``a*_pm(f0) = g / sqrt(1 + x_pm^2)`` with
``x_pm = Q M cos(alpha) (cos(alpha) +- sin(alpha)/cs)``
(:func:`study.analysis.collapse_variable`). Main panel: the lowest threshold over the
file's frequency axis, ``min_f min(a*_+, a*_-) / g``, for every structure against
``x = max(|x_+|, |x_-|)``, log-log, with ``1 / sqrt(1 + x^2)`` in black. The minimum
over ``f`` sits slightly off resonance and below that value; for ``Q >> 1``,
``w^2 G`` runs on the circle of diameter ``Q`` through 0 and ``-i Q``, whose farthest
point from ``-1/K`` gives the envelope ``min_f a*/g = sqrt(1 + x^2/4) - x/2`` (dashed).
Both tend to ``1/x``: the paper's ``Q m1 ~ m``. Side panel: the same minima against
``M`` alone, one line per ``Q``: what the collapse removes.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from study.analysis import collapse_variable
from study.figures import FigureError
from study.figures.common import grid_minimum, save, structure_from_dataset

__all__ = ["draw"]

_AXES = ("Q", "M")

def _minima(dataset: xr.Dataset):
    """Per structure: its index, x, the minimum over f and whether it is at a range edge."""
    lower = np.minimum(dataset["a_star_plus"], dataset["a_star_minus"])
    dims = [d for d in lower.dims if d != "f"]
    extra = [d for d in dims if d not in _AXES]
    if extra:
        raise FigureError(
            "figure 'threshold-collapse' collapses the Q and M axes; this file also sweeps "
            f"{', '.join(extra)}"
        )
    lower = lower.transpose(*dims, "f").values
    f = dataset["f"].values
    rows = []
    for index in itertools.product(*(range(dataset.sizes[d]) for d in dims)):
        structure = structure_from_dataset(dataset, **dict(zip(dims, index, strict=True)))
        x = max(abs(v) for v in collapse_variable(structure))
        curve = lower[index]
        j, resolved = grid_minimum(f, curve, structure.f0, structure.Q)
        rows.append((dict(zip(dims, index, strict=True)), structure, x, curve[j] / structure.g,
                     not resolved))
    return dims, rows


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the collapse from a ``threshold-collapse`` result; returns the PNG and the PDF."""
    dims, rows = _minima(dataset)
    f = dataset["f"].values
    q_values = np.atleast_1d(dataset["Q"].values)
    colors = plt.cm.viridis(np.linspace(0.0, 0.85, q_values.size))
    by_q = "Q" in dims

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12.0, 5.4), layout="constrained",
                                 gridspec_kw={"width_ratios": [1.7, 1.0]})
    xs = np.array([r[2] for r in rows])
    ys = np.array([r[3] for r in rows])
    edge = np.array([r[4] for r in rows])
    for k, q in enumerate(q_values):
        pick = [i for i, r in enumerate(rows) if not by_q or r[0]["Q"] == k]
        inside = [i for i in pick if not edge[i]]
        ax.plot(xs[inside], ys[inside], "o", ms=6, color=colors[k], mec="k", mew=0.4,
                label=f"Q = {q:g}", zorder=3)
        outside = [i for i in pick if edge[i]]
        if outside:
            ax.plot(xs[outside], ys[outside], "o", ms=6, mfc="none", mec=colors[k], zorder=3)
    if edge.any():
        ax.plot([], [], "o", mfc="none", mec="k",
                label="not resolved: f step > $f_0/(10Q)$ or at the range edge (upper bound)")
    span = np.geomspace(min(xs.min(), 1e-2) / 2, max(xs.max(), 10.0) * 2, 400)
    ax.plot(span, 1.0 / np.hypot(1.0, span), color="k", lw=1.6, zorder=2,
            label="closed form at $f_0$: $1/\\sqrt{1+x^2}$")
    ax.plot(span, np.sqrt(1.0 + span**2 / 4) - span / 2, color="0.35", lw=1.1, ls="--",
            zorder=4, label="min over f for $Q \\gg 1$: $\\sqrt{1+x^2/4} - x/2$")
    ratio = ys / (1.0 / np.hypot(1.0, xs))
    good = ~edge
    if good.any():
        worst = int(np.argmax(np.where(good, np.abs(ratio - 1), -1.0)))
        large = good & (xs > 20)
        note = (f"resolved minima / closed form at $f_0$: {ratio[good].min():.3f} .. "
                f"{ratio[good].max():.3f}\nlargest gap {100 * abs(ratio[worst] - 1):.1f} % "
                f"at x = {xs[worst]:.2g}")
        if large.any():
            note += f"; < {100 * np.max(np.abs(ratio[large] - 1)):.2g} % for x > 20"
    else:
        note = "no minimum resolved by the f grid"
    if edge.any():
        note += f"\n{int(edge.sum())} of {edge.size} minima not resolved by the f grid"
    ax.text(0.03, 0.04, note, transform=ax.transAxes, fontsize=8, va="bottom",
            bbox={"facecolor": "white", "edgecolor": "0.7", "alpha": 0.9})
    ax.set(xscale="log", yscale="log", xlim=(span[0], span[-1]),
           xlabel="collapse variable $x = \\max|x_\\pm|$, "
                  "$x_\\pm = Q M \\cos\\alpha(\\cos\\alpha \\pm \\sin\\alpha / c_s)$ [1]",
           ylabel="minimum threshold over f, $a^*_{min}/g$ [1]",
           title="Minimum thresholds collapse on the resonance closed form")
    ax.legend(loc="upper right", fontsize=8, framealpha=0.9)

    # Side panel: the same minima against M alone.
    if "M" in dims:
        m_values = dataset["M"].values
        for k, q in enumerate(q_values):
            pick = [i for i, r in enumerate(rows) if not by_q or r[0]["Q"] == k]
            order = sorted(pick, key=lambda i: rows[i][0]["M"])
            ms = m_values[[rows[i][0]["M"] for i in order]]
            bx.plot(ms, ys[order], "-", lw=1.2, color=colors[k], label=f"Q = {q:g}")
            bx.plot(ms, np.where(edge[order], np.nan, ys[order]), "o", ms=3.5, color=colors[k])
            bx.plot(ms, np.where(edge[order], ys[order], np.nan), "o", ms=4, mfc="none",
                    mec=colors[k])
        bx.set(xscale="log", xlabel="mass ratio M = m$_1$/m [1]")
    else:
        bx.plot(np.atleast_1d(dataset["M"].values).repeat(len(rows)), ys, "o",
                color=colors[0], label=f"Q = {q_values[0]:g}")
        bx.set(xlabel="mass ratio M = m$_1$/m [1]")
    bx.set(yscale="log", ylabel="minimum threshold over f, $a^*_{min}/g$ [1]",
           title="The same minima against M alone\n(not collapsed)")
    bx.legend(loc="lower left", fontsize=8, framealpha=0.9)

    s = rows[0][1]
    title = (
        f"Q m1 ~ m: minimum motion threshold over f in [{f[0]:g}, {f[-1]:g}] Hz for "
        f"{len(rows)} structures (f0 = {s.f0:g} Hz, alpha = {s.alpha:g} deg, cs = {s.cs:g})"
    )
    fig.suptitle(title, fontsize=11)
    return save(fig, output, dataset, title)

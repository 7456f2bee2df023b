"""The ``Q m1 ~ m`` scaling: minimum thresholds for many ``Q`` and ``M`` on one curve.

At resonance ``w^2 G = -i Q``, so ``a*_pm(f0) = g / sqrt(1 + x_pm^2)`` with
``x_pm = Q M cos(alpha) (cos(alpha) +- sin(alpha)/cs)``
(:func:`study.analyses.thresholds.collapse_variable`). Main panel: the lowest threshold over the
file's frequency axis, ``min_f min(a*_+, a*_-) / g``, for every structure against
``x = max(|x_+|, |x_-|)``, log-log, with ``1 / sqrt(1 + x^2)`` in black. The minimum
over ``f`` sits slightly off resonance and below that value; for ``Q >> 1``,
``w^2 G`` runs on the circle of diameter ``Q`` through 0 and ``-i Q``, whose farthest
point from ``-1/K`` gives the envelope ``min_f a*/g = sqrt(1 + x^2/4) - x/2`` (dashed).
Both tend to ``1/x``: the paper's ``Q m1 ~ m``. Side panel: the same minima against
``M`` alone, one line per ``Q`` (against ``Q`` when only ``Q`` is swept): what the
collapse removes. The structures are coloured by ``Q`` when it is swept (else by
``M``); more than 8 values get a colour bar instead of a legend entry each.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.colors import LogNorm, Normalize
from matplotlib.ticker import NullFormatter

from study.analyses.thresholds import collapse_variable
from study.figures.common import (
    grid_minimum,
    require_axis,
    require_dims,
    save,
    selection_text,
    structure_from_dataset,
    structure_text,
    value_colours,
)

__all__ = ["draw"]

_AXES = ("Q", "M")


def _minima(dataset: xr.Dataset):
    """Per structure: its index, x, the minimum over f and whether it is at a range edge."""
    lower = np.minimum(dataset["a_star_plus"], dataset["a_star_minus"])
    dims = [d for d in lower.dims if d != "f"]
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


@dataclass(frozen=True)
class _Colouring:
    """The structures' colours: by ``Q`` when it is swept, else by ``M``; ``groups``
    lists the rows (structures) of each value."""

    by: str
    values: np.ndarray
    colors: list
    bar: object  # a ScalarMappable for a colour bar, or None: a legend entry each
    groups: list[list[int]]


def _colouring(dataset: xr.Dataset, dims: list[str], rows: list) -> _Colouring:
    """Colour by Q when it is swept, else by M: one legend entry each, or a colour bar."""
    by = "Q" if "Q" in dims else ("M" if "M" in dims else "Q")
    c_values = np.atleast_1d(dataset[by].values).astype(float)
    spread = c_values.max() / c_values.min() if c_values.min() > 0 else 1.0
    norm = (LogNorm(c_values.min(), c_values.max()) if spread > 10 else
            Normalize(c_values.min(), c_values.max() if c_values.max() > c_values.min()
                      else c_values.min() + 1.0))
    colors, bar = value_colours(c_values, norm=norm)
    swept = by in dims
    groups = [[i for i, r in enumerate(rows) if not swept or r[0][by] == k]
              for k in range(c_values.size)]
    return _Colouring(by, c_values, colors, bar, groups)


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the collapse from a ``threshold-collapse`` result; returns the PNG and the PDF."""
    dataset = require_dims(dataset, "threshold-collapse", ("f", *_AXES),
                           "minimum thresholds over the Q and M axes", variable="a_star_plus")
    require_axis(dataset, "threshold-collapse", "f",
                 "the minimum of the thresholds over f for each structure")
    dims, rows = _minima(dataset)
    f = dataset["f"].values
    colouring = _colouring(dataset, dims, rows)

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12.0, 5.4), layout="constrained",
                                 gridspec_kw={"width_ratios": [1.7, 1.0]})
    _collapse_panel(ax, rows, colouring)
    _side_panel(bx, dataset, dims, rows, colouring)
    if colouring.bar is not None:
        fig.colorbar(colouring.bar, ax=bx, pad=0.01,
                     label=f"{colouring.by} ({colouring.values.size} values)")

    # Thresholds do not depend on ck.
    title = (
        f"Q m1 ~ m: minimum motion threshold over f in [{f[0]:g}, {f[-1]:g}] Hz for "
        f"{len(rows)} structures ({structure_text(dataset, omit=('ck',), tex=False)})"
    )
    selected = selection_text(dataset)
    fig.suptitle(title + (f"\n{selected}" if selected else ""), fontsize=11)
    return save(fig, output, dataset, title)


def _collapse_panel(ax: plt.Axes, rows: list, colouring: _Colouring) -> None:
    """Main panel: every structure's minimum against x, log-log, with the closed forms
    and a note on how far the resolved minima lie from them."""
    by, colors, bar = colouring.by, colouring.colors, colouring.bar
    xs = np.array([r[2] for r in rows])
    ys = np.array([r[3] for r in rows])
    edge = np.array([r[4] for r in rows])
    for k, value in enumerate(colouring.values):
        pick = colouring.groups[k]
        inside = [i for i in pick if not edge[i]]
        ax.plot(xs[inside], ys[inside], "o", ms=6 if len(rows) <= 200 else 3.5,
                color=colors[k], mec="k", mew=0.4,
                label=None if bar is not None else f"{by} = {value:g}", zorder=3)
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
    ax.text(0.03, 0.04, _gap_note(xs, ys, edge), transform=ax.transAxes, fontsize=8,
            va="bottom", bbox={"facecolor": "white", "edgecolor": "0.7", "alpha": 0.9})
    ax.set(xscale="log", yscale="log", xlim=(span[0], span[-1]),
           xlabel="collapse variable $x = \\max|x_\\pm|$, "
                  "$x_\\pm = Q M \\cos\\alpha(\\cos\\alpha \\pm \\sin\\alpha / c_s)$ [1]",
           ylabel="minimum threshold over f, $a^*_{min}/g$ [1]",
           title="Minimum thresholds collapse on the resonance closed form")
    ax.legend(loc="best", fontsize=8, framealpha=0.9)


def _gap_note(xs: np.ndarray, ys: np.ndarray, edge: np.ndarray) -> str:
    """How far the resolved minima lie from the closed form at resonance, and how many
    the f grid does not resolve."""
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
    return note


def _side_panel(bx: plt.Axes, dataset: xr.Dataset, dims: list[str], rows: list,
                colouring: _Colouring) -> None:
    """Side panel: the same minima against M alone (or Q, when only Q is swept)."""
    by, colors, bar = colouring.by, colouring.colors, colouring.bar
    ys = np.array([r[3] for r in rows])
    edge = np.array([r[4] for r in rows])
    along = "M" if "M" in dims else ("Q" if "Q" in dims else "M")
    axis_values = np.atleast_1d(dataset[along].values)
    if along == by:  # one line through every structure, coloured point by point
        order = sorted(range(len(rows)), key=lambda i: rows[i][0].get(along, 0))
        xv = axis_values[[rows[i][0].get(along, 0) for i in order]]
        bx.plot(xv, ys[order], "-", lw=1.0, color="0.6", zorder=1)
        bx.scatter(xv, ys[order], s=22, zorder=2, edgecolors="k", linewidths=0.4,
                   c=[colors[rows[i][0].get(by, 0)] for i in order])
    for k, value in enumerate(colouring.values if along != by else []):
        order = sorted(colouring.groups[k], key=lambda i: rows[i][0].get(along, 0))
        xv = axis_values[[rows[i][0].get(along, 0) for i in order]]
        bx.plot(xv, ys[order], "-", lw=1.2, color=colors[k],
                label=None if bar is not None else f"{by} = {value:g}")
        bx.plot(xv, np.where(edge[order], np.nan, ys[order]), "o", ms=3.5, color=colors[k])
        bx.plot(xv, np.where(edge[order], ys[order], np.nan), "o", ms=4, mfc="none",
                mec=colors[k])
    names = {"M": "mass ratio M = m$_1$/m [1]", "Q": "quality factor Q [1]"}
    bx.set(xscale="log" if along in dims else "linear", xlabel=names[along])
    bx.xaxis.set_minor_formatter(NullFormatter())
    bx.set(yscale="log", ylabel="minimum threshold over f, $a^*_{min}/g$ [1]",
           title=f"The same minima against {along} alone\n(not collapsed)")
    if bx.get_legend_handles_labels()[0]:
        bx.legend(loc="lower left", fontsize=8, framealpha=0.9)

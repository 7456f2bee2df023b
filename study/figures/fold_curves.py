"""Where the forward and backward hops coexist: their fold curves over the drive plane.

Drawn from a study swept slowly along ``f`` both ways with the ``jumps`` observable
over one structure axis (workflow ``mass-ratio-folds``: the mass ratio ``M``). For each
value of that axis, in one colour: the forward hop's fold ``f(a)`` (solid, where the
sweep up leaves a forward motion for a backward one) and the backward hop's fold
(dashed, where the sweep down leaves a backward motion for a forward one), each point
located on the branch exactly (:func:`study.analyses.hop_folds.hop_folds`), and the
band between them where both hops exist, shaded; a band reaching the grid's end is
drawn to it with an open end marked. Beside it, the lowest acceleration at which the
two coexist against the structure axis: the one below which a structure shows one
motion whatever its history.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from study.analyses.hop_folds import EDGES, hop_folds
from study.figures.common import coupling_label, save, selection_text, structure_text

__all__ = ["compose", "draw", "onset"]

#: The structure axes the figure can draw the curves over, and their labels.
_AXES = {"M": "mass ratio M", "Q": "quality factor Q", "cs": "c$_s$", "alpha":
         "alpha [degree]", "f0": "f$_0$ [Hz]"}


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the fold-curves figure; returns the PNG and PDF.

    Parameters
    ----------
    dataset : xarray.Dataset
        A study swept slowly along ``f`` both ways with the ``jumps`` observable
        (``direction``, a structure axis, ``f``, ``a``).
    output : pathlib.Path
        File stem.
    """
    fig, title = compose(dataset)
    return save(fig, output, dataset, title)


def onset(folds: xr.Dataset) -> xr.DataArray:
    """The lowest acceleration [m s-2] at which both hops exist somewhere in ``f``, for
    each value of the other dimensions of :func:`~study.analyses.hop_folds.hop_folds`'s
    result (NaN where they never do on the grid)."""
    coexist = np.isfinite(folds["coexistence_width"])
    lowest = folds["a"].where(coexist).min("a")
    return lowest.assign_attrs(units="m s-2", long_name="lowest drive acceleration at "
                               "which the forward and backward hops coexist")


def compose(dataset: xr.Dataset) -> tuple[plt.Figure, str]:
    """The figure of :func:`draw`, not saved, and its one-line title."""
    from study.figures import FigureError

    try:
        folds = hop_folds(dataset)
    except ValueError as error:
        raise FigureError(f"figure 'fold-curves': {error}") from None
    over = [d for d in folds["coexistence_width"].dims if d != "a"]
    if len(over) > 1:
        raise FigureError(f"figure 'fold-curves' draws the curves over one structure axis; "
                          f"this file sweeps {', '.join(over)}: select all but one with "
                          "--sel")
    if "a" not in folds.dims or folds.sizes["a"] < 2:
        raise FigureError("figure 'fold-curves' draws curves over a, which needs several "
                          "values of a")
    axis = over[0] if over else None
    values = folds[axis].values if axis else np.array([np.nan])
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.9, max(values.size, 1)))
    fig, (plane, side) = plt.subplots(1, 2, figsize=(12.0, 6.0), layout="constrained",
                                      width_ratios=(2.2, 1.0))
    f = dataset["f"].values
    a = folds["a"].values
    for k, value in enumerate(values):
        at = folds.isel({axis: k}) if axis else folds
        label = f"{axis} = {value:g}" if axis else ""
        colour = colours[k]
        low, high = at["coexistence_low"].values, at["coexistence_high"].values
        plane.fill_betweenx(a, low, high, where=np.isfinite(low) & np.isfinite(high),
                            color=colour, alpha=0.18, linewidth=0)
        for name, style, what in (("forward_fold_f", "-o", "forward"),
                                  ("backward_fold_f", "--s", "backward")):
            curve = at[name].values
            if np.isfinite(curve).any():  # a value without a fold names none in the legend
                plane.plot(curve, a, style, color=colour, markersize=3, linewidth=1.3,
                           label=f"{label}: {what} hop's fold")
        for name, edges in (("coexistence_low", at["coexistence_low_edge"].values),
                            ("coexistence_high", at["coexistence_high_edge"].values)):
            ends = edges == EDGES.index("grid_end")
            if ends.any():
                plane.plot(at[name].values[ends], a[ends], ">" if name.endswith("high")
                           else "<", color=colour, markersize=5, linestyle="none")
    plane.set_xlim(f[0], f[-1])
    plane.set_xlabel("drive frequency f [Hz]")
    plane.set_ylabel("drive acceleration a [m s$^{-2}$]")
    plane.set_title("fold curves (each point located exactly); shaded: both hops exist;\n"
                    "an arrow: the band reaches the grid's end", fontsize=9)
    plane.legend(fontsize=7, loc="upper right", ncols=1 if values.size < 4 else 2)
    lowest = onset(folds)
    never = ~np.isfinite(np.atleast_1d(lowest.values))
    x = values if axis else np.array([0.0])
    lowest_values = np.atleast_1d(lowest.values)
    side.plot(x[~never], lowest_values[~never], "o-", color="black")
    floor = lowest_values == a[0]
    if floor.any():
        # At the grid's lowest acceleration: they may coexist below it too.
        side.plot(x[floor], lowest_values[floor], "v", color="black", markersize=9,
                  linestyle="none", label=f"at the grid's lowest a ({a[0]:g} m s$^{{-2}}$): "
                  "perhaps lower")
    if never.any():
        side.plot(x[never], np.full(int(never.sum()), a[-1]), "x", color="tab:red",
                  markersize=8, linestyle="none",
                  label=f"no coexistence up to a = {a[-1]:g} m s$^{{-2}}$")
    if never.any() or floor.any():
        side.legend(fontsize=8, loc="upper right")
    side.set_ylim(a[0] - 0.05 * (a[-1] - a[0]), a[-1] + 0.05 * (a[-1] - a[0]))
    side.set_xlabel(_AXES.get(axis, axis or ""))
    side.set_ylabel("lowest a where both hops exist [m s$^{-2}$]")
    side.set_title(_summary(values, np.atleast_1d(lowest.values), axis), fontsize=9)
    selected = selection_text(dataset)
    head = "Where the forward and backward hops coexist: their folds"
    fig.suptitle(f"{head}\n{coupling_label(dataset)}\n{structure_text(dataset)}"
                 + (f"\n{selected}" if selected else ""), fontsize=11)
    return fig, (f"Fold curves of the forward and backward hops, {coupling_label(dataset)} "
                 f"({structure_text(dataset, tex=False)})")


def _summary(values: np.ndarray, lowest: np.ndarray, axis: str | None) -> str:
    """Where the coexistence begins along the structure axis, in words."""
    if axis is None:
        return ""
    present = np.isfinite(lowest)
    if present.all():
        return f"both hops coexist at every {axis} drawn"
    if not present.any():
        return f"the hops coexist at no {axis} drawn"
    first = int(np.flatnonzero(present)[0])
    if first > 0 and not present[:first].any():
        return (f"they coexist from {axis} = {values[first]:g} on\n(not at "
                f"{axis} = {values[first - 1]:g})")
    return f"they coexist at {present.sum()} of {values.size} values of {axis}"

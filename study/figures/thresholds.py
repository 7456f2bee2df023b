"""The paper's Fig. 1B: motion thresholds a*_+ and a*_- against drive frequency.

Drawn from a ``thresholds`` result file alone (``study figure thresholds FILE``): the
thresholds, the lift-off acceleration and the mode's resonance curve behind them; with
``--measurements lab.csv`` the measured thresholds with their error bars
(:mod:`study.figures.measured`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.patches import Patch

from study.figures import common, measured
from study.figures.common import (
    parameter_text,
    require_axis,
    single_structure,
    structure_text,
)
from study.model.forces import lift_off_acceleration

__all__ = ["axis_top", "draw"]


def draw(dataset: xr.Dataset, output: Path,
         measurements: Sequence[str | Path] | None = None) -> list[Path]:
    """Draw the thresholds of a ``thresholds`` result into ``output.png/.pdf``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result holding a_star_plus, a_star_minus and mode_gain over f (the
        lift-off acceleration is read from it, else evaluated in closed form for
        the structure stored in it).
    output : pathlib.Path
        File stem.
    measurements : sequence of paths, optional
        Measurement files whose ``threshold`` rows (of this structure) are drawn with
        their error bars, marker by direction.

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    dataset = single_structure(dataset, "thresholds")
    require_axis(dataset, "thresholds", "f", "the thresholds against f")
    structure = common.structure_from_dataset(dataset)
    f = dataset["f"].values
    a_plus = dataset["a_star_plus"].values
    a_minus = dataset["a_star_minus"].values
    gain = dataset["mode_gain"].values
    if "lift_off_acceleration" in dataset:
        a_lift = dataset["lift_off_acceleration"].values
    else:
        a_lift = lift_off_acceleration(structure, f)
    lowest = np.fmin(a_plus, a_minus)
    top = axis_top(dataset, lowest, a_lift, structure.g)
    data = rows = None
    if measurements:
        data = measured.load(measurements)
        rows = measured.same_structure(data, measured.pick(data, "threshold", "thresholds"),
                                       dataset, "thresholds")
        high = data["value"].values[rows] + np.nan_to_num(data["sigma"].values[rows])
        top = max(top, 1.1 * float(np.max(high)))
    flight = common.is_flight(dataset)

    fig, ax = plt.subplots(figsize=(7.5, 5.0), layout="constrained")
    _mode_gain_behind(ax, f, gain)

    ax.fill_between(f, 0.0, np.fmin(lowest, top), color="tab:green", alpha=0.12, lw=0)
    if not flight:  # with flight the model follows the base past lift-off: still valid
        ax.fill_between(f, np.fmin(a_lift, top), top, facecolor="none", edgecolor="0.6",
                        hatch="///", lw=0)
    ax.axhline(structure.g, color="0.45", lw=0.8, ls=":")
    ax.text(f[0] + 0.7 * (f[-1] - f[0]), structure.g, "g", va="top", color="0.35",
            fontsize=10)
    curves = ((a_plus, "tab:blue", "-", 2.0), (a_minus, "tab:red", "-", 2.0),
              (a_lift, "black", "--", 1.4))
    left = False
    for curve, colour, style, width in curves:
        ax.plot(f, curve, color=colour, lw=width, ls=style)
        left |= _mark_exits(ax, f, curve, top, colour)
    own = _own_lift_off(dataset)
    if own is not None:
        ax.plot(f, own, ls="none", marker="o", ms=3.0, mfc="none", mec="black", mew=0.8,
                zorder=4)
    xlim = (float(f[0]), float(f[-1]))
    if rows is not None:
        colour = {"forward": "tab:blue", "backward": "tab:red", "unknown": "white"}
        directions = data["direction"].values.astype(str)[rows]
        measured.draw_rows(ax, data, rows, "f", colours=[colour[d] for d in directions])
        xs = data["f"].values[rows]
        xlim = (min(xlim[0], float(xs.min()) - 0.2), max(xlim[1], float(xs.max()) + 0.2))
    ax.set(xlim=xlim, ylim=(0.0, top), xlabel="drive frequency f [Hz]",
           ylabel="drive acceleration a [m s$^{-2}$]")

    title = "Motion thresholds against drive frequency"
    if rows is not None:
        title += f", with {rows.size} measured"
    # Thresholds, lift-off and the mode's gain do not depend on ck.
    ax.set_title(f"{title}\n{parameter_text(dataset, omit=('ck',))}", fontsize=11)
    handles = _legend_handles(dataset, data, rows, left, own is not None)
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=8.5,
               frameon=False)
    return common.save(fig, output, dataset,
                       f"{title} ({structure_text(dataset, omit=('ck',), tex=False)})")


def _mode_gain_behind(ax: plt.Axes, f: np.ndarray, gain: np.ndarray) -> None:
    """The mode's gain over f [1], shaded on a twin axis behind the thresholds."""
    behind = ax.twinx()
    # The resonance curve sits behind the thresholds: the twin axis is drawn first.
    ax.set_zorder(behind.get_zorder() + 1)
    ax.patch.set_visible(False)
    behind.fill_between(f, 0.0, gain, color="0.88", lw=0)
    behind.plot(f, gain, color="0.65", lw=0.8)
    behind.set_ylim(0.0, 1.15 * float(np.nanmax(gain)))
    behind.set_ylabel(r"mode gain $|\omega_0^2 G|$ [1]", color="0.4")
    behind.tick_params(axis="y", colors="0.4")


def axis_top(dataset: xr.Dataset, lowest: np.ndarray, a_lift: np.ndarray,
             g: float) -> float:
    """The top of the acceleration axis [m s-2]: the study's own range of ``a`` where the
    file sweeps it (a map); else room above the thresholds and the lift-off, but never
    above a sensible range, the larger of 2 g and 1.5 times the lowest threshold (a
    threshold or lift-off that diverges, as a*_- does where the forces cannot reach
    a backward slip, would squash the rest). Curves that leave it are marked."""
    if "a" in dataset.dims and dataset.sizes["a"] > 1:
        return float(np.max(dataset["a"].values))
    finite = lowest[np.isfinite(lowest)]
    lift = a_lift[np.isfinite(a_lift)]
    room = max(1.25 * float(np.max(lift, initial=0.0)),
               1.15 * float(np.max(finite, initial=0.0)), 1.1 * g)
    sensible = max(2.0 * g, 1.5 * float(np.min(finite, initial=0.0)),
                   1.25 * float(np.min(lift, initial=0.0)))
    return min(room, sensible)


def _mark_exits(ax: plt.Axes, f: np.ndarray, curve: np.ndarray, top: float,
                colour) -> bool:
    """An arrowhead on the axis's top edge wherever ``curve`` leaves it (or comes back):
    between the two grid frequencies it crosses ``top`` at, interpolated linearly where
    both are finite. Returns whether it leaves it anywhere."""
    above = ~(curve <= top)  # NaN or infinite: beyond any axis
    crossings = np.flatnonzero(above[1:] != above[:-1])
    for i in crossings:
        low, high = curve[i], curve[i + 1]
        if np.isfinite(low) and np.isfinite(high) and high != low:
            where = f[i] + (top - low) / (high - low) * (f[i + 1] - f[i])
        else:
            where = 0.5 * (f[i] + f[i + 1])
        ax.plot(where, 1.0, marker="^", ms=7, color=colour, mec="black", mew=0.5,
                transform=ax.get_xaxis_transform(), clip_on=False, zorder=6)
    if above[0] and np.isfinite(curve[0]):
        ax.plot(f[0], 1.0, marker="^", ms=7, color=colour, mec="black", mew=0.5,
                transform=ax.get_xaxis_transform(), clip_on=False, zorder=6)
    return bool(above.any())


def _own_lift_off(dataset: xr.Dataset) -> np.ndarray | None:
    """A two-way study's own lift-off over f: the lowest ``a`` of its map where its
    motion leaves the table (:func:`~study.figures.common.leaves_the_table`), NaN
    where it never does; None for a file without such a map."""
    if (not common.is_two_way(dataset) or "status" not in dataset
            or set(dataset["status"].dims) != {"f", "a"} or dataset.sizes["a"] < 2):
        return None
    status = dataset["status"].transpose("f", "a").values
    airborne = (dataset["airborne_fraction"].transpose("f", "a").values
                if "airborne_fraction" in dataset else None)
    leaves = common.leaves_the_table(status, airborne)
    a = dataset["a"].values
    first = np.where(leaves.any(axis=1), a[np.argmax(leaves, axis=1)], np.nan)
    return first if np.isfinite(first).any() else None


def _legend_handles(dataset: xr.Dataset, data: xr.Dataset | None, rows: np.ndarray | None,
                    left: bool, own: bool) -> list:
    """The legend: the curves and regions drawn, and a marker per direction measured."""
    two_way = common.is_two_way(dataset)
    if two_way:
        lift = "lift-off of a base at rest (one-way estimate)"
    else:
        lift = "lift-off acceleration (n < 0 above)"
    handles = [
        plt.Line2D([], [], color="tab:blue", lw=2.0, label="$a^*_+$: forward slips start"),
        plt.Line2D([], [], color="tab:red", lw=2.0, label="$a^*_-$: backward slips start"),
        plt.Line2D([], [], color="black", lw=1.4, ls="--", label=lift),
        Patch(facecolor="tab:green", alpha=0.12, label=r"static: $a < \min(a^*_+, a^*_-)$"),
    ]
    if not common.is_flight(dataset):
        handles.append(Patch(facecolor="none", edgecolor="0.6", hatch="///",
                             label="lift-off: model invalid" if not two_way else
                             "above: outside the model (no flight)"))
    handles.append(Patch(facecolor="0.88", edgecolor="0.65", lw=0.8,
                         label=r"mode gain $|\omega_0^2 G|$ (right axis)"))
    if own:
        handles.append(plt.Line2D([], [], ls="none", marker="o", ms=4, mfc="none",
                                  mec="black",
                                  label="this study: the base leaves\nthe table "
                                        "from this a up"))
    if left:
        handles.append(plt.Line2D([], [], ls="none", marker="^", ms=7, color="0.5",
                                  mec="black", mew=0.5,
                                  label="a curve leaves the axis"))
    if rows is not None:
        directions = set(data["direction"].values.astype(str)[rows])
        for direction, colour, text in (
                ("forward", "tab:blue", "measured, forward"),
                ("backward", "tab:red", "measured, backward"),
                ("unknown", "white", "measured, direction unknown")):
            if direction in directions:
                handles.append(plt.Line2D([], [], ls="none", marker=measured.MARKERS[direction],
                                          ms=6, mfc=colour, mec="black",
                                          label=f"{text} $\\pm\\sigma$"))
    return handles

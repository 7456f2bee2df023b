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

__all__ = ["draw"]


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
    top = float(max(1.25 * np.nanmax(a_lift), 1.15 * np.nanmax(lowest), 1.1 * structure.g))
    data = rows = None
    if measurements:
        data = measured.load(measurements)
        rows = measured.same_structure(data, measured.pick(data, "threshold", "thresholds"),
                                       dataset, "thresholds")
        high = data["value"].values[rows] + np.nan_to_num(data["sigma"].values[rows])
        top = max(top, 1.1 * float(np.max(high)))

    fig, ax = plt.subplots(figsize=(7.5, 5.0), layout="constrained")
    _mode_gain_behind(ax, f, gain)

    ax.fill_between(f, 0.0, lowest, color="tab:green", alpha=0.12, lw=0)
    ax.fill_between(f, a_lift, top, facecolor="none", edgecolor="0.6", hatch="///", lw=0)
    ax.axhline(structure.g, color="0.45", lw=0.8, ls=":")
    ax.text(f[0] + 0.7 * (f[-1] - f[0]), structure.g, "g", va="top", color="0.35",
            fontsize=10)
    ax.plot(f, a_plus, color="tab:blue", lw=2.0)
    ax.plot(f, a_minus, color="tab:red", lw=2.0)
    ax.plot(f, a_lift, color="black", lw=1.4, ls="--")
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
    fig.legend(handles=_legend_handles(data, rows), loc="outside lower center", ncol=3,
               fontsize=8.5, frameon=False)
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


def _legend_handles(data: xr.Dataset | None, rows: np.ndarray | None) -> list:
    """The legend: the curves and regions, and a marker per direction measured."""
    handles = [
        plt.Line2D([], [], color="tab:blue", lw=2.0, label="$a^*_+$: forward slips start"),
        plt.Line2D([], [], color="tab:red", lw=2.0, label="$a^*_-$: backward slips start"),
        plt.Line2D([], [], color="black", lw=1.4, ls="--",
                   label="lift-off acceleration (n < 0 above)"),
        Patch(facecolor="tab:green", alpha=0.12, label=r"static: $a < \min(a^*_+, a^*_-)$"),
        Patch(facecolor="none", edgecolor="0.6", hatch="///",
              label="lift-off: model invalid"),
        Patch(facecolor="0.88", edgecolor="0.65", lw=0.8,
              label=r"mode gain $|\omega_0^2 G|$ (right axis)"),
    ]
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

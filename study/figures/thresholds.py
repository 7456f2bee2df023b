"""The paper's Fig. 1B: motion thresholds a*_+ and a*_- against drive frequency.

Drawn from a ``thresholds`` result file alone (``study figure thresholds FILE``): the
thresholds, the lift-off acceleration and the mode's resonance curve behind them.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.patches import Patch

from study.figures import common
from study.figures.common import parameter_text, single_structure
from study.physics.forces import lift_off_acceleration

__all__ = ["draw"]


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the thresholds of a ``thresholds`` result into ``output.png/.pdf``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result holding a_star_plus, a_star_minus and mode_gain over f (the
        lift-off acceleration is read from it, else evaluated in closed form for
        the structure stored in it).
    output : pathlib.Path
        File stem.

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    single_structure(dataset, "thresholds")
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

    fig, ax = plt.subplots(figsize=(7.5, 5.0), layout="constrained")
    behind = ax.twinx()
    # The resonance curve sits behind the thresholds: the twin axis is drawn first.
    ax.set_zorder(behind.get_zorder() + 1)
    ax.patch.set_visible(False)
    behind.fill_between(f, 0.0, gain, color="0.88", lw=0)
    behind.plot(f, gain, color="0.65", lw=0.8)
    behind.set_ylim(0.0, 1.15 * float(np.nanmax(gain)))
    behind.set_ylabel(r"mode gain $|\omega_0^2 G|$ [1]", color="0.4")
    behind.tick_params(axis="y", colors="0.4")

    ax.fill_between(f, 0.0, lowest, color="tab:green", alpha=0.12, lw=0)
    ax.fill_between(f, a_lift, top, facecolor="none", edgecolor="0.6", hatch="///", lw=0)
    ax.axhline(structure.g, color="0.45", lw=0.8, ls=":")
    ax.text(f[0] + 0.7 * (f[-1] - f[0]), structure.g, "g", va="top", color="0.35",
            fontsize=10)
    ax.plot(f, a_plus, color="tab:blue", lw=2.0)
    ax.plot(f, a_minus, color="tab:red", lw=2.0)
    ax.plot(f, a_lift, color="black", lw=1.4, ls="--")
    ax.set(xlim=(f[0], f[-1]), ylim=(0.0, top), xlabel="drive frequency f [Hz]",
           ylabel="drive acceleration a [m s$^{-2}$]")

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
    title = "Motion thresholds against drive frequency"
    ax.set_title(f"{title}\n{parameter_text(dataset)}", fontsize=11)
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=8.5,
               frameon=False)
    return common.save(fig, output, dataset, title)

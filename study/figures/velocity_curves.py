"""The paper's Fig. 1C inset: mean velocity against drive acceleration at fixed frequencies.

Drawn from a ``velocity-curves`` result file alone (``study figure velocity-curves FILE``).
Each curve stops at the first lift-off point of its frequency: beyond it the model
does not apply. Points that did not converge leave gaps and are marked on the axis.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib import colormaps
from matplotlib.colors import ListedColormap
from matplotlib.lines import Line2D

from study.figures import common
from study.figures.common import (
    VALID,
    coupling_label,
    one_way_velocity,
    parameter_text,
    single_structure,
)
from study.status import Status

__all__ = ["FREQUENCY_COLORS", "draw", "frequency_position"]

#: Diverging colours for the drive frequency: blues below the resonance (forward
#: motion), reds above (backward); light near f0, dark far from it, never so light
#: that a line vanishes on white.
FREQUENCY_COLORS = ListedColormap(
    np.vstack([
        colormaps["Blues"](np.linspace(1.0, 0.4, 128)),
        colormaps["Reds"](np.linspace(0.4, 1.0, 128)),
    ]),
    name="below-above-f0",
)


def frequency_position(f: np.ndarray, f0: float) -> np.ndarray:
    """Position in :data:`FREQUENCY_COLORS` of each frequency, centred on ``f0``.

    ``0.5 + 0.5 sign(f - f0) sqrt(|f - f0| / max|f - f0|)``: monotone in ``f``, 0.5 at
    the resonance; the square root spreads the colours of frequencies close to ``f0``,
    where the curves differ most.
    """
    offset = np.asarray(f, dtype=float) - f0
    span = max(float(np.max(np.abs(offset))), 1e-12)
    return 0.5 + 0.5 * np.sign(offset) * np.sqrt(np.abs(offset) / span)


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw velocity against acceleration, one line per frequency, into ``output.png/.pdf``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result holding velocity and status over (f, a).
    output : pathlib.Path
        File stem.

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    single_structure(dataset, "velocity-curves")
    structure = common.structure_from_dataset(dataset)
    f = dataset["f"].values
    a = dataset["a"].values
    velocity = 1e3 * dataset["velocity"].transpose("f", "a").values  # mm/s
    status = dataset["status"].transpose("f", "a").values
    positions = frequency_position(f, structure.f0)
    paper = one_way_velocity(dataset, "f", "a")  # beside a two-way study

    fig, ax = plt.subplots(figsize=(8.0, 5.2), layout="constrained")
    ax.axhline(0.0, color="black", lw=0.8)
    handles = []
    any_lift = any_stuck = False
    for i, frequency in enumerate(f):
        color = FREQUENCY_COLORS(positions[i])
        lifted = np.flatnonzero(status[i] == Status.LIFT_OFF)
        end = int(lifted[0]) if lifted.size else a.size
        valid = np.isin(status[i, :end], VALID)
        shown = np.where(valid, velocity[i, :end], np.nan)
        (line,) = ax.plot(a[:end], shown, color=color, lw=1.6, label=f"{frequency:g} Hz")
        handles.append(line)
        if paper is not None:
            ax.plot(a, 1e3 * paper[i], color=color, lw=0.9, ls="--", alpha=0.8)
        if lifted.size and end > 0 and valid[-1]:
            any_lift = True
            ax.plot(a[end - 1], shown[-1], ls="none", marker="o", ms=5.5, mfc="white",
                    mec=color, mew=1.6, zorder=4)
        stuck = np.flatnonzero(status[i] == Status.NOT_CONVERGED)
        if stuck.size:
            any_stuck = True
            ax.plot(a[stuck], np.full(stuck.size, 0.03), ls="none", marker="x", ms=5,
                    color=color, transform=ax.get_xaxis_transform(), clip_on=False)
    if paper is not None:
        handles.append(Line2D([], [], color="0.3", lw=0.9, ls="--",
                              label="one-way (paper's) model,\nsame frequency"))
    if any_lift:
        handles.append(Line2D([], [], ls="none", marker="o", ms=5.5, mfc="white", mec="0.3",
                              mew=1.6, label="curve ends: lift-off\nabove (model invalid)"))
    if any_stuck:
        handles.append(Line2D([], [], ls="none", marker="x", ms=5, color="0.3",
                              label="not converged at this a\n(no velocity; gap)"))
    ax.set(xlim=(a[0], a[-1]), xlabel="drive acceleration a [m s$^{-2}$]",
           ylabel="mean velocity v [mm s$^{-1}$]  (> 0: forward)")
    title = ("Mean steady velocity against drive acceleration at fixed frequencies, "
             f"{coupling_label(dataset)}")
    ax.set_title(title.replace("frequencies, ", "frequencies\n", 1)
                 + f"\n{parameter_text(dataset)}", fontsize=11)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0),
              borderaxespad=0.0, fontsize=8.5, title="drive frequency f\n(blue < $f_0$ < red)",
              title_fontsize=9, frameon=False)
    return common.save(fig, output, dataset, title)

"""The paper's Fig. 1C inset: velocity against acceleration at fixed frequencies."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.colors import Normalize

from study.figures import common
from study.figures.regime_map import VALID, parameter_text, single_structure
from study.status import Status

__all__ = ["draw"]


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """One velocity curve per frequency of the file, into ``output.png/.pdf``."""
    single_structure(dataset, "velocity-curves")
    f = dataset["f"].values
    a = dataset["a"].values
    velocity = dataset["velocity"].values * 1e3
    status = dataset["status"].values
    # Every curve must stay visible: a sequential map, no pale middle.
    norm = Normalize(vmin=f.min(), vmax=max(f.max(), f.min() + 1e-9))
    cmap = plt.get_cmap("viridis")

    fig, ax = plt.subplots(figsize=(7.5, 4.8), layout="constrained")
    ax.axhline(0.0, color="0.4", lw=0.8)
    flagged = False
    for i, frequency in enumerate(f):
        valid = np.isin(status[i], VALID)
        line = np.where(valid, velocity[i], np.nan)
        ax.plot(a, line, color=cmap(norm(frequency)), lw=1.6, label=f"{frequency:g} Hz")
        lifted = np.flatnonzero(status[i] == Status.LIFT_OFF)
        if lifted.size:
            end = lifted[0] - 1
            if end >= 0 and np.isfinite(line[end]):
                ax.plot(a[end], line[end], "x", color=cmap(norm(frequency)), ms=6)
                flagged = True
    if flagged:
        ax.plot([], [], "kx", label="lift-off: curve ends")
    if np.any(status == Status.NOT_CONVERGED):
        ax.plot([], [], " ", label="not converged points left out")
    ax.set(xlim=(a[0], a[-1]), xlabel="drive acceleration a [m s$^{-2}$]",
           ylabel="mean velocity v [mm s$^{-1}$]")
    title = "Velocity against drive acceleration at fixed frequencies (paper Fig. 1C)"
    ax.set_title(f"{title}\n{parameter_text(dataset)}", fontsize=10)
    ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=8, title="f",
              frameon=False)
    return common.save(fig, output, dataset, title)

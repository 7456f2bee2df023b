"""The paper's Fig. 1B: motion thresholds against frequency, the resonance behind."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from study.figures import common
from study.figures.regime_map import parameter_text, single_structure

__all__ = ["draw"]


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw a*_+ and a*_- against f over the mode's gain into ``output.png/.pdf``."""
    single_structure(dataset, "thresholds")
    f = dataset["f"].values
    a_plus = dataset["a_star_plus"].values
    a_minus = dataset["a_star_minus"].values
    lower = np.minimum(a_plus, a_minus)
    top = 1.25 * float(dataset["g"]) if "g" in dataset.coords else 12.0

    fig, ax = plt.subplots(figsize=(7.5, 4.8), layout="constrained")
    gain_ax = ax.twinx()
    gain_ax.fill_between(f, dataset["mode_gain"].values, color="0.85", lw=0, zorder=0)
    gain_ax.set_ylabel("mode gain $|\\omega_0^2 G|$ [1] (grey)")
    gain_ax.set_ylim(0, 1.1 * float(dataset["mode_gain"].max()))
    ax.set_zorder(gain_ax.get_zorder() + 1)
    ax.patch.set_visible(False)

    ax.fill_between(f, 0, np.minimum(lower, top), color="0.6", alpha=0.25, lw=0,
                    label="static: below both thresholds")
    ax.plot(f, a_plus, color="tab:blue", lw=2, label="$a^*_+$: forward slips start")
    ax.plot(f, a_minus, color="tab:red", lw=2, label="$a^*_-$: backward slips start")
    if "lift_off_acceleration" in dataset:
        ax.plot(f, dataset["lift_off_acceleration"].values, "k--", lw=1.2,
                label="lift-off: model invalid above")
    i = int(np.argmin(lower))
    ax.plot(f[i], lower[i], "ko", ms=5,
            label=f"lowest threshold {lower[i]:.2f} m s$^{{-2}}$ at {f[i]:.2f} Hz")
    ax.set(xlim=(f[0], f[-1]), ylim=(0, top), xlabel="drive frequency f [Hz]",
           ylabel="drive acceleration a [m s$^{-2}$]")
    title = "Motion thresholds against drive frequency (paper Fig. 1B)"
    ax.set_title(f"{title}\n{parameter_text(dataset)}", fontsize=10)
    ax.legend(loc="lower left", fontsize=8, framealpha=0.9)
    return common.save(fig, output, dataset, title)

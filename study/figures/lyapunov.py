"""Irregular motion over the drive plane: the mean velocity and the largest Lyapunov
exponent over (f, a).

Drawn from a study with the ``irregular`` observable (the ``irregular-bouncing``
workflow). Left: the mean velocity [mm s-1], chaotic and quasi-periodic points hatched
over it (their time-averaged velocity), points without a velocity flat. Right: the
largest Lyapunov exponent per drive period, diverging about 0: below 0 the stable
orbits (the log of their largest Floquet multiplier over their period), near 0 the
quasi-periodic motions, above 0 the chaotic ones.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.colors import TwoSlopeNorm

from study.figures.common import (
    VALID,
    coupling_label,
    require_axis,
    save,
    selection_text,
    single_structure,
    status_handles,
    status_hatches,
    status_layers,
    structure_text,
)
from study.model.status import Status

__all__ = ["EXPONENT_FLOOR", "compose", "draw"]

#: The lowest exponent [1 per drive period] the colour scale spans.
EXPONENT_FLOOR = -2.0


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the velocity and the Lyapunov exponent over (f, a); returns the PNG and PDF.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result of one structure over ``(f, a)`` holding ``velocity``, ``status`` and
        ``lyapunov_exponent`` (the ``irregular`` observable).
    output : pathlib.Path
        File stem.
    """
    fig, title = compose(dataset)
    return save(fig, output, dataset, title)


def compose(dataset: xr.Dataset) -> tuple[plt.Figure, str]:
    """The figure of :func:`draw`, not saved, and its one-line title."""
    dataset = single_structure(dataset, "lyapunov")
    for axis in ("f", "a"):
        require_axis(dataset, "lyapunov", axis, "maps over (f, a)")
    f = dataset["f"].values
    a = dataset["a"].values
    status = dataset["status"].transpose("a", "f").values
    velocity = 1e3 * dataset["velocity"].transpose("a", "f").values
    exponent = dataset["lyapunov_exponent"].transpose("a", "f").values

    fig, (left, right) = plt.subplots(1, 2, figsize=(13.0, 5.4), layout="constrained",
                                      sharey=True)
    shown = np.ma.masked_where(~np.isin(status, VALID) | ~np.isfinite(velocity), velocity)
    limit = float(np.max(np.abs(shown))) if shown.count() else 1.0
    mesh = left.pcolormesh(f, a, shown, cmap="RdBu",
                           norm=TwoSlopeNorm(0.0, -(limit or 1.0), limit or 1.0),
                           shading="nearest", rasterized=True)
    fig.colorbar(mesh, ax=left, location="bottom", shrink=0.85, aspect=30,
                 label="mean velocity v [mm s$^{-1}$] (> 0: forward)")
    painted = status_layers(left, f, a, status)
    painted += status_hatches(left, f, a, status)

    finite = np.ma.masked_invalid(exponent)
    # Each side of 0 on its own scale: the chaotic exponents (a few tenths) would be
    # pale beside the stable orbits' (a strongly attracting orbit reaches -4); below
    # EXPONENT_FLOOR the colour is the floor's.
    low = max(float(finite.min()) if finite.count() else -1.0, EXPONENT_FLOOR)
    high = float(finite.max()) if finite.count() else 1.0
    norm = TwoSlopeNorm(0.0, min(low, -1e-3), max(high, 1e-3))
    mesh = right.pcolormesh(f, a, finite, cmap="PuOr_r", norm=norm, shading="nearest",
                            rasterized=True)
    fig.colorbar(mesh, ax=right, location="bottom", shrink=0.85, aspect=30,
                 extend="min" if finite.count() and finite.min() < EXPONENT_FLOOR else
                 "neither",
                 label="largest Lyapunov exponent [1 per drive period] (> 0: chaotic)")
    status_layers(right, f, a, status)
    status_hatches(right, f, a, status, (Status.CHAOTIC, Status.QUASI_PERIODIC))

    counts = {flag: int(np.count_nonzero(status == flag))
              for flag in (Status.CHAOTIC, Status.QUASI_PERIODIC, Status.NOT_CONVERGED)}
    left.set_title("mean velocity; " + ", ".join(
        f"{count} {flag.flag.replace('_', ' ')}" for flag, count in counts.items()),
        fontsize=10)
    right.set_title("largest Lyapunov exponent (orbits: log of the Floquet multiplier "
                    "per period)", fontsize=10)
    for ax in (left, right):
        ax.set(xlim=(f[0], f[-1]), ylim=(a[0], a[-1]), xlabel="drive frequency f [Hz]")
        ax.yaxis.set_tick_params(labelleft=True)
    left.set_ylabel("drive acceleration a [m s$^{-2}$]")
    handles = status_handles(painted)
    if handles:
        fig.legend(handles=handles, loc="outside lower center", ncols=min(len(handles), 4),
                   fontsize=9)
    title = (f"Irregular motion: mean velocity and largest Lyapunov exponent, "
             f"{coupling_label(dataset)} ({structure_text(dataset, tex=False)})")
    selected = selection_text(dataset)
    fig.suptitle("Irregular motion: mean velocity and largest Lyapunov exponent\n"
                 f"{coupling_label(dataset)}\n{structure_text(dataset)}"
                 + (f"\n{selected}" if selected else ""), fontsize=11)
    return fig, title

"""Two-way against one-way coupling over the mass ratio: where the paper's model stops holding.

Left: over ``M``, the share of the points where the one-way model moves at which
two-way coupling changes the velocity by more than 10 %, reverses it, or lifts the
structure off, and the median relative change. Right: velocity against drive
frequency at one acceleration, one-way (dashed) and two-way (solid), for a few ``M``.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from study.analysis import coupling_effect
from study.figures import FigureError
from study.figures.common import VALID, coupling_label, require_dims, save, selection_text

__all__ = ["draw"]

#: Drive acceleration of the velocity curves [m s^-2] (nearest grid value is used).
CURVE_ACCELERATION = 8.5


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the coupling figure from a ``coupling`` result file; returns PNG and PDF."""
    if "M" not in dataset.dims:
        raise FigureError("figure 'coupling' needs M swept (a dimension of the file)")
    require_dims(dataset, "coupling", ("M", "f", "a"), "the effect of coupling over M",
                 variable="velocity")
    effect = coupling_effect(dataset)
    m = dataset["M"].values

    fig, (left, right) = plt.subplots(1, 2, figsize=(11.5, 4.6), constrained_layout=True)
    left.semilogx(m, 100 * effect["changed"], "o-", color="tab:purple",
                  label="|v2 - v1| > 10 % |v1|")
    left.semilogx(m, 100 * effect["median_change"], "s-", color="k",
                  label="median |v2 - v1| / |v1|")
    left.semilogx(m, 100 * effect["reversed"], "^-", color="tab:red",
                  label="direction reversed")
    left.semilogx(m, 100 * effect["lifted"], "v-", color="0.5",
                  label="two-way lifts off (one-way moves)")
    if float(effect["paradox"].max()) > 0:
        left.semilogx(m, 100 * effect["paradox"], "x-", color="tab:orange",
                      label="friction paradox")
    left.semilogx(m, 100 * m, ":", color="0.3", lw=0.8, label="100 M (reference)")
    left.set_xlabel("mass ratio M = m1/m")
    left.set_ylabel("share of the moving one-way points [%]")
    left.set_ylim(bottom=0)
    left.legend(fontsize=8, loc="upper left")
    left.set_title("two-way vs one-way over the (f, a) grid", fontsize=10)

    a_index = int(np.argmin(np.abs(dataset["a"].values - CURVE_ACCELERATION)))
    a_value = float(dataset["a"].values[a_index])
    f = dataset["f"].values
    picks = sorted({0, len(m) // 3, (2 * len(m)) // 3, len(m) - 1})
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(picks)))
    for color, i in zip(colors, picks, strict=True):
        at = {"M": i, "a": a_index}
        for name, status_name, style in (("velocity_one_way", "status_one_way", "--"),
                                         ("velocity", "status", "-")):
            v = dataset[name].isel(at).values
            ok = np.isin(dataset[status_name].isel(at).values, VALID)
            right.plot(f, np.where(ok, 1e3 * v, np.nan), style, color=color,
                       label=f"M = {m[i]:g}" if style == "-" else None)
    right.axhline(0, color="0.6", lw=0.6)
    right.plot([], [], "k--", label="one-way (paper)")
    right.plot([], [], "k-", label="two-way")
    right.set_xlabel("drive frequency f [Hz]")
    right.set_ylabel("mean velocity v [mm s$^{-1}$]")
    right.set_title(f"a = {a_value:.2f} m s$^{{-2}}$ (gaps: lift-off)", fontsize=10)
    right.legend(fontsize=8)
    fixed = ", ".join(
        f"{name} = {float(dataset[name]):g}" for name in ("f0", "Q", "alpha", "cs", "ck")
        if name in dataset.coords and dataset[name].ndim == 0
    )
    solver = ("exact solver" if dataset.attrs.get("study_solver_method") == "exact"
              else "time integration")
    fig.suptitle(f"Sliding feeding back on the mode: {coupling_label(dataset)}, {solver},\n"
                 f"against the paper's one-way model; M swept, {fixed}"
                 + (f"\n{selection_text(dataset)}" if "study_selection" in dataset.attrs
                    else ""), fontsize=9.5)
    return save(fig, output, dataset,
                f"Two-way against one-way coupling over M; velocities: {coupling_label(dataset)}")

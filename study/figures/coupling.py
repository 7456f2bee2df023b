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

from study.analyses.coupling import coupling_effect
from study.figures import FigureError
from study.figures.common import (
    VALID,
    coupling_label,
    require_dims,
    restore_dim,
    save,
    selection_text,
    structure_text,
)

__all__ = ["draw"]

#: Drive acceleration of the velocity curves [m s-2] (nearest grid value is used).
CURVE_ACCELERATION = 8.5

#: The variables the figure draws, which keep a selected M, f or a as a dimension.
_DRAWN = ("velocity", "status", "velocity_one_way", "status_one_way")

_COUPLINGS = (("velocity_one_way", "status_one_way", "--"), ("velocity", "status", "-"))


def _velocity(dataset: xr.Dataset, name: str, status_name: str, at: dict) -> np.ndarray:
    """Velocity [mm s-1] at ``at``, NaN where it is not valid (lift-off)."""
    v = dataset[name].isel(at).values
    ok = np.isin(dataset[status_name].isel(at).values, VALID)
    return np.where(ok, 1e3 * v, np.nan)


def _curves(right, dataset: xr.Dataset, m: np.ndarray) -> None:
    """Right panel: velocity against f at the acceleration nearest
    :data:`CURVE_ACCELERATION` for a few M; against a when a single f is left, against
    M when a single (f, a) point is."""
    f, a = dataset["f"].values, dataset["a"].values
    a_index = int(np.argmin(np.abs(a - CURVE_ACCELERATION)))
    if f.size == 1 and a.size == 1:
        for name, status_name, style in _COUPLINGS:
            right.semilogx(m, _velocity(dataset, name, status_name, {"f": 0, "a": 0}),
                           style, marker="o", color="tab:purple")
        right.set_xlabel("mass ratio M = m1/m")
        where = f"f = {f[0]:g} Hz, a = {a[0]:.2f} m s$^{{-2}}$"
    else:
        along, fixed = ("f", {"a": a_index}) if f.size > 1 else ("a", {"f": 0})
        picks = sorted({0, len(m) // 3, (2 * len(m)) // 3, len(m) - 1})
        colors = plt.cm.viridis(np.linspace(0, 0.9, len(picks)))
        for color, i in zip(colors, picks, strict=True):
            for name, status_name, style in _COUPLINGS:
                right.plot(dataset[along].values,
                           _velocity(dataset, name, status_name, {"M": i, **fixed}), style,
                           color=color, label=f"M = {m[i]:g}" if style == "-" else None)
        right.set_xlabel("drive frequency f [Hz]" if along == "f"
                         else "drive acceleration a [m s$^{-2}$]")
        where = (f"a = {a[a_index]:.2f} m s$^{{-2}}$" if along == "f"
                 else f"f = {f[0]:g} Hz")
    right.axhline(0, color="0.6", lw=0.6)
    right.plot([], [], "k--", label="one-way (paper)")
    right.plot([], [], "k-", label="two-way")
    right.set_ylabel("mean velocity v [mm s$^{-1}$]")
    right.set_title(f"{where} (gaps: lift-off)", fontsize=10)
    right.legend(fontsize=8)


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the coupling figure from a ``coupling`` result file; returns PNG and PDF.

    A selection of one value keeps the figure: one M gives the shares at that M, one
    a the curves at that acceleration, one f the velocity against a at that frequency
    (against M when a single (f, a) point is left)."""
    if "M" not in dataset.dims and not ("M" in dataset.coords and dataset["M"].ndim == 0):
        raise FigureError("figure 'coupling' draws the effect of coupling over M; this file "
                          f"(study {dataset.attrs.get('study_name')!r}) has no M")
    for dim in ("M", "f", "a"):
        dataset = restore_dim(dataset, dim, _DRAWN)
    dataset = require_dims(dataset, "coupling", ("M", "f", "a"),
                           "the effect of coupling over M", variable="velocity")
    effect = coupling_effect(dataset)
    if not np.any(effect["moving_points"].values > 0):
        selected = dataset.attrs.get("study_selection")
        raise FigureError(
            "figure 'coupling' compares the couplings where the one-way model moves, but "
            + (f"the selection ({selected}) leaves" if selected else "this file holds")
            + " no such point: select accelerations above the motion thresholds")
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
    if float(effect["bouncing"].max()) > 0:
        left.semilogx(m, 100 * effect["bouncing"], "D-", color="tab:green",
                      label="two-way bounces (flight; one-way moves)")
    if float(effect["paradox"].max()) > 0:
        left.semilogx(m, 100 * effect["paradox"], "x-", color="tab:orange",
                      label="friction paradox")
    left.semilogx(m, 100 * m, ":", color="0.3", lw=0.8, label="100 M (reference)",
                  marker="_" if m.size == 1 else None)
    left.set_xlabel("mass ratio M = m1/m")
    left.set_ylabel("share of the moving one-way points [%]")
    left.set_ylim(bottom=0)
    left.legend(fontsize=8, loc="upper left")
    drive = [d for d in ("f", "a") if dataset.sizes[d] > 1]
    over = {2: "over the (f, a) grid", 1: f"over {''.join(drive)}",
            0: "at one (f, a) point"}[len(drive)]
    left.set_title(f"two-way vs one-way {over}", fontsize=10)

    _curves(right, dataset, m)
    parameters = structure_text(dataset, tex=False)
    solver = ("exact solver" if dataset.attrs.get("study_solver_method") == "exact"
              else "time integration")
    fig.suptitle(f"Sliding feeding back on the mode: {coupling_label(dataset)}, {solver},\n"
                 f"against the paper's one-way model; {parameters}"
                 + (f"\n{selection_text(dataset)}" if "study_selection" in dataset.attrs
                    else ""), fontsize=9.5)
    return save(fig, output, dataset,
                f"Two-way against one-way coupling over M; velocities: "
                f"{coupling_label(dataset)} ({parameters})")

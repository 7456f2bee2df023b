"""A bifurcation diagram: the phase-0 section of the motion against one drive parameter.

Drawn from a study with the ``section`` and ``irregular`` observables along one axis,
``f`` or ``a`` (the ``bifurcation-along-a`` and ``bifurcation-along-f`` workflows; a
map's file draws once the other axis is selected with ``--sel``). Top: the base's
sliding speed at drive phase 0 in each of the section's periods, one dot per period,
coloured by the point's largest Lyapunov exponent: a single dot is an orbit of period
1, ``p`` dots a cycle of ``p`` periods, a vertical smear a quasi-periodic or chaotic
motion. Middle: the base's height above the table at phase 0 the same way (with
flight; without it, the mode's deflection). Bottom: the mean velocity, irregular
points with their 95 % interval.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.colors import TwoSlopeNorm

from study.figures.common import (
    IRREGULAR,
    VALID,
    coupling_label,
    is_flight,
    require_dims,
    save,
    selection_text,
    structure_text,
)
from study.figures.lyapunov import EXPONENT_FLOOR
from study.model.statistics import Z_95
from study.model.status import Status

__all__ = ["compose", "draw", "swept_axis"]

#: The mean velocity's colour by status where it is not an orbit's (blue).
_POINT_COLOURS = {Status.CHAOTIC: "tab:red", Status.QUASI_PERIODIC: "tab:orange",
                  Status.STATIC: "0.4"}
#: What each drive axis is, for labels.
_AXES = {"f": "drive frequency f [Hz]", "a": "drive acceleration a [m s$^{-2}$]"}


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the bifurcation diagram; returns the PNG and PDF.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result of one structure along ``f`` or ``a`` (the other of one value) holding
        ``section_speed``, ``velocity``, ``status`` and ``lyapunov_exponent``.
    output : pathlib.Path
        File stem.
    """
    fig, title = compose(dataset)
    return save(fig, output, dataset, title)


def swept_axis(dataset: xr.Dataset) -> str:
    """The drive axis the diagram runs along: ``"f"`` or ``"a"``, the one with more than
    one value.

    Raises
    ------
    FigureError
        If both or neither have several values (naming the ``--sel`` to give).
    """
    from study.figures import FigureError

    several = [d for d in ("f", "a") if dataset.sizes.get(d, 1) > 1]
    if len(several) == 1:
        return several[0]
    if not several:
        raise FigureError("figure 'bifurcation' draws the section along f or a, which "
                          "needs several values of f or a; this file (as selected) holds a "
                          "single drive point")
    raise FigureError("figure 'bifurcation' draws the section along one drive axis, but "
                      f"this file (study {dataset.attrs.get('study_name')!r}) sweeps both f "
                      f"and a: select one value of the other, e.g. --sel "
                      f"a={float(dataset['a'].values[-1]):g} (along f) or --sel "
                      f"f={float(dataset['f'].values[0]):g} (along a)")


def compose(dataset: xr.Dataset) -> tuple[plt.Figure, str]:
    """The figure of :func:`draw`, not saved, and its one-line title."""
    dataset = require_dims(dataset, "bifurcation", ("f", "a", "section_period"),
                           "a single structure along f or a")
    axis = swept_axis(dataset)
    other = "a" if axis == "f" else "f"
    dataset = dataset.squeeze(other) if other in dataset.dims else dataset
    if "section_period" not in dataset["section_speed"].dims:  # one period selected
        dataset = dataset.assign({
            name: dataset[name].expand_dims("section_period", -1) for name in dataset
            if name.startswith("section_")})
    x = dataset[axis].values
    status = dataset["status"].values
    exponent = dataset["lyapunov_exponent"].values
    flight = is_flight(dataset) and "section_gap" in dataset
    speed = 1e3 * dataset["section_speed"].transpose(axis, "section_period").values
    second = dataset["section_gap" if flight else "section_delta"].transpose(
        axis, "section_period").values * 1e3
    periods = speed.shape[1]

    finite = np.ma.masked_invalid(exponent)
    low = max(float(finite.min()) if finite.count() else -1.0, EXPONENT_FLOOR)
    high = float(finite.max()) if finite.count() else 1.0
    norm = TwoSlopeNorm(0.0, min(low, -1e-3), max(high, 1e-3))
    fig, (top, middle, bottom) = plt.subplots(
        3, 1, figsize=(9.0, 9.5), layout="constrained", sharex=True,
        height_ratios=(3.0, 2.0, 2.0))
    xs = np.repeat(x, periods)
    colours = np.repeat(np.clip(exponent, EXPONENT_FLOOR, None), periods)
    for ax, values in ((top, speed), (middle, second)):
        shown = np.isfinite(values.ravel()) & np.isfinite(colours)
        dots = ax.scatter(xs[shown], values.ravel()[shown], c=colours[shown], s=1.5,
                          cmap="PuOr_r", norm=norm, linewidths=0, rasterized=True)
    fig.colorbar(dots, ax=(top, middle), location="right", shrink=0.9, aspect=40,
                 label="largest Lyapunov exponent [1 per drive period] (> 0: chaotic)")
    top.set_ylabel("sliding speed at phase 0 [mm s$^{-1}$]")
    middle.set_ylabel("height at phase 0 [mm]" if flight
                      else "mode deflection at phase 0 [mm]")
    counts = {flag: int(np.count_nonzero(status == flag)) for flag in IRREGULAR}
    top.set_title(f"phase-0 section: {periods} consecutive periods per point; "
                  + ", ".join(f"{count} {flag.flag.replace('_', ' ')}"
                              for flag, count in counts.items()), fontsize=10)

    velocity = 1e3 * dataset["velocity"].values
    error = 1e3 * Z_95 * dataset["velocity_error"].values if "velocity_error" in dataset \
        else np.zeros_like(velocity)
    bottom.axhline(0.0, color="0.6", linewidth=0.6)
    for flag in VALID:
        chosen = (status == flag) & np.isfinite(velocity)
        if not chosen.any():
            continue
        colour = _POINT_COLOURS.get(flag, "tab:blue")
        if flag in IRREGULAR:
            bottom.errorbar(x[chosen], velocity[chosen], yerr=error[chosen], fmt="o",
                            markersize=2.5, color=colour, elinewidth=0.8,
                            label=flag.legend)
        else:
            bottom.plot(x[chosen], velocity[chosen], ".", markersize=3, color=colour,
                        label=flag.legend)
    missing = ~np.isin(status, VALID)
    if missing.any():
        bottom.plot(x[missing], np.zeros(int(missing.sum())), "|", color="black",
                    markersize=6, label="no velocity: " + ", ".join(
                        sorted({Status(int(s)).flag for s in status[missing]})))
    bottom.set_ylabel("mean velocity [mm s$^{-1}$]")
    bottom.set_xlabel(_AXES[axis])
    bottom.legend(fontsize=8, loc="best")
    bottom.set_xlim(x[0], x[-1])
    fixed = float(dataset[other].values)
    where = (f"f = {fixed:g} Hz" if other == "f" else f"a = {fixed:g} m s$^{{-2}}$")
    title = (f"Bifurcation diagram along {axis} at "
             f"{where.replace('$^{-2}$', '^-2')}, {coupling_label(dataset)} "
             f"({structure_text(dataset, tex=False)})")
    selected = selection_text(dataset)
    fig.suptitle(f"Bifurcation diagram along {axis} at {where}\n{coupling_label(dataset)}\n"
                 f"{structure_text(dataset)}" + (f"\n{selected}" if selected else ""),
                 fontsize=11)
    return fig, title

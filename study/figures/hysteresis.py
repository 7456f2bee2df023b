"""Hysteresis of slow sweeps: the motion swept up against swept down.

Drawn from a study with a slow-sweep protocol in both directions (``[sweep] protocol =
{ along = "f", direction = "both" }``: a ``direction`` dimension labelled ``up`` and
``down``, the ``jumped`` flag beside the velocity). Along one line of the swept axis
(the other drive axis of one value, or selected with ``--sel``): the mean velocity
swept up and swept down against the swept value, the points where a sweep jumped
marked, and where a file holds it the velocity each point reaches from its start alone
(``velocity_unswept``) beside them. Over a two-axis map: where the two sweeps end on
different motions, coloured by how far apart their velocities are.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from study.figures.common import (
    coupling_label,
    require_dims,
    save,
    selection_text,
    structure_text,
)

__all__ = ["compose", "differing", "draw", "sweep_axis"]

#: Sweeps differ at a point where their velocities differ by more than this fraction of
#: the velocity scale a / (2 pi f) (an orbit's velocity is exact: two sweeps on one
#: orbit agree to rounding).
DIFFERENT = 1e-6
#: What each drive axis is, for labels.
_AXES = {"f": "drive frequency f [Hz]", "a": "drive acceleration a [m s$^{-2}$]"}
_COLOURS = {"up": "tab:red", "down": "tab:blue"}


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the hysteresis figure; returns the PNG and PDF.

    Parameters
    ----------
    dataset : xarray.Dataset
        A slow sweep in both directions of one structure (``direction``, ``f``, ``a``),
        holding ``velocity``, ``status`` and ``jumped``.
    output : pathlib.Path
        File stem.
    """
    fig, title = compose(dataset)
    return save(fig, output, dataset, title)


def sweep_axis(dataset: xr.Dataset) -> str:
    """The swept drive axis: the file's ``study_protocol_along`` attribute, else the one
    drive axis with several values."""
    from study.figures import FigureError

    along = dataset.attrs.get("study_protocol_along")
    if along in ("f", "a"):
        return str(along)
    several = [d for d in ("f", "a") if dataset.sizes.get(d, 1) > 1]
    if len(several) == 1:
        return several[0]
    raise FigureError("figure 'hysteresis' needs the swept axis: this file records no "
                      "'study_protocol_along' and sweeps "
                      + (" and ".join(several) if several else "no drive axis"))


def differing(dataset: xr.Dataset) -> xr.DataArray:
    """Where the up and down sweeps end on different motions: their velocities differ
    by more than :data:`DIFFERENT` of ``a / (2 pi f)``, or one has a velocity and the
    other not (bool over the drive axes)."""
    up = dataset["velocity"].sel(direction="up")
    down = dataset["velocity"].sel(direction="down")
    scale = dataset["a"] / (2.0 * np.pi * dataset["f"])
    apart = np.abs(up - down) > DIFFERENT * scale
    one_only = up.isnull() != down.isnull()
    return (apart | one_only).transpose(*up.dims)


def compose(dataset: xr.Dataset) -> tuple[plt.Figure, str]:
    """The figure of :func:`draw`, not saved, and its one-line title."""
    from study.figures import FigureError

    dataset = require_dims(dataset, "hysteresis", ("direction", "f", "a"),
                           "a slow sweep up and down of one structure")
    if "direction" not in dataset.dims or set(dataset["direction"].values) != {"up",
                                                                               "down"}:
        raise FigureError("figure 'hysteresis' compares the sweeps up and down, which "
                          "needs several values of direction (up and down): this file "
                          f"(study {dataset.attrs.get('study_name')!r}, as selected) holds "
                          "not both; a study declares them with [sweep] protocol = "
                          "{ along = ..., direction = \"both\" }")
    axis = sweep_axis(dataset)
    other = "a" if axis == "f" else "f"
    if dataset.sizes.get(axis, 1) < 2:
        raise FigureError(f"figure 'hysteresis' draws the sweeps along {axis}, which needs "
                          f"several values of {axis}; the selection leaves one")
    if dataset.sizes.get(other, 1) > 1:
        return _map(dataset, axis)
    return _line(dataset.squeeze(other) if other in dataset.dims else dataset, axis,
                 other)


def _line(dataset: xr.Dataset, axis: str, other: str) -> tuple[plt.Figure, str]:
    x = dataset[axis].values
    fig, ax = plt.subplots(figsize=(8.5, 5.0), layout="constrained")
    ax.axhline(0.0, color="0.6", linewidth=0.6)
    jumps = 0
    for direction, marker in (("up", "^"), ("down", "v")):
        v = 1e3 * dataset["velocity"].sel(direction=direction).values
        jumped = dataset["jumped"].sel(direction=direction).values.astype(bool)
        jumps += int(jumped.sum())
        ax.plot(x, v, marker + "-", color=_COLOURS[direction], markersize=3.5,
                linewidth=1.0, label=f"swept {direction}")
        if jumped.any():
            ax.plot(x[jumped], v[jumped], "o", markersize=9, markerfacecolor="none",
                    markeredgecolor=_COLOURS[direction], markeredgewidth=1.5,
                    label=f"jumped (swept {direction})")
    if "velocity_unswept" in dataset:
        # Above the sweeps (each value lies on one of them or on neither): open circles.
        start = dataset.attrs.get("study_start", "release")
        ax.plot(x, 1e3 * dataset["velocity_unswept"].values, "o", markersize=6.5,
                markerfacecolor="none", markeredgecolor="black", markeredgewidth=0.8,
                zorder=5, label=f"each point from its start alone ({start})")
    apart = int(differing(dataset).sum())
    ax.set_xlabel(_AXES[axis])
    ax.set_ylabel("mean velocity [mm s$^{-1}$]")
    ax.legend(fontsize=8, loc="best")
    fixed = float(dataset[other].values)
    where = f"f = {fixed:g} Hz" if other == "f" else f"a = {fixed:g} m s$^{{-2}}$"
    ax.set_title(f"{apart} of {x.size} drive values end on different motions up and "
                 f"down; {jumps} jumps", fontsize=10)
    return fig, _titles(fig, dataset, f"Slow sweeps along {axis} at {where}, up and down",
                        f"Hysteresis along {axis} at {where.replace('$^{-2}$', '^-2')}")


def _map(dataset: xr.Dataset, axis: str) -> tuple[plt.Figure, str]:
    apart = differing(dataset).transpose("f", "a")
    up = dataset["velocity"].sel(direction="up").transpose("f", "a")
    down = dataset["velocity"].sel(direction="down").transpose("f", "a")
    gap = 1e3 * np.abs(up - down).where(apart)
    fig, ax = plt.subplots(figsize=(8.5, 6.0), layout="constrained")
    f, a = dataset["f"].values, dataset["a"].values
    mesh = ax.pcolormesh(f, a, gap.values.T, shading="nearest", cmap="magma_r")
    fig.colorbar(mesh, ax=ax, label="|v(up) - v(down)| where they differ [mm s$^{-1}$]")
    count = int(apart.sum())
    ax.set_xlabel(_AXES["f"])
    ax.set_ylabel(_AXES["a"])
    ax.set_title(f"swept along {axis}: up and down end on different motions at {count} "
                 f"of {apart.size} points", fontsize=10)
    return fig, _titles(fig, dataset, f"Where slow sweeps up and down differ (along {axis})",
                        f"Hysteresis map, swept along {axis}")


def _titles(fig: plt.Figure, dataset: xr.Dataset, head: str, plain: str) -> str:
    """Set the figure's title (``head``, the coupling, the structure, the selection)
    and return its one-line title for the files' metadata (``plain`` and the same)."""
    selected = selection_text(dataset)
    fig.suptitle(f"{head}\n{coupling_label(dataset)}\n{structure_text(dataset)}"
                 + (f"\n{selected}" if selected else ""), fontsize=11)
    return f"{plain}, {coupling_label(dataset)} ({structure_text(dataset, tex=False)})"

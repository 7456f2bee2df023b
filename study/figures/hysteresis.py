"""Hysteresis of slow sweeps: the motion swept up against swept down.

Drawn from a study with a slow-sweep protocol in both directions (``[sweep] protocol =
{ along = "f", direction = "both" }``: a ``direction`` dimension labelled ``up`` and
``down``, the ``jumped`` flag beside the velocity). Along one line of the swept axis
(the other drive axis of one value, or selected with ``--sel``): the mean velocity
swept up and swept down against the swept value, the points where a sweep jumped
marked (and, where the file holds the ``jumps`` observable, the bifurcation each jump
was located at, with the kind's marker and its drive written beside), the points where
it started again by the declared start (the point before had
no state to carry: not converged, lift-off without flight, the friction paradox;
:func:`restarted`) and the points without a velocity marked on the axis, and where a
file holds it the velocity each point reaches from its start alone
(``velocity_unswept``) beside them. With a few values of the other drive axis (fewer
than :data:`~study.figures.common.MIN_CELLS`, such as a listed ``a = [10, 12]``): one
such panel per value. Over a map (the other axis of more values): where the two sweeps
end on different motions, coloured by how far apart their velocities are, the restarts
marked.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from study.figures.common import (
    VALID,
    coupling_label,
    is_coarse,
    map_mesh,
    require_dims,
    save,
    selection_text,
    structure_text,
)
from study.model.bifurcations import kind_of_code
from study.model.status import Status

__all__ = ["compose", "differing", "draw", "restarted", "sweep_axis"]

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


def restarted(dataset: xr.Dataset) -> xr.DataArray:
    """Where a sweep resumed from the declared start: a point with a velocity after one
    whose motion has no state to carry (a status without a velocity: not converged,
    lift-off without flight, the friction paradox), in the sweep's order along its
    axis, up or down (bool over ``direction`` and the drive axes; docs/theory/starts.md,
    "Slow sweeps"). Its motion is the declared start's, not the continuation of the
    sweep's branch. A run's first point is not counted (every run starts so), nor a
    point that again has no velocity (inside a lift-off region: nothing resumed)."""
    axis = sweep_axis(dataset)
    stateless = ~dataset["status"].isin(list(VALID)) | dataset["velocity"].isnull()
    dims = stateless.dims
    moved = stateless.transpose(*[d for d in dims if d != axis], axis)
    values = np.asarray(moved.values, dtype=bool)
    order = np.argsort(dataset[axis].values, kind="stable")
    restart = np.zeros_like(values)
    for k, direction in enumerate(moved["direction"].values):
        ranked = order if direction == "up" else order[::-1]
        line = values[k][..., ranked]
        after = np.zeros_like(line)
        after[..., 1:] = line[..., :-1]
        restart[k][..., ranked] = after
    restart &= ~values
    return xr.DataArray(restart, coords=moved.coords, dims=moved.dims).transpose(*dims)


def compose(dataset: xr.Dataset) -> tuple[plt.Figure, str]:
    """The figure of :func:`draw`, not saved, and its one-line title.

    Along the swept axis the sweeps are lines; the other drive axis is a map's second
    axis only where it has at least :data:`~study.figures.common.MIN_CELLS` values,
    else each of its values gets a panel of its own (the values a study lists, such as
    ``a = [10, 12]``, are drawn as what they are, never as cells spanning 9-13)."""
    from study.figures import FigureError

    dataset = require_dims(dataset, "hysteresis", ("direction", "f", "a"),
                           "a slow sweep up and down of one structure", "velocity")
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
        if is_coarse(dataset[other].values):
            return _panels(dataset, axis, other)
        return _map(dataset, axis)
    return _single(dataset.squeeze(other) if other in dataset.dims else dataset, axis,
                   other)


def _where(dataset: xr.Dataset, other: str) -> str:
    fixed = float(dataset[other].values)
    return f"f = {fixed:g} Hz" if other == "f" else f"a = {fixed:g} m s$^{{-2}}$"


def _counts(dataset: xr.Dataset, x: np.ndarray, jumps: int, restarts: int) -> str:
    apart = int(differing(dataset).sum())
    text = (f"{apart} of {x.size} drive values end on different motions up and down; "
            f"{jumps} jumps")
    if restarts:
        text += f"; {restarts} resumed from the {dataset.attrs.get('study_start', 'release')}"
    return text


def _single(dataset: xr.Dataset, axis: str, other: str) -> tuple[plt.Figure, str]:
    fig, ax = plt.subplots(figsize=(8.5, 5.0), layout="constrained")
    jumps, restarts = _line(ax, dataset, axis, restarted(dataset))
    ax.legend(fontsize=8, loc="best")
    ax.set_title(_counts(dataset, dataset[axis].values, jumps, restarts), fontsize=10)
    where = _where(dataset, other)
    return fig, _titles(fig, dataset, f"Slow sweeps along {axis} at {where}, up and down",
                        f"Hysteresis along {axis} at {where.replace('$^{-2}$', '^-2')}")


def _panels(dataset: xr.Dataset, axis: str, other: str) -> tuple[plt.Figure, str]:
    """One panel of :func:`_line` per value of the (coarse) other drive axis."""
    count = dataset.sizes[other]
    fig, axes = plt.subplots(count, 1, figsize=(8.5, 1.9 + 2.7 * count),
                             layout="constrained", sharex=True, squeeze=False)
    restart = restarted(dataset)
    handles: dict[str, object] = {}
    for ax, value in zip(axes[:, 0], dataset[other].values, strict=True):
        at = dataset.sel({other: value})
        jumps, restarts = _line(ax, at, axis, restart.sel({other: value}))
        ax.set_title(f"{_where(at, other)}: "
                     + _counts(at, dataset[axis].values, jumps, restarts), fontsize=9)
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(label, handle)
        if ax is not axes[-1, 0]:
            ax.set_xlabel("")
    fig.legend(list(handles.values()), list(handles), loc="outside lower center",
               ncols=2, fontsize=8)
    symbol = "a" if other == "a" else "f"
    values = ", ".join(f"{v:g}" for v in dataset[other].values)
    units = "m s$^{-2}$" if other == "a" else "Hz"
    return fig, _titles(fig, dataset,
                        f"Slow sweeps along {axis} at {symbol} = {values} {units}, up and "
                        "down", f"Hysteresis along {axis} at {symbol} = {values} "
                        f"{units.replace('$^{-2}$', '^-2')}")


def _line(ax: plt.Axes, dataset: xr.Dataset, axis: str,
          restart: xr.DataArray) -> tuple[int, int]:
    """The sweeps up and down along ``axis`` on ``ax`` (one value of the other axis),
    their jumps, restarts and points without a velocity; returns the counts of jumps
    and restarts."""
    x = dataset[axis].values
    ax.axhline(0.0, color="0.6", linewidth=0.6)
    jumps = restarts = 0
    start = dataset.attrs.get("study_start", "release")
    for direction, marker in (("up", "^"), ("down", "v")):
        colour = _COLOURS[direction]
        v = 1e3 * dataset["velocity"].sel(direction=direction).values
        jumped = dataset["jumped"].sel(direction=direction).values.astype(bool)
        again = restart.sel(direction=direction).values.astype(bool)
        jumps += int(jumped.sum())
        restarts += int(again.sum())
        ax.plot(x, v, marker + "-", color=colour, markersize=3.5, linewidth=1.0,
                label=f"swept {direction}")
        if jumped.any():
            ax.plot(x[jumped], v[jumped], "o", markersize=9, markerfacecolor="none",
                    markeredgecolor=colour, markeredgewidth=1.5,
                    label=f"jumped (swept {direction})")
        if "jump_bifurcation" in dataset:
            _located_jumps(ax, dataset.sel(direction=direction), axis, x, v, colour,
                           direction)
        if again.any():
            ax.plot(x[again], v[again], "s", markersize=8, markerfacecolor="none",
                    markeredgecolor=colour, markeredgewidth=1.2, zorder=4,
                    label=f"resumed from the {start} (swept {direction}): the point "
                          "before left no state to carry")
        status = dataset["status"].sel(direction=direction).values
        lost = ~np.isin(status, VALID)
        if lost.any():
            names = ", ".join(Status(code).name.lower().replace("_", " ")
                              for code in np.unique(status[lost]))
            ax.plot(x[lost], np.full(int(lost.sum()), 0.02 if direction == "up" else 0.05),
                    ls="none", marker="x", ms=5, color=colour,
                    transform=ax.get_xaxis_transform(), clip_on=False,
                    label=f"no velocity (swept {direction}: {names})")
    if "velocity_unswept" in dataset:
        # Above the sweeps (each value lies on one of them or on neither): open circles.
        ax.plot(x, 1e3 * dataset["velocity_unswept"].values, "o", markersize=6.5,
                markerfacecolor="none", markeredgecolor="black", markeredgewidth=0.8,
                zorder=5, label=f"each point from its start alone ({start})")
    ax.set_xlabel(_AXES[axis])
    ax.set_ylabel("mean velocity [mm s$^{-1}$]")
    return jumps, restarts


def _located_jumps(ax: plt.Axes, dataset: xr.Dataset, axis: str, x: np.ndarray,
                   v: np.ndarray, colour: str, direction: str) -> None:
    """Each jump of one direction at the bifurcation where it was located (the
    ``jumps`` observable): the kind's marker on the branch the sweep rode, at the drive
    located, its value written beside, and a dotted line down (or up) to the motion the
    sweep landed on."""
    kinds = dataset["jump_bifurcation"].values
    where = dataset[f"jump_{axis}"].values
    velocity = 1e3 * dataset["jump_velocity"].values
    units = "Hz" if axis == "f" else "m s$^{-2}$"
    for index in np.flatnonzero(kinds > 0):
        kind = kind_of_code(int(kinds[index]))
        ax.plot([where[index], where[index], x[index]],
                [velocity[index], v[index], v[index]], ":", color=colour, linewidth=1.0)
        ax.plot(where[index], velocity[index], kind.marker, markersize=8, color=colour,
                markeredgecolor="black", markeredgewidth=0.6, zorder=6,
                label=f"{kind.name.replace('_', ' ')} located (swept {direction})")
        ax.annotate(f"{where[index]:.5f} {units}", (where[index], velocity[index]),
                    textcoords="offset points", xytext=(-6, 6 if direction == "up" else -12),
                    ha="right", fontsize=7, color=colour)


def _map(dataset: xr.Dataset, axis: str) -> tuple[plt.Figure, str]:
    apart = differing(dataset).transpose("f", "a")
    up = dataset["velocity"].sel(direction="up").transpose("f", "a")
    down = dataset["velocity"].sel(direction="down").transpose("f", "a")
    gap = 1e3 * np.abs(up - down).where(apart)
    fig, ax = plt.subplots(figsize=(8.5, 6.0), layout="constrained")
    f, a = dataset["f"].values, dataset["a"].values
    empty = not np.isfinite(gap.values).any()  # a scale of |v| from 0 all the same
    mesh = map_mesh(ax, f, a, gap.values.T, cmap="magma_r",
                    **({"vmin": 0.0, "vmax": 1.0} if empty else {}))
    fig.colorbar(mesh, ax=ax, label="|v(up) - v(down)| where they differ [mm s$^{-1}$]")
    restart = restarted(dataset).transpose("direction", "f", "a")
    restarts = 0
    start = dataset.attrs.get("study_start", "release")
    for direction, marker in (("up", "^"), ("down", "v")):
        again = restart.sel(direction=direction).values
        restarts += int(again.sum())
        if again.any():
            rows, columns = np.nonzero(again)
            ax.plot(f[rows], a[columns], marker, ls="none", ms=4, mfc="none",
                    mec=_COLOURS[direction], mew=1.0,
                    label=f"resumed from the {start} (swept {direction}): the point "
                          "before left no state to carry")
    if restarts:
        ax.legend(fontsize=8, loc="best")
    count = int(apart.sum())
    ax.set_xlabel(_AXES["f"])
    ax.set_ylabel(_AXES["a"])
    ax.set_title(f"swept along {axis}: up and down end on different motions at {count} "
                 f"of {apart.size} points"
                 + (f";\n{restarts} points where a sweep resumed from the {start} after a "
                    "point without a state" if restarts else ""), fontsize=10)
    return fig, _titles(fig, dataset, f"Where slow sweeps up and down differ (along {axis})",
                        f"Hysteresis map, swept along {axis}")


def _titles(fig: plt.Figure, dataset: xr.Dataset, head: str, plain: str) -> str:
    """Set the figure's title (``head``, the coupling, the structure, the selection)
    and return its one-line title for the files' metadata (``plain`` and the same)."""
    selected = selection_text(dataset)
    fig.suptitle(f"{head}\n{coupling_label(dataset)}\n{structure_text(dataset)}"
                 + (f"\n{selected}" if selected else ""), fontsize=11)
    return f"{plain}, {coupling_label(dataset)} ({structure_text(dataset, tex=False)})"

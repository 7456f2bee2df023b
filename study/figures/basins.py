"""Basins: each motion of a map followed across the drive, and its share of the starts.

Drawn from a study with the ``basins`` observable (the ``attractor`` dimension, the
``basin_*`` variables). The attractors are labelled by
:func:`study.analyses.basins.follow_attractors` (or by the file's ``attractor_label``
where it holds one, so that a line selected from a labelled map keeps the map's
labels); each label has one colour in both drawings. Over (f, a), both axes of at least
:data:`~study.figures.common.MIN_CELLS` values: one panel per label, most points first
(at most :data:`MAX_PANELS`), its region coloured by its basin fraction of the drawn
starts (from grey, a basin too small to be seen or a motion only the seeded sweep state
reaches, to the label's colour, every start; white where the motion is not found),
each point a cell (:func:`~study.figures.common.map_mesh`: a listed
axis's cells only as wide as its smallest step). Along one drive axis (the other of one
value, or selected with ``--sel``): the velocity of each label above, and the basin
fractions stacked beneath, a bar per grid point, as Attractors.jl's basins-fractions
plot; with a coarse second axis (fewer values, such as a listed ``a = [10, 12]``), one
such column per value of it. Where the file holds the fold curves (the ``fold_curves``
observable), each hop's fold f_fold(a) is drawn over every panel as a black line at the
accelerations where it was located (solid: the forward hop's, where a sweep up jumps;
dashed: the backward hop's, where a sweep down jumps), and along f as a vertical line at
its frequency: the edges of the region where both hops coexist. The forward hop's
period doubling (``doubling_f``, the same observable: below it in f the forward hop has
twice the period) is drawn likewise, dotted.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.colors import LinearSegmentedColormap, to_rgb

from study.analyses.basins import (
    class_name,
    follow_attractors,
    fraction_by_label,
    status_class,
)
from study.figures.common import (
    coupling_label,
    is_coarse,
    map_mesh,
    require_dims,
    save,
    selection_text,
    structure_text,
)

__all__ = ["DOUBLING_STYLE", "FOLD_STYLES", "MAX_PANELS", "bar_width", "compose", "draw",
           "fold_lines", "label_colour", "labelled"]

#: Labels drawn over (f, a) at most, most points first.
MAX_PANELS = 6
_AXES = {"f": "drive frequency f [Hz]", "a": "drive acceleration a [m s$^{-2}$]"}
_PALETTE = plt.get_cmap("tab10").colors
#: How each hop's fold curve (the fold_curves observable) is drawn.
FOLD_STYLES = {"forward": {"color": "black", "linestyle": "-"},
               "backward": {"color": "black", "linestyle": "--"}}
_FOLD_LABELS = {"forward": "forward hop's fold (a sweep up jumps there)",
                "backward": "backward hop's fold (a sweep down jumps there)"}
#: How the forward hop's period-doubling curve (``doubling_f``) is drawn.
DOUBLING_STYLE = {"color": "black", "linestyle": ":",
                  "label": "forward hop's period doubling (period 2 below it in f)"}


def fold_lines(ax: plt.Axes, dataset: xr.Dataset, along: str = "a") -> list[plt.Line2D]:
    """Each hop's fold curve of the file (``fold_f``, the fold_curves observable) on
    ``ax``: over (f, a) as the line f_fold(a) through the accelerations where it was
    located (``along="a"``), or, at one acceleration, a vertical line at its frequency
    (``along="f"``); then the forward hop's period doubling (``doubling_f``) the same
    way, dotted; the axes' limits kept. Returns the lines drawn (none where the file
    holds no such curve, or none was found)."""
    limits = ax.get_xlim(), ax.get_ylim()
    drawn = []
    hops = (dataset["hop"].values if "fold_f" in dataset and "hop" in dataset["fold_f"].dims
            else ())
    for hop in hops:
        name = str(hop)
        f = np.atleast_1d(dataset["fold_f"].sel(hop=hop).values)
        if not np.isfinite(f).any():
            continue
        style = {**FOLD_STYLES.get(name, FOLD_STYLES["forward"]), "zorder": 5,
                 "label": _FOLD_LABELS.get(name, f"{name} fold")}
        if along == "a":
            a = np.atleast_1d(dataset["fold_f"].sel(hop=hop)["a"].values)
            drawn.append(ax.plot(f, a, marker="o", markersize=2.5, linewidth=1.4,
                                 **style)[0])
        else:
            drawn.append(ax.axvline(float(f[np.isfinite(f)][0]), linewidth=1.2, **style))
    doubling = (np.atleast_1d(dataset["doubling_f"].values) if "doubling_f" in dataset
                else np.empty(0))
    if np.isfinite(doubling).any():  # the forward hop's other edge (newer files hold it)
        style = {**DOUBLING_STYLE, "zorder": 5}
        if along == "a":
            a = np.atleast_1d(dataset["doubling_f"]["a"].values)
            drawn.append(ax.plot(doubling, a, marker="s", markersize=2.5, linewidth=1.4,
                                 **style)[0])
        else:
            drawn.append(ax.axvline(float(doubling[np.isfinite(doubling)][0]),
                                    linewidth=1.2, **style))
    ax.set_xlim(*limits[0])
    ax.set_ylim(*limits[1])
    return drawn


def label_colour(label: int) -> tuple[float, float, float]:
    """The colour of a label in both drawings (tab10, cycled)."""
    return tuple(to_rgb(_PALETTE[int(label) % len(_PALETTE)]))


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the basins figure; returns the PNG and PDF.

    Parameters
    ----------
    dataset : xarray.Dataset
        A basins map of one structure (``f``, ``a``, ``attractor``) holding
        ``basin_status``, ``basin_velocity`` [m s-1], ``basin_largest_hop`` [m],
        ``basin_period`` and ``basin_fraction`` [1].
    output : pathlib.Path
        File stem.
    """
    fig, title = compose(dataset)
    return save(fig, output, dataset, title)


def labelled(dataset: xr.Dataset) -> tuple[xr.Dataset, xr.Dataset]:
    """The dataset with ``attractor_label`` and the per-label summary: the file's own
    labels where it holds them, else :func:`~study.analyses.basins.follow_attractors`'s.
    """
    if "attractor_label" not in dataset:
        return follow_attractors(dataset)
    labels = dataset["attractor_label"]
    present = np.unique(labels.values[labels.values >= 0])
    shares = fraction_by_label(dataset).sel(label=present)
    velocity = dataset["basin_velocity"]
    summary = xr.Dataset(
        {"points": ("label", [int((labels == k).sum()) for k in present]),
         "velocity_min": ("label", [float(velocity.where(labels == k).min()) for k in present]),
         "velocity_max": ("label", [float(velocity.where(labels == k).max()) for k in present]),
         "fraction_max": shares.max([d for d in shares.dims if d != "label"])},
        coords={"label": present})
    classes = []
    for k in present:
        where = labels == k
        period = int(dataset["basin_period"].where(where).max())
        status = int(dataset["basin_status"].where(where).max())
        classes.append(class_name(int(status_class(np.array([status]),
                                                   np.array([period]))[0])))
    summary["status_class"] = ("label", np.array(classes, dtype=object))
    return dataset, summary


def compose(dataset: xr.Dataset) -> tuple[plt.Figure, str]:
    """The figure of :func:`draw`, not saved, and its one-line title."""
    from study.figures import FigureError

    if "attractor" not in dataset["basin_status"].dims:
        raise FigureError("figure 'basins' follows every attractor of each point, which "
                          "needs several values of attractor (the whole dimension); the "
                          "selection leaves one")
    if ("attractor_count" in dataset
            and int(dataset["attractor_count"].max()) > dataset.sizes["attractor"]):
        raise FigureError("figure 'basins' follows every attractor of each point, which "
                          "needs several values of attractor (all its slots); the "
                          f"selection leaves {dataset.sizes['attractor']} of them where a "
                          f"point holds {int(dataset['attractor_count'].max())}")
    dataset = require_dims(dataset, "basins", ("f", "a", "attractor"),
                           "the attractors of one structure over (f, a)", "basin_status")
    several = [d for d in ("f", "a") if dataset.sizes.get(d, 1) > 1]
    if not several:
        raise FigureError("figure 'basins' draws the attractors along f or a, which needs "
                          "several values of f or a; the selection leaves one")
    labelled_map, summary = labelled(dataset)
    if not summary.sizes["label"]:
        raise FigureError("figure 'basins': no point of this file (as selected) holds an "
                          "attractor")
    if len(several) == 2 and not any(is_coarse(dataset[d].values) for d in several):
        return _map(labelled_map, summary)
    # A line of the axis with more values per value of the other (a coarse or listed
    # axis is drawn as what it is: its values, never cells spanning between them).
    axis = max(several, key=lambda d: dataset.sizes[d])
    other = "a" if axis == "f" else "f"
    return _lines(labelled_map, summary, axis, other)


def _describe(summary: xr.Dataset, label: int) -> str:
    row = summary.sel(label=label)
    low, high = 1e3 * float(row["velocity_min"]), 1e3 * float(row["velocity_max"])
    if row["status_class"].item() == "static":
        speed = "at rest"
    elif np.isfinite(low):
        speed = f"v {low:+.0f} to {high:+.0f} mm s$^{{-1}}$"
    else:
        speed = "no velocity"
    return f"{row['status_class'].item()}, {speed}"


def _map(dataset: xr.Dataset, summary: xr.Dataset) -> tuple[plt.Figure, str]:
    shares = fraction_by_label(dataset).transpose("label", "f", "a")
    order = summary["label"].values[np.argsort(-summary["points"].values, kind="stable")]
    shown = order[:MAX_PANELS]
    columns = min(3, shown.size)
    rows = -(-shown.size // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns + 0.8, 3.6 * rows + 1.6),
                             layout="constrained", sharex=True, sharey=True, squeeze=False)
    f, a = dataset["f"].values, dataset["a"].values
    for ax, label in zip(axes.flat, shown, strict=False):
        colour = label_colour(label)
        cmap = LinearSegmentedColormap.from_list(f"label-{label}",
                                                 [(0.85, 0.85, 0.85), colour])
        mesh = map_mesh(ax, f, a, shares.sel(label=label).values.T, cmap=cmap,
                        vmin=0.0, vmax=1.0)
        fig.colorbar(mesh, ax=ax, label="basin fraction of the drawn starts", shrink=0.85)
        points = int(summary["points"].sel(label=label))
        ax.set_title(f"label {label}: {_describe(summary, label)}\n{points} points",
                     fontsize=9, color=colour)
        folds = fold_lines(ax, dataset)
    for ax in axes.flat[shown.size:]:
        ax.set_visible(False)
    if folds:
        fig.legend(handles=folds, loc="outside lower center", ncols=len(folds), fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel(_AXES["f"])
    for ax in axes[:, 0]:
        ax.set_ylabel(_AXES["a"])
    count = dataset["attractor_label"].max("attractor") >= 0
    most = int((dataset["attractor_label"] >= 0).sum("attractor").max())
    head = ("Each motion followed over (f, a), coloured by its basin fraction of the drawn "
            "starts (grey: found, no draw reaches it)\n"
            f"{order.size} motions over {int(count.sum())} points, at most {most} at one "
            f"point; the {shown.size} with most points drawn")
    return fig, _titles(fig, dataset, head, "Basins over (f, a)")


def _where(dataset: xr.Dataset, other: str) -> str:
    fixed = float(dataset[other].values)
    return f"f = {fixed:g} Hz" if other == "f" else f"a = {fixed:g} m s$^{{-2}}$"


def bar_width(x: np.ndarray) -> float:
    """The width [units of ``x``] of a grid point's bar: 0.8 of the smallest step, so
    that each bar reads as the one point it was computed at."""
    steps = np.abs(np.diff(np.asarray(x, dtype=float)))
    return 0.8 * float(np.min(steps)) if steps.size else 1.0


def _lines(dataset: xr.Dataset, summary: xr.Dataset, axis: str,
           other: str) -> tuple[plt.Figure, str]:
    """Along ``axis``: per value of ``other`` (a column each), the velocity of each
    label above its basin fractions stacked in a bar per grid point."""
    values = (dataset[other].values if other in dataset.dims
              else np.atleast_1d(dataset[other].values))
    columns = values.size
    fig, axes = plt.subplots(2, columns, figsize=(8.5 if columns == 1 else 4.6 * columns,
                                                  7.0),
                             layout="constrained", sharex=True, sharey="row",
                             height_ratios=(1.0, 1.2), squeeze=False)
    handles: dict[str, object] = {}
    for column, value in enumerate(values):
        at = dataset.sel({other: value}) if other in dataset.dims else dataset
        top, bottom = axes[:, column]
        present, most = _line(top, bottom, at, summary, axis)
        if axis == "f":  # the folds at this acceleration, where the file holds them
            for ax in (top, bottom):
                for line in fold_lines(ax, at, along="f"):
                    handles.setdefault(line.get_label(), line)
        head = f"{_where(at, other)}: " if columns > 1 else ""
        top.set_title(f"{head}{len(present)} motions along {axis}, at most {most} at one "
                      "drive", fontsize=10 if columns == 1 else 9)
        if columns == 1:
            top.legend(fontsize=8, loc="best")  # the bars: each label's colour
        else:
            # The velocities' entries name each label; its bars have its colour.
            for handle, label in zip(*top.get_legend_handles_labels(), strict=True):
                handles.setdefault(label, handle)
        if column:
            top.set_ylabel("")
            bottom.set_ylabel("")
    if columns > 1:
        fig.legend(list(handles.values()), list(handles), loc="outside lower center",
                   ncols=2, fontsize=8)
    if columns == 1:
        where = _where(dataset if other not in dataset.dims else dataset.squeeze(other),
                       other)
    else:
        symbol, units = ("f", "Hz") if other == "f" else ("a", "m s$^{-2}$")
        where = f"{symbol} = {', '.join(f'{v:g}' for v in values)} {units}"
    return fig, _titles(fig, dataset, f"Basin fractions along {axis} at {where}",
                        f"Basins along {axis} at {where.replace('$^{-2}$', '^-2')}")


def _line(top: plt.Axes, bottom: plt.Axes, dataset: xr.Dataset, summary: xr.Dataset,
          axis: str) -> tuple[list[int], int]:
    """One line along ``axis`` (the other drive axis of one value): each label's
    velocity on ``top``, the basin fractions stacked on ``bottom``, a bar per grid
    point (never a band between points: a motion found at one point is one bar).
    Returns the labels present and the most attractors at one point."""
    shares = fraction_by_label(dataset).transpose("label", axis)
    x = dataset[axis].values
    held = set(shares["label"].values.tolist())
    present = [int(k) for k in summary["label"].values
               if k in held and bool(shares.sel(label=k).notnull().any())]
    top.axhline(0.0, color="0.6", linewidth=0.6)
    label_of = dataset["attractor_label"].transpose(axis, "attractor").values
    velocity = dataset["basin_velocity"].transpose(axis, "attractor").values
    for label in present:
        v = np.where(label_of == label, velocity, np.nan)
        v = np.nanmax(np.where(np.isnan(v), -np.inf, v), axis=1)
        v = np.where(np.isfinite(v), v, np.nan)
        top.plot(x, 1e3 * v, "o-", color=label_colour(label), markersize=3.0,
                 linewidth=1.0, label=f"label {label}: {_describe(summary, label)}")
    top.set_ylabel("mean velocity [mm s$^{-1}$]")
    width = bar_width(x)
    below = np.zeros(x.size)
    for label in present:
        share = np.nan_to_num(shares.sel(label=label).values)
        bottom.bar(x, share, width=width, bottom=below, color=label_colour(label),
                   alpha=0.85, linewidth=0, label=f"label {label}")
        below = below + share
    bottom.set_ylim(0.0, 1.0)
    bottom.set_xlim(float(x.min()) - width, float(x.max()) + width)
    bottom.set_xlabel(_AXES[axis])
    bottom.set_ylabel("basin fraction of the\ndrawn starts (stacked)")
    most = int((label_of >= 0).sum(axis=1).max())
    return present, most


def _titles(fig: plt.Figure, dataset: xr.Dataset, head: str, plain: str) -> str:
    """Set the figure's title (``head``, the coupling, the structure, the selection)
    and return its one-line title for the files' metadata."""
    selected = selection_text(dataset)
    fig.suptitle(f"{head}\n{coupling_label(dataset)}\n{structure_text(dataset)}"
                 + (f"\n{selected}" if selected else ""), fontsize=11)
    return f"{plain}, {coupling_label(dataset)} ({structure_text(dataset, tex=False)})"

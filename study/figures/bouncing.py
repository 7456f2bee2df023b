"""The bouncing region: where the base leaves the table, how fast, how high and how long.

Drawn from a study with flight (``[solver] flight = true``: the ``mass-ratio-limit-flight``
workflow) alone. One row per mass ratio (up to three, evenly spread over the file's,
ends included), three maps over ``(f, a)`` in each: the steady mean velocity [mm s-1]
(diverging, each row its own scale: speeds grow tenfold towards M = 1), the largest hop
of the base above the table [mm] (logarithmic over three decades below the row's
largest: hops vanish at the region's edge) and the fraction of the period it spends in
the air [%]. On every map: the bouncing region's edge (status ``bouncing``), the
closed-form lift-off acceleration of the base at rest, and the zero-velocity frontier
``f*(a)`` (black dots) where the file holds it: bouncing points have a velocity, so the
frontier runs on through the region.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.colors import LogNorm, Normalize, TwoSlopeNorm
from matplotlib.lines import Line2D

from study.figures import FigureError
from study.figures.common import (
    IRREGULAR,
    VALID,
    coupling_label,
    in_the_air,
    is_flight,
    require_axis,
    require_dims,
    restore_dim,
    save,
    selection_text,
    spread_indices,
    status_handles,
    status_hatches,
    status_layers,
    structure_from_dataset,
    structure_text,
)
from study.model.status import Status

__all__ = ["MAX_ROWS", "bouncing_share", "compose", "draw", "row_indices"]

#: Mass ratios drawn at most (one row of three maps each).
MAX_ROWS = 3
#: The edge of the bouncing region.
_EDGE = {"colors": "darkgreen", "linewidths": 1.1, "linestyles": "-"}


def row_indices(n: int, limit: int = MAX_ROWS) -> list[int]:
    """Indices of at most ``limit`` of ``n`` mass ratios, evenly spread, ends included."""
    return spread_indices(n, limit)


def bouncing_share(status: np.ndarray, airborne: np.ndarray | None = None
                   ) -> tuple[float, float]:
    """Share [1] of the points that bounce (orbits, and irregular motions in the air
    when ``airborne`` is given), of all points and of the moving ones (every status
    with a velocity but static)."""
    status = np.asarray(status)
    bouncing = np.count_nonzero(in_the_air(status, airborne))
    moving = np.count_nonzero(np.isin(status, [s for s in VALID if s != Status.STATIC]))
    return bouncing / max(status.size, 1), bouncing / max(moving, 1)


#: Decades of hop height a row's scale spans below its largest hop.
HOP_DECADES = 3


def _hop_norm(hop: np.ma.MaskedArray) -> LogNorm:
    """A logarithmic scale of the hops [mm] drawn: :data:`HOP_DECADES` decades up to
    the largest (a hop vanishes at the edge of the region: lower ones get the lowest
    colour)."""
    high = float(hop.max()) if hop.count() else 1.0
    return LogNorm(high * 10.0**-HOP_DECADES, high, clip=True)


def _over_fa(dataset: xr.Dataset, name: str, at: dict) -> np.ndarray:
    return dataset[name].isel(at).transpose("a", "f").values


def _overlays(ax, dataset: xr.Dataset, at: dict, flying: np.ndarray) -> bool:
    """The bouncing region's edge (``flying``, over (a, f)): where this study's base
    leaves the table, and the frontier where the file holds it. Returns whether a
    frontier point was drawn.

    The closed-form lift-off of the base at rest is not drawn: it is the one-way
    model's, and a two-way coupled base that slides lifts off elsewhere (at M = 0.9 the
    estimate is 1.3 m s-2 at resonance where bouncing starts near 5 m s-2); the edge is
    where the file's own motion leaves the table."""
    f = dataset["f"].values
    a = dataset["a"].values
    bouncing = flying.astype(float)
    if bouncing.any() and min(bouncing.shape) > 1:
        ax.contour(f, a, bouncing, levels=[0.5], **_EDGE)
    drawn = False
    if "frontier_frequency" in dataset:
        frontier = dataset["frontier_frequency"].isel(at).transpose("a", "branch").values
        rows, _ = np.nonzero(np.isfinite(frontier))
        ax.plot(frontier[np.isfinite(frontier)], a[rows], "o", color="k", ms=2.0, zorder=5)
        drawn = bool(rows.size)
    ax.set(xlim=(f[0], f[-1]), ylim=(a[0], a[-1]))
    return drawn


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the bouncing region of a study with flight; returns the PNG and the PDF.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result with flight holding ``velocity``, ``status``, ``largest_hop`` and
        ``airborne_fraction`` over ``(f, a)``, of one structure or sweeping ``M``
        (other structure axes selected with ``--sel``).
    output : pathlib.Path
        File stem.

    Raises
    ------
    FigureError
        A file without flight, or with more axes than ``M``, ``f`` and ``a``.
    """
    fig, title = compose(dataset)
    return save(fig, output, dataset, title)


def compose(dataset: xr.Dataset) -> tuple[plt.Figure, str]:
    """The figure of :func:`draw`, not saved, and its title.

    Each map's colour bar lies under its own map, its label below it: beside the map,
    with the three maps of a row sharing their y axis, a bar's label would sit against
    the next map's axis and read as that map's label.

    Parameters
    ----------
    dataset : xarray.Dataset
        As :func:`draw`'s.

    Returns
    -------
    matplotlib.figure.Figure, str
        The figure and its one-line title.
    """
    if not is_flight(dataset):
        raise FigureError(
            "figure 'bouncing' draws the bouncing region of a study with flight; this "
            f"file (study {dataset.attrs.get('study_name')!r}) stops at lift-off: run a "
            "spec with [solver] flight = true (e.g. workflows/mass-ratio-limit-flight.toml)")
    dataset = require_dims(dataset, "bouncing", ("M", "f", "a"),
                           "one row of maps over (f, a) per M", variable="velocity")
    for axis in ("f", "a"):
        require_axis(dataset, "bouncing", axis, "maps over (f, a)")
    dataset = restore_dim(dataset, "branch", ("frontier_frequency",))
    swept = "M" in dataset["velocity"].dims
    ats = [{"M": i} for i in row_indices(dataset.sizes["M"])] if swept else [{}]
    f = dataset["f"].values
    a = dataset["a"].values

    fig, axes = plt.subplots(len(ats), 3, figsize=(15.5, 4.6 * len(ats) + 1.3),
                             layout="constrained", sharex=True, sharey=True, squeeze=False)
    labels = ("mean velocity v [mm s$^{-1}$] (> 0: forward)", "largest hop [mm]",
              "time in the air [% of the period]")
    painted = []
    frontier = edge = False
    for row, at in enumerate(ats):
        status = _over_fa(dataset, "status", at)
        airborne = 100 * _over_fa(dataset, "airborne_fraction", at)
        flying = in_the_air(status, airborne)
        v = 1e3 * _over_fa(dataset, "velocity", at)
        velocity = np.ma.masked_where(~np.isin(status, VALID) | ~np.isfinite(v), v)
        limit = float(np.max(np.abs(velocity))) if velocity.count() else 0.0
        hop = 1e3 * _over_fa(dataset, "largest_hop", at)
        hop = np.ma.masked_where(~flying | ~np.isfinite(hop) | (hop <= 0), hop)
        panels = (
            (velocity, "RdBu", TwoSlopeNorm(0.0, -(limit or 1.0), limit or 1.0)),
            (hop, "viridis", _hop_norm(hop)),
            (np.ma.masked_where(~flying | ~np.isfinite(airborne), airborne), "magma_r",
             Normalize(0.0, 100.0)),
        )
        share, of_moving = bouncing_share(status, airborne)
        M = float(structure_from_dataset(dataset, **at).M)
        for column, (values, cmap, norm) in enumerate(panels):
            ax = axes[row, column]
            mesh = ax.pcolormesh(f, a, values, cmap=cmap, norm=norm, shading="nearest",
                                 rasterized=True)
            fig.colorbar(mesh, ax=ax, location="bottom", shrink=0.85, aspect=30,
                         label=labels[column])
            painted += status_layers(ax, f, a, status)
            painted += status_hatches(ax, f, a, status, IRREGULAR)
            frontier |= _overlays(ax, dataset, at, flying)
            edge |= bool(flying.any())
            if column == 0:
                ax.set_ylabel("drive acceleration a [m s$^{-2}$]")
            # Under every map (its colour bar below): the frequency axis on each row.
            ax.set_xlabel("drive frequency f [Hz]")
            ax.xaxis.set_tick_params(labelbottom=True)
        axes[row, 0].set_title(f"M = {M:g}: velocity; bouncing {100 * share:.0f} % of the "
                               f"map ({100 * of_moving:.0f} % of the moving points)",
                               fontsize=9.5)
        axes[row, 1].set_title(f"M = {M:g}: largest hop of the base", fontsize=9.5)
        axes[row, 2].set_title(f"M = {M:g}: time in the air", fontsize=9.5)

    handles = []
    if edge:
        handles.append(Line2D([], [], color=_EDGE["colors"], lw=_EDGE["linewidths"],
                              label="edge of the bouncing region: where this study's base "
                                    "leaves the table (flights and impacts)"))
    if frontier:
        handles.append(Line2D([], [], ls="none", marker="o", color="k", ms=3,
                              label="frontier $f^*(a)$: v changes sign"))
    handles += status_handles(painted)
    if handles:
        fig.legend(handles=handles, loc="outside lower center", ncols=min(3, len(handles)),
                   fontsize=9)
    title = (f"The bouncing region: where the base flies and lands, {coupling_label(dataset)} "
             f"({structure_text(dataset, tex=False)})")
    selected = selection_text(dataset)
    fig.suptitle(f"The bouncing region: where the base flies and lands\n"
                 f"{coupling_label(dataset)}\n{structure_text(dataset)}"
                 + (f"\n{selected}" if selected else ""), fontsize=11)
    return fig, title

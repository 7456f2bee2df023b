"""The paper's Fig. 2: mean velocity over (f, a), thresholds, lift-off and frontier f*(a).

The frontier is drawn when the study computed it; a map without it says so.

Drawn from a ``regime-map`` result file alone (``study figure regime-map FILE``).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.patheffects as path_effects
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.colors import TwoSlopeNorm
from matplotlib.lines import Line2D

from study.figures import common
from study.figures.common import (
    PAPER_POINTS,
    VALID,
    coupling_label,
    is_paper_file,
    one_way_velocity,
    parameter_text,
    require_axis,
    restore_dim,
    single_structure,
)
from study.model.status import Status

__all__ = ["draw"]

#: A white outline that keeps thin lines readable over the colour map.
OUTLINE = [path_effects.withStroke(linewidth=3.2, foreground="white")]
#: The edge of the bouncing region (a study with flight).
BOUNCING_EDGE = "darkgreen"
#: The legend's line for a study that did not compute the frontier.
NO_FRONTIER = 'frontier f*(a) not computed (observable "frontier")'


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the regime map of a ``regime-map`` result into ``output.png/.pdf``.

    The paper's points S, P, N, PN are drawn only when the file's structure is the
    paper's (:func:`study.model.paper.is_paper_structure`); a file sweeping the structure
    is drawn for one structure selected with ``--sel``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result holding velocity and status over (f, a), a*_pm and the lift-off
        acceleration; the frontier f*(a) is drawn when it holds it (observable
        ``frontier``), else the legend says it was not computed.
    output : pathlib.Path
        File stem.

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    dataset = single_structure(dataset, "regime-map")
    require_axis(dataset, "regime-map", "f", "a map over (f, a)",
                 "figure 'velocity-curves' draws the velocity against a at one frequency")
    require_axis(dataset, "regime-map", "a", "a map over (f, a)")
    # One frontier branch selected (--sel branch=0): that branch alone.
    dataset = restore_dim(dataset, "branch", ("frontier_frequency",))
    f = dataset["f"].values
    a = dataset["a"].values

    fig, ax = plt.subplots(figsize=(8.0, 6.0), layout="constrained")
    hatched, stuck = _velocity_map(fig, ax, dataset)
    handles = _curves(ax, dataset)
    status = dataset["status"].values
    # The statuses without a velocity, each in its declared colour; lift-off always
    # without flight (it explains where the map ends).
    painted = set(Status(code) for code in np.unique(status)) | (
        set() if common.is_flight(dataset) else {Status.LIFT_OFF})
    handles += common.status_handles(flag for flag in painted
                                     if flag.colour is not None
                                     and flag != Status.NOT_CONVERGED)
    if np.any(_flying(dataset)):
        handles.append(Line2D([], [], color=BOUNCING_EDGE, lw=1.3,
                              label="edge of the bouncing region (flight):\nwhere "
                                    "this study's base leaves the table"))
    # The paper's points belong to the paper's structure: drawn on its maps only.
    points = PAPER_POINTS if is_paper_file(dataset) else {}
    if any(f[0] <= fp <= f[-1] and a[0] <= ap <= a[-1] for fp, ap in points.values()):
        handles.append(Line2D([], [], ls="none", marker="o", ms=5, mfc="white", mec="black",
                              label="the paper's points in regions S, P, N, PN"))
    # Continuous sliding and the irregular motions: hatched over their velocity.
    handles += common.status_handles(hatched)
    if np.any(stuck):
        handles += common.status_handles([Status.NOT_CONVERGED])

    ax.set(xlim=(f[0], f[-1]), ylim=(a[0], a[-1]), xlabel="drive frequency f [Hz]",
           ylabel="drive acceleration a [m s$^{-2}$]")
    _paper_points(ax, f, a, points)
    title = (f"Mean steady velocity over drive frequency and acceleration, "
             f"{coupling_label(dataset)}")
    ax.set_title(title.replace(", ", "\n", 1) + f"\n{parameter_text(dataset)}",
                 fontsize=11)
    # Three columns fit the figure's width up to six entries; more take two.
    fig.legend(handles=handles, loc="outside lower center",
               ncol=3 if len(handles) <= 6 else 2, fontsize=8.5, frameon=False)
    return common.save(fig, output, dataset,
                       f"{title} ({common.structure_text(dataset, tex=False)})")


def _flying(dataset: xr.Dataset) -> xr.DataArray:
    """Where the base leaves the table (:func:`study.figures.common.in_the_air`)."""
    airborne = dataset.get("airborne_fraction")
    return xr.apply_ufunc(common.in_the_air, dataset["status"],
                          *([] if airborne is None else [airborne]))


def _velocity_map(fig: plt.Figure, ax: plt.Axes, dataset: xr.Dataset
                  ) -> tuple[list[Status], np.ndarray]:
    """The velocity over (f, a) with its colour bar, lift-off and not-converged points
    as flat layers, continuous sliding and the irregular motions hatched. Returns the
    statuses hatched and where the solver did not converge, over (a, f)."""
    f = dataset["f"].values
    a = dataset["a"].values
    velocity = 1e3 * dataset["velocity"].transpose("a", "f").values  # mm s-1 over (a, f)
    status = dataset["status"].transpose("a", "f").values
    valid = np.isin(status, VALID)
    stuck = status == Status.NOT_CONVERGED
    shown = np.ma.masked_where(~valid | ~np.isfinite(velocity), velocity)
    limit = float(np.max(np.abs(shown))) if shown.count() else 0.0
    limit = limit if limit > 0 else 1.0
    mesh = ax.pcolormesh(f, a, shown, cmap="RdBu", norm=TwoSlopeNorm(0.0, -limit, limit),
                         shading="nearest", rasterized=True)
    fig.colorbar(mesh, ax=ax, label="mean velocity v [mm s$^{-1}$]  (> 0: forward)",
                 shrink=0.9)
    common.status_layers(ax, f, a, status)
    hatched = common.status_hatches(ax, f, a, status)
    bouncing = _flying(dataset).transpose("a", "f").values
    if np.any(bouncing) and min(bouncing.shape) > 1:  # with flight: the region's edge
        ax.contour(f, a, bouncing.astype(float), levels=[0.5], colors=BOUNCING_EDGE,
                   linewidths=1.3, zorder=3)
    return hatched, stuck


def _curves(ax: plt.Axes, dataset: xr.Dataset) -> list:
    """The thresholds, the lift-off acceleration, the frontier branches and, beside a
    two-way study, the one-way model's frontier; returns their legend handles."""
    f = dataset["f"].values
    a = dataset["a"].values
    handles = []
    lines = [
        ("a_star_plus", dict(color="tab:blue", lw=1.8), "$a^*_+$: forward slips start"),
        ("a_star_minus", dict(color="tab:red", lw=1.8), "$a^*_-$: backward slips start"),
    ]
    # The closed-form lift-off is the one-way model's (a base at rest); a two-way study
    # shows its own (the lift-off layer, the bouncing region's edge): a sliding base
    # lifts off elsewhere, at M = 0.9 near 5 m s-2 where the estimate says 1.3.
    if not common.is_two_way(dataset):
        lines.append(("lift_off_acceleration", dict(color="black", lw=1.4, ls="--"),
                      common.lift_off_label(dataset)))
    for name, style, label in lines:
        (line,) = ax.plot(f, dataset[name].values, label=label, path_effects=OUTLINE, **style)
        handles.append(line)

    if "frontier_frequency" in dataset:
        frontier = dataset["frontier_frequency"].transpose("a", "branch").values
        for branch in range(frontier.shape[1]):
            found = int(np.count_nonzero(np.isfinite(frontier[:, branch])))
            ax.plot(frontier[:, branch], a, color="black", lw=1.2, marker="o", ms=2.5,
                    markevery=max(1, found // 25), zorder=4)
        handles.append(Line2D([], [], color="black", lw=1.2, marker="o", ms=2.5,
                              label="frontier f*(a): v changes sign"))
    else:
        # A map without the frontier (it costs bisections, on a flight study often more
        # than the map): said, so that no reader looks for its line.
        handles.append(Line2D([], [], ls="none", label=NO_FRONTIER))
    # A two-way study with the paper's model beside it: where the one-way velocity
    # changes sign (the paper's frontier), for comparison.
    paper = one_way_velocity(dataset, "a", "f")
    if paper is not None and np.any(paper > 0) and np.any(paper < 0):
        ax.contour(f, a, np.ma.masked_invalid(paper), levels=[0.0], colors="0.25",
                   linewidths=1.1, linestyles="--", zorder=4)
        handles.append(Line2D([], [], color="0.25", lw=1.1, ls="--",
                              label="one-way (paper's) model: v changes sign"))
    return handles


def _paper_points(ax: plt.Axes, f: np.ndarray, a: np.ndarray,
                  points: dict[str, tuple[float, float]]) -> None:
    """The paper's points S, P, N, PN that lie on the map, labelled."""
    for name, (f_point, a_point) in points.items():
        if f[0] <= f_point <= f[-1] and a[0] <= a_point <= a[-1]:
            ax.plot(f_point, a_point, marker="o", ms=5, mfc="white", mec="black", zorder=5)
            ax.annotate(name, (f_point, a_point), xytext=(7, 5), textcoords="offset points",
                        ha="left", va="bottom", fontsize=12, fontweight="bold", zorder=5,
                        bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.3",
                                  alpha=0.85))

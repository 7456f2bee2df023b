"""The limit ``M -> 1``: regime maps for a growing resonant share of the mass.

One small regime map per mass ratio (up to six, 2 x 3): the steady mean velocity
over ``(f, a)`` in mm s-1 on one diverging scale shared by every panel (one colour
bar, so that colours compare across M), the thresholds ``a*_pm``, the
lift-off region (grey, no velocity: outside the model), continuous sliding
(status ``continuous_sliding``, hatched and outlined), points without a periodic
orbit (black) and the zero-velocity frontier ``f*(a)`` as black dots. The paper: as
``M -> 1`` the region PN (above both thresholds) widens and the frontier gains
branches. Thresholds and lift-off come from the file, or else from their closed
forms for the structure stored in it.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.patheffects as patheffects
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.colors import TwoSlopeNorm
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from study.figures.common import (
    VALID,
    coupling_label,
    in_the_air,
    is_flight,
    is_two_way,
    lift_off_label,
    require_axis,
    require_dims,
    restore_dim,
    save,
    selection_text,
    status_handles,
    status_hatches,
    status_layers,
    structure_from_dataset,
    structure_text,
)
from study.model import lift_off_acceleration, thresholds
from study.model.status import Status

__all__ = ["draw", "panel_indices", "valid_velocity_mm_s"]

MAX_PANELS = 6
_STROKE = [patheffects.withStroke(linewidth=3.0, foreground="white")]
_BOUNCING_EDGE = "darkgreen"


def valid_velocity_mm_s(velocity: np.ndarray, status: np.ndarray) -> np.ma.MaskedArray:
    """Velocity [mm s-1], masked wherever it is not a valid steady velocity.

    Lift-off and not-converged points (and any NaN) are masked: they are drawn as
    their own regions, never as a velocity.
    """
    velocity = np.asarray(velocity, dtype=np.float64)
    status = np.asarray(status)
    valid = np.isin(status, VALID)
    valid &= np.isfinite(velocity)
    return np.ma.masked_where(~valid, 1e3 * velocity)


def panel_indices(n: int, limit: int = MAX_PANELS) -> list[int]:
    """Indices of at most ``limit`` of ``n`` mass ratios, evenly spread, ends included."""
    if n <= limit:
        return list(range(n))
    return sorted(set(np.rint(np.linspace(0, n - 1, limit)).astype(int).tolist()))


def _norm(panels: list[np.ma.MaskedArray]) -> TwoSlopeNorm:
    """One diverging norm for every panel, centred on 0, each side scaled to its own
    extreme over all panels."""
    counted = [v for v in panels if v.count()]
    if counted:
        low = min(float(v.min()) for v in counted)
        high = max(float(v.max()) for v in counted)
    else:
        low = high = 0.0
    scale = max(abs(low), abs(high), 1e-9)
    low = min(low, -1e-3 * scale)
    high = max(high, 1e-3 * scale)
    return TwoSlopeNorm(vcenter=0.0, vmin=low, vmax=high)


def _closed(dataset: xr.Dataset, name: str, at: dict, structure, f) -> np.ndarray:
    if name in dataset:
        return dataset[name].isel(at).values
    if name == "lift_off_acceleration":
        return lift_off_acceleration(structure, f)
    a_plus, a_minus = thresholds(structure, f)
    return a_plus if name == "a_star_plus" else a_minus


def _velocity(dataset: xr.Dataset, at: dict) -> np.ma.MaskedArray:
    status = dataset["status"].isel(at).transpose("f", "a").values
    return valid_velocity_mm_s(dataset["velocity"].isel(at).transpose("f", "a").values, status)


def _panel(ax, dataset: xr.Dataset, at: dict, norm: TwoSlopeNorm):
    """One map; returns its velocity mesh (for the figure's one colour bar)."""
    f = dataset["f"].values
    a = dataset["a"].values
    structure = structure_from_dataset(dataset, **at)
    status = dataset["status"].isel(at).transpose("f", "a").values
    v = _velocity(dataset, at)
    mesh = ax.pcolormesh(f, a, v.T, cmap="RdBu", norm=norm, shading="nearest",
                         rasterized=True)
    status_layers(ax, f, a, status.T)
    status_hatches(ax, f, a, status.T)
    sliding = (status == Status.CONTINUOUS_SLIDING).astype(float)
    if sliding.any() and min(sliding.shape) > 1:
        ax.contour(f, a, sliding.T, levels=[0.5], colors="k", linewidths=0.7)
    airborne = (dataset["airborne_fraction"].isel(at).transpose("f", "a").values
                if "airborne_fraction" in dataset else None)
    bouncing = in_the_air(status, airborne).astype(float)
    if bouncing.any() and min(bouncing.shape) > 1:  # with flight: the region's edge
        ax.contour(f, a, bouncing.T, levels=[0.5], colors=_BOUNCING_EDGE, linewidths=1.1)

    a_plus = _closed(dataset, "a_star_plus", at, structure, f)
    a_minus = _closed(dataset, "a_star_minus", at, structure, f)
    if is_two_way(dataset):
        # The closed-form lift-off is the one-way model's (a base at rest): a two-way
        # coupled base that slides lifts off elsewhere (at M = 0.8 near 7 m s-2 where
        # the estimate says 3), so the study's own lift-off (the lift-off layer, the
        # bouncing edge) is drawn instead, and the thresholds whole.
        for threshold, color in ((a_plus, "tab:blue"), (a_minus, "tab:red")):
            ax.plot(f, threshold, color=color, lw=1.4, path_effects=_STROKE)
    else:
        a_lift = _closed(dataset, "lift_off_acceleration", at, structure, f)
        for threshold, color in ((a_plus, "tab:blue"), (a_minus, "tab:red")):
            # Above lift-off a threshold is outside the model: thin and dotted there.
            below = threshold < a_lift
            ax.plot(f, np.where(below, threshold, np.nan), color=color, lw=1.4,
                    path_effects=_STROKE)
            ax.plot(f, np.where(below, np.nan, threshold), color=color, lw=0.8, ls=":")
        ax.plot(f, a_lift, color="k", lw=0.9, ls="--")

    branches = 0
    if "frontier_frequency" in dataset:
        frontier = dataset["frontier_frequency"].isel(at).transpose("a", "branch").values
        found = np.isfinite(frontier)
        branches = int(found.sum(axis=1).max(initial=0))
        rows = np.nonzero(found)
        ax.plot(frontier[rows], a[rows[0]], "o", color="k", ms=2.2, zorder=5)

    valid = np.isin(status, VALID)
    above_both = a[None, :] > np.maximum(a_plus, a_minus)[:, None]
    pn_share = np.count_nonzero(above_both & valid) / max(np.count_nonzero(valid), 1)
    cs_share = np.count_nonzero(status == Status.CONTINUOUS_SLIDING) / status.size
    title = (f"M = {structure.M:g}: {branches} frontier branch"
             f"{'' if branches == 1 else 'es'}, CS {100 * cs_share:.0f} %")
    if is_flight(dataset):
        title += f", bouncing {100 * np.count_nonzero(bouncing) / status.size:.0f} %"
    # The points of the classes drawn apart by a flat colour or a hatch, counted on a
    # second line: on one line a panel's title runs into its neighbour's.
    counted = [f"{np.count_nonzero(status == flag)} {flag.flag.replace('_', ' ')}"
               for flag in (Status.CHAOTIC, Status.QUASI_PERIODIC, Status.NOT_CONVERGED)
               if np.any(status == flag)]
    if counted:
        title += "\n" + ", ".join(counted)
    ax.set_title(title, fontsize=10)
    ax.text(0.02, 0.97, f"PN: {100 * pn_share:.0f} % of the valid map", transform=ax.transAxes,
            fontsize=8, va="top", bbox={"facecolor": "white", "edgecolor": "none",
                                        "alpha": 0.85, "pad": 1.5})
    ax.set(xlim=(f[0], f[-1]), ylim=(a[0], a[-1]))
    return mesh


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the regime maps of a ``mass-ratio-limit`` result; returns the PNG and the PDF."""
    dataset = require_dims(dataset, "mass-ratio-limit", ("M", "f", "a"),
                           "one regime map per M", variable="velocity")
    for axis in ("f", "a"):
        require_axis(dataset, "mass-ratio-limit", axis, "a regime map over (f, a) per M")
    # One frontier branch selected (--sel branch=0): that branch alone.
    dataset = restore_dim(dataset, "branch", ("frontier_frequency",))
    swept = "M" in dataset["velocity"].dims
    ats = [{"M": i} for i in panel_indices(dataset.sizes["M"])] if swept else [{}]
    ncols = min(len(ats), 3)
    nrows = -(-len(ats) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.2 * ncols, 4.0 * nrows + 0.9),
                             layout="constrained", sharex=True, sharey=True, squeeze=False)
    norm = _norm([_velocity(dataset, at) for at in ats])
    mesh = None
    for k, ax in enumerate(axes.flat):
        if k >= len(ats):
            ax.set_visible(False)
            continue
        mesh = _panel(ax, dataset, ats[k], norm)
        if k % ncols == 0:
            ax.set_ylabel("drive acceleration a [m s$^{-2}$]")
        if k // ncols == nrows - 1 or k + ncols >= len(ats):
            ax.set_xlabel("drive frequency f [Hz]")
            ax.xaxis.set_tick_params(labelbottom=True)

    two_way = is_two_way(dataset)
    handles = [
        Line2D([], [], color="tab:blue", lw=1.4, path_effects=_STROKE,
               label="$a^*_+$ (forward slips start)"),
        Line2D([], [], color="tab:red", lw=1.4, path_effects=_STROKE,
               label="$a^*_-$ (backward slips start)"),
        *([] if two_way else [
            Line2D([], [], color="0.3", lw=0.8, ls=":",
                   label="$a^*_\\pm$ above lift-off (invalid)"),
            Line2D([], [], color="k", lw=0.9, ls="--", label=lift_off_label(dataset))]),
        *(status_handles([Status.LIFT_OFF]) if not is_flight(dataset) else
          [Line2D([], [], color=_BOUNCING_EDGE, lw=1.1,
                  label="edge of the bouncing region: where this study's base leaves "
                        "the table")]),
        Patch(facecolor="none", edgecolor="k", hatch=Status.CONTINUOUS_SLIDING.hatch,
              label=f"{Status.CONTINUOUS_SLIDING.legend} (CS)"),
        *status_handles(flag for flag in Status
                        if (flag.colour is not None or flag.hatch is not None)
                        and flag not in (Status.LIFT_OFF, Status.CONTINUOUS_SLIDING)
                        and np.any(dataset["status"].values == flag)),
        Line2D([], [], ls="none", marker="o", color="k", ms=3, label="frontier $f^*(a)$"),
    ]
    fig.colorbar(mesh, ax=[ax for ax in axes.flat if ax.get_visible()], pad=0.01, shrink=0.9,
                 label="mean velocity v [mm s$^{-1}$] (one scale, all panels)")
    fig.legend(handles=handles, loc="outside lower center", ncols=3, fontsize=9)
    title = (
        "The limit M -> 1: steady velocity over (f, a) as the resonant share of the mass "
        f"grows, {coupling_label(dataset)} ({structure_text(dataset, tex=False)})"
    )
    selected = selection_text(dataset)
    fig.suptitle(title.replace(" (f0", "\n(f0", 1).replace("grows, ", "grows,\n", 1)
                 + "; PN: above both thresholds"
                 + (f"\n{selected}" if selected else ""), fontsize=11)
    return save(fig, output, dataset, title)

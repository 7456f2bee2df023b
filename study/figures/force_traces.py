"""The paper's Fig. 2 insets: normal and tangential forces at drive points.

``n(t)/g`` and ``tau(t)/(cs g)`` over two drive periods, in closed form for the
structure stored in the result file (``study figure force-traces FILE``); each panel
also gives the velocity the file holds at the grid point nearest to its point. A slip
is possible forward where ``tau > cs n`` and backward where ``-tau > cs n``.

The points: those named with ``--point F,A`` (repeatable); by default the paper's four
points S, P, N, PN for the paper's structure (:mod:`study.model.paper`), and for any other
structure one point in each region the file's grid holds below lift-off (S, P, N, PN:
the grid point nearest the middle of the region, :func:`regime_points`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from study.figures import FigureError, common
from study.figures.common import (
    PAPER_POINTS,
    coupling_label,
    is_paper_file,
    parameter_text,
    single_structure,
)
from study.model.forces import (
    lift_off_acceleration,
    normal_force,
    tangential_force,
    thresholds,
)
from study.model.status import Status

__all__ = ["draw", "regime_points", "region_of"]

#: Drive periods shown.
PERIODS = 2.0


def region_of(a: float, a_plus: float, a_minus: float) -> str:
    """The paper's region name of a drive acceleration: S, P, N or PN."""
    forward, backward = a > a_plus, a > a_minus
    return {(False, False): "S", (True, False): "P", (False, True): "N",
            (True, True): "PN"}[(bool(forward), bool(backward))]


def _slack(values: np.ndarray) -> float:
    """Half the mean spacing of a grid axis (0 for a single value)."""
    return 0.5 * float(np.ptp(values)) / (values.size - 1) if values.size > 1 else 0.0


def regime_points(dataset: xr.Dataset) -> dict[str, tuple[float, float]]:
    """One drive point in each region (S, P, N, PN) the file's grid holds below
    lift-off: the grid point of the region nearest to the region's mean position (in
    coordinates scaled by the grid's ranges)."""
    structure = common.structure_from_dataset(dataset)
    f = np.atleast_1d(dataset["f"].values).astype(float)
    a = np.atleast_1d(dataset["a"].values).astype(float)
    a_plus, a_minus = thresholds(structure, f)
    a_lift = lift_off_acceleration(structure, f)
    ff, aa = np.meshgrid(f, a, indexing="ij")
    usable = (aa < a_lift[:, None]) & (aa > 0)
    if "status" in dataset and dataset["status"].dims == ("f", "a"):
        usable &= dataset["status"].transpose("f", "a").values != Status.LIFT_OFF
    forward, backward = aa > a_plus[:, None], aa > a_minus[:, None]
    scale_f = max(float(np.ptp(f)), 1e-12)
    scale_a = max(float(np.ptp(a)), 1e-12)
    points = {}
    for name, (fw, bw) in (("S", (False, False)), ("P", (True, False)),
                           ("N", (False, True)), ("PN", (True, True))):
        inside = usable & (forward == fw) & (backward == bw)
        if not inside.any():
            continue
        fs, as_ = ff[inside], aa[inside]
        distance = np.hypot((fs - fs.mean()) / scale_f, (as_ - as_.mean()) / scale_a)
        k = int(np.argmin(distance))
        points[name] = (float(fs[k]), float(as_[k]))
    return points


def _grid_text(dataset: xr.Dataset, f_point: float, a_point: float) -> str:
    """What the file holds at the grid point nearest to (f_point, a_point)."""
    f, a = np.atleast_1d(dataset["f"].values), np.atleast_1d(dataset["a"].values)
    if not (f.min() - _slack(f) <= f_point <= f.max() + _slack(f)
            and a.min() - _slack(a) <= a_point <= a.max() + _slack(a)):
        return (f"outside the file's grid (f {f.min():g}-{f.max():g} Hz, "
                f"a {a.min():g}-{a.max():g} m s$^{{-2}}$): no velocity")
    near = dataset.sel({d: v for d, v in (("f", f_point), ("a", a_point)) if d in dataset.dims},
                       method="nearest")
    velocity = float(near["velocity"])
    where = (f"nearest grid point ({float(near['f']):.4g} Hz, "
             f"{float(near['a']):.3g} m s$^{{-2}}$)")
    code = int(near["status"]) if "status" in near else None
    if code == Status.LIFT_OFF:
        return f"{where}: lift-off (model invalid)"
    if code == Status.NOT_CONVERGED:
        return f"{where}: not converged"
    if code == Status.STATIC or velocity == 0.0:
        return f"{where}: static, v = 0"
    if not np.isfinite(velocity):
        return f"{where}: no velocity"
    text = f"{where}: v = {1e3 * velocity:+.3g} mm s$^{{-1}}$"
    if "velocity_one_way" in near and "status_one_way" in near:
        # A two-way study with the paper's model beside it.
        paper = float(near["velocity_one_way"])
        text += (f"\nthe one-way (paper's) model: v = {1e3 * paper:+.3g} mm s$^{{-1}}$"
                 if np.isfinite(paper)
                 else "\nthe one-way (paper's) model: no velocity")
    return text


def draw(dataset: xr.Dataset, output: Path,
         points: Sequence[tuple[float, float]] | None = None) -> list[Path]:
    """Draw the force traces at drive points into ``output.png/.pdf``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result over (f, a) holding the velocity (and normally the status), with
        the structure's parameters as scalar coordinates.
    output : pathlib.Path
        File stem.
    points : sequence of (f [Hz], a [m s-2]), optional
        The points (default: the paper's four for the paper's structure, else
        :func:`regime_points`).

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    dataset = single_structure(dataset, "force-traces")
    structure = common.structure_from_dataset(dataset)
    chosen, which = _chosen_points(dataset, points)
    ncols = 1 if len(chosen) == 1 else 2
    nrows = -(-len(chosen) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.0 * ncols, 3.3 * nrows + 0.6),
                             sharex=True, sharey=True, layout="constrained", squeeze=False)
    for ax in axes.flat[len(chosen):]:
        ax.set_visible(False)
    lowest = highest = 0.0
    any_lift = False
    for ax, (name, (f_point, a_point)) in zip(axes.flat, chosen.items(), strict=False):
        lows, highs, lifted = _trace(ax, dataset, structure, name, f_point, a_point)
        any_lift = any_lift or lifted
        lowest = min(lowest, *lows)
        highest = max(highest, *highs)
    pad = 0.06 * (highest - lowest)
    axes[0, 0].set(xlim=(0.0, PERIODS), ylim=(lowest - pad, highest + pad))
    for k, ax in enumerate(axes.flat[:len(chosen)]):
        if k + ncols >= len(chosen):
            ax.set_xlabel("time t / T  (T = 1/f: drive periods)")
            ax.xaxis.set_tick_params(labelbottom=True)
    for ax in axes[:, 0]:
        ax.set_ylabel("force per unit weight [1]")

    title = f"Contact forces over two drive periods {which}"
    traces = "forces with the base at rest and the mode on its steady response"
    if dataset.attrs.get("study_coupling") == "two-way":
        # Two-way coupling changes the forces only once the base slides: the traces
        # still decide where slips start, the velocities are the file's.
        traces += " (as in both couplings until a slip starts)"
    title = f"{title}; velocities: {coupling_label(dataset)}"
    fig.suptitle(f"{title.replace('; ', chr(10), 1)}\n{traces}\n{parameter_text(dataset)}",
                 fontsize=10.5)
    fig.legend(handles=_legend_handles(any_lift), loc="outside lower center", ncol=3,
               fontsize=8.5, frameon=False)
    return common.save(fig, output, dataset,
                       f"{title} ({common.structure_text(dataset, tex=False)})")


def _chosen_points(dataset: xr.Dataset, points: Sequence[tuple[float, float]] | None
                   ) -> tuple[dict[str, tuple[float, float]], str]:
    """The drive points to draw by name, and which they are for the title."""
    if points:
        chosen = {f"point {k + 1}": (float(fp), float(ap))
                  for k, (fp, ap) in enumerate(points)}
        return chosen, "at the points asked for"
    if is_paper_file(dataset):
        return dict(PAPER_POINTS), "at the paper's points S, P, N, PN"
    chosen = regime_points(dataset)
    which = "at a point of each region " + ", ".join(chosen) + " of the file's grid"
    if not chosen:
        selected = dataset.attrs.get("study_selection")
        grid = f"the grid as selected ({selected})" if selected else "the grid"
        raise FigureError(
            "figure 'force-traces' draws the forces at a point of each region of the "
            f"file's grid of (f, a), but {grid} holds no point with 0 < a below "
            "lift-off; name points with --point F,A"
            + (" or select other values of f and a" if selected else ""))
    return chosen, which


def _trace(ax: plt.Axes, dataset: xr.Dataset, structure, name: str, f_point: float,
           a_point: float) -> tuple[tuple[float, float], tuple[float, float], bool]:
    """One point's panel: n(t), -n(t) and tau(t)/cs over two periods, the phases where
    a slip is possible shaded. Returns the lowest and the highest values drawn [1] and
    whether the base lifts off."""
    g, cs = structure.g, structure.cs
    phase = np.linspace(0.0, PERIODS, 1601)  # time in drive periods
    t = phase / f_point
    n = normal_force(structure, f_point, a_point, t)
    tau = tangential_force(structure, f_point, a_point, t)
    lifted = n < 0.0  # outside the model: neither slip criterion applies
    forward = (tau > cs * n) & ~lifted
    backward = (-tau > cs * n) & ~lifted
    strip = ax.get_xaxis_transform()
    ax.fill_between(phase, 0, 1, where=forward, color="tab:blue", alpha=0.18, lw=0,
                    transform=strip)
    ax.fill_between(phase, 0, 1, where=backward, color="tab:red", alpha=0.18, lw=0,
                    transform=strip)
    if np.any(lifted):
        ax.fill_between(phase, 0, 1, where=lifted, facecolor="none", edgecolor="0.4",
                        hatch="xx", lw=0, transform=strip)
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.plot(phase, n / g, color="black", lw=1.6)
    ax.plot(phase, -n / g, color="black", lw=0.9, ls=":")
    ax.plot(phase, tau / (cs * g), color="tab:purple", lw=1.6)

    a_plus, a_minus = (float(x) for x in thresholds(structure, f_point))
    model = region_of(a_point, a_plus, a_minus)
    if name.startswith("point"):
        region = f"{name}, region {model}"
    else:
        region = f"region {name}" if model == name else f"region {name} (model: {model})"
    ax.set_title(
        f"{region}: f = {f_point:g} Hz, a = {a_point:g} m s$^{{-2}}$\n"
        f"{_grid_text(dataset, f_point, a_point)}",
        fontsize=9.5,
    )
    return ((float(np.min(-n / g)), float(np.min(tau / (cs * g)))),
            (float(np.max(n / g)), float(np.max(tau / (cs * g)))), bool(np.any(lifted)))


def _legend_handles(any_lift: bool) -> list:
    """The legend of the traces (lift-off only where some panel lifts off)."""
    handles = [
        Line2D([], [], color="black", lw=1.6, label="n(t) / g  (normal)"),
        Line2D([], [], color="black", lw=0.9, ls=":", label="-n(t) / g"),
        Line2D([], [], color="tab:purple", lw=1.6, label=r"$\tau(t)$ / ($c_s$ g)  (tangential)"),
        Patch(facecolor="tab:blue", alpha=0.18, label=r"$\tau > c_s n$: forward slip possible"),
        Patch(facecolor="tab:red", alpha=0.18,
              label=r"$-\tau > c_s n$: backward slip possible"),
    ]
    if any_lift:
        handles.append(Patch(facecolor="none", edgecolor="0.4", hatch="xx",
                             label="n < 0: lift-off, model invalid"))
    return handles

"""Steering through waypoints: an open-loop plan against closed-loop correction.

Drawn from a ``steering-plan`` result file alone (``study figure steering-plan FILE``),
a plan scene: waypoints, the noise-free open-loop plan (its segments and where it
predicts each leg to end), and the disk's path for each strategy and realisation of
the heading noise (realisation 0 is noise-free). Left: the waypoints, the start pose
and every path (open loop dashed, closed loop solid, noise-free thick). Right: the
distance by which each run misses each waypoint, with the disk's diameter for scale.
"""

from __future__ import annotations

import textwrap
import warnings
from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from study.figures import FigureError
from study.figures.common import restore_dim, save, scene_suptitle, selected_keys
from study.figures.steering import angle_values, check_scene_kind, heading_arrow, labels_of

__all__ = ["STRATEGY_STYLES", "draw"]

#: Colour and line style of each strategy; others take the fallback colours, dotted.
STRATEGY_STYLES: dict[str, tuple[str, str]] = {
    "open_loop": ("tab:orange", "--"),
    "closed_loop": ("tab:blue", "-"),
}
OTHER_COLORS = ("tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan")


def _styles(strategies: list[str]) -> dict[str, tuple[str, str]]:
    styles, others = {}, 0
    for name in strategies:
        if name in STRATEGY_STYLES:
            styles[name] = STRATEGY_STYLES[name]
        else:
            styles[name] = (OTHER_COLORS[others % len(OTHER_COLORS)], ":")
            others += 1
    return styles


#: A plan's variables along each of its dimensions: a selection of one value
#: (``--sel strategy_name=open_loop``, ``realisation=0``, ``waypoint=1``, ``t=10``)
#: keeps the dimension with length 1 and the figure draws what is left.
ALONG = {
    "strategy": ("x", "y", "heading", "miss_distance", "run_status", "strategy_name"),
    "realisation": ("x", "y", "heading", "miss_distance", "run_status",
                    "realisation_heading_drift"),
    "t": ("x", "y", "heading"),
    "waypoint": ("waypoint_x", "waypoint_y", "planned_x", "planned_y", "miss_distance"),
    "segment": ("segment_label", "frequency", "acceleration", "duration"),
}


def _noise_free(dataset: xr.Dataset) -> int | None:
    """Index of the noise-free realisation (coordinate value 0; without a coordinate,
    the first), None when the selection left it out."""
    if "realisation" not in dataset.coords:
        return 0
    zero = np.flatnonzero(dataset["realisation"].values == 0)
    return int(zero[0]) if zero.size else None


def _plan_text(dataset: xr.Dataset) -> str:
    """The noise-free open-loop plan, by label: count, frequency and total duration."""
    if "segment_label" not in dataset:
        return ""
    labels = labels_of(dataset["segment_label"].values)
    frequency = dataset["frequency"].values if "frequency" in dataset else None
    duration = dataset["duration"].values if "duration" in dataset else None
    parts = []
    for label in dict.fromkeys(labels):
        picked = np.array([lab == label for lab in labels])
        text = f"{label} x{int(picked.sum())}"
        if frequency is not None:
            text += " at " + ", ".join(f"{v:g}" for v in
                                       sorted({round(float(v), 3) for v in frequency[picked]}))
            text += " Hz"
        if duration is not None:
            text += f" ({float(np.nansum(duration[picked])):.3g} s)"
        parts.append(text)
    total = f", {float(np.nansum(duration)):.3g} s in all" if duration is not None else ""
    return f"open-loop plan: {len(labels)} segments{total}: " + "; ".join(parts)


@dataclass(frozen=True)
class _Plan:
    """What the plan figure draws, read from the file: positions in mm, angles in degree."""

    x: np.ndarray  # (strategy, realisation, t)
    y: np.ndarray
    miss: np.ndarray  # (strategy, realisation, waypoint)
    wx: np.ndarray
    wy: np.ndarray
    numbers: np.ndarray  # the waypoints' numbers, from 1
    strategies: list[str]
    styles: dict[str, tuple[str, str]]
    clean: int | None  # the noise-free realisation
    single: bool  # one time selected (--sel t=10): the poses at that time
    radius: float
    start: list[float]
    start_heading: float

    @property
    def n_real(self) -> int:
        return self.x.shape[1]

    @property
    def diameter(self) -> float:
        return 2 * self.radius if np.isfinite(self.radius) and self.radius > 0 else np.nan

    @property
    def noisy(self) -> list[int]:
        return [r for r in range(self.n_real) if r != self.clean]


def _read_plan(dataset: xr.Dataset) -> _Plan:
    """The plan's paths, waypoints, misses and start pose, checked."""
    for name in ("x", "y"):
        if set(dataset[name].dims) != {"strategy", "realisation", "t"}:
            raise FigureError(
                f"figure 'steering-plan' draws paths over (strategy, realisation, t); "
                f"{name!r} has dimensions {dataset[name].dims}"
            )
    order = ("strategy", "realisation", "t")
    x = 1e3 * dataset["x"].transpose(*order).values
    y = 1e3 * dataset["y"].transpose(*order).values
    miss = 1e3 * dataset["miss_distance"].transpose("strategy", "realisation", "waypoint").values
    wx = 1e3 * dataset["waypoint_x"].values
    wy = 1e3 * dataset["waypoint_y"].values
    names = dataset["strategy_name"] if "strategy_name" in dataset.variables else (
        dataset["strategy"])
    strategies = labels_of(names.values)
    clean = _noise_free(dataset)
    first = 0 if clean is None else clean
    radius = 1e3 * float(dataset.attrs.get("disk_radius", np.nan))
    start = [1e3 * float(dataset.attrs[k]) if k in dataset.attrs else np.nan
             for k in ("start_x", "start_y")]
    if not np.all(np.isfinite(start)):
        start = [x[0, first, 0], y[0, first, 0]]
    start_heading = float(dataset.attrs.get("start_heading", np.nan))  # degree
    if not np.isfinite(start_heading) and "heading" in dataset:
        angle_values(dataset, "heading", "steering-plan")
        start_heading = float(dataset["heading"].transpose(*order).values[0, first, 0])
    numbers = (dataset["waypoint"].values + 1 if "waypoint" in dataset.coords
               else np.arange(1, wx.size + 1))
    return _Plan(x=x, y=y, miss=miss, wx=wx, wy=wy, numbers=numbers, strategies=strategies,
                 styles=_styles(strategies), clean=clean, single=x.shape[2] == 1,
                 radius=radius, start=start, start_heading=start_heading)


def _plot(dataset: xr.Dataset) -> plt.Figure:
    """The plan figure (not saved): paths carry gid ``path-STRATEGY-I`` for realisation
    index ``I``, the miss-distance points ``miss-STRATEGY``."""
    check_scene_kind(dataset, "steering-plan", "plan")
    for dim, names in ALONG.items():
        dataset = restore_dim(dataset, dim, names)
    plan = _read_plan(dataset)
    fig, (left, right) = plt.subplots(1, 2, figsize=(12.5, 5.8), layout="constrained",
                                      width_ratios=(1.2, 1.0))
    _draw_paths(left, dataset, plan)
    _draw_misses(right, dataset, plan)
    scene_suptitle(fig, dataset, _title(dataset, plan), 9)
    return fig


def _draw_paths(left: plt.Axes, dataset: xr.Dataset, plan: _Plan) -> None:
    """Left: waypoints, start pose, all paths."""
    x, y, wx, wy, radius, start = plan.x, plan.y, plan.wx, plan.wy, plan.radius, plan.start
    for s, strategy in enumerate(plan.strategies):
        color, style = plan.styles[strategy]
        for r in range(plan.n_real):
            thick = r == plan.clean
            (line,) = left.plot(x[s, r], y[s, r], ls=style, color=color,
                                marker="o" if plan.single else None, ms=6 if thick else 3.5,
                                lw=2.0 if thick else 0.7, alpha=1.0 if thick else 0.45,
                                zorder=(3.5 if style != "-" else 3) if thick else 2)
            line.set_gid(f"path-{strategy}-{r}")
    if np.isfinite(plan.diameter):
        for px, py in zip(wx, wy, strict=True):
            left.add_patch(Circle((px, py), radius, fill=False, color="0.55", lw=0.7,
                                  ls=":"))
        left.add_patch(Circle(start, radius, fill=False, color="0.2", lw=1.0))
    left.plot(wx, wy, "*", color="black", ms=11, zorder=5)
    for number, px, py in zip(plan.numbers, wx, wy, strict=True):
        left.annotate(str(number), (px, py), xytext=(6, 5), textcoords="offset points",
                      fontsize=10, fontweight="bold")
    if "planned_x" in dataset and "planned_y" in dataset:
        left.plot(1e3 * dataset["planned_x"].values, 1e3 * dataset["planned_y"].values, "s",
                  mfc="none", color="0.3", ms=6, zorder=4)
    left.plot(*start, "o", color="black", ms=4, zorder=5)
    if np.isfinite(plan.start_heading):
        extent = max(float(np.nanmax(x) - np.nanmin(x)), float(np.nanmax(y) - np.nanmin(y)),
                     1e-3)
        length = radius if np.isfinite(radius) and radius > 0 else 0.05 * extent
        heading_arrow(left, start[0], start[1], plan.start_heading, length, lw=1.2,
                      color="black")
    left.annotate("start", start, xytext=(4, -12), textcoords="offset points", fontsize=8)
    left.set_aspect("equal", adjustable="datalim")
    left.set_xlabel("x [mm]")
    left.set_ylabel("y [mm]")
    left.grid(color="0.92", lw=0.6)
    left.set_title(f"waypoints and the positions at t = {float(dataset['t'].values[0]):g} s"
                   if plan.single else "waypoints and paths", fontsize=10)
    left.legend(handles=_path_handles(dataset, plan), fontsize=8, loc="upper center",
                bbox_to_anchor=(0.5, -0.13), ncol=3, frameon=False)


def _path_handles(dataset: xr.Dataset, plan: _Plan) -> list[Line2D]:
    """The legend of the paths' panel."""
    styles, clean = plan.styles, plan.clean
    handles = [Line2D([], [], color=styles[s][0], ls=styles[s][1], lw=1.5,
                      label=s.replace("_", " ")) for s in plan.strategies]
    handles += [
        *([Line2D([], [], color="0.3", lw=2.0, label="noise-free (thick)")]
          if clean is not None else []),
        *([Line2D([], [], color="0.3", lw=0.7, alpha=0.6, label="heading noise (thin)")]
          if plan.n_real > (clean is not None) else []),
        Line2D([], [], marker="*", color="black", ls="none", ms=10, label="waypoint"),
    ]
    if "planned_x" in dataset:
        handles.append(Line2D([], [], marker="s", mfc="none", color="0.3", ls="none", ms=6,
                              label="plan's predicted leg end"))
    if np.isfinite(plan.diameter):
        handles.append(Line2D([], [], color="0.55", ls=":", lw=0.8,
                              label="disk outline centred on a waypoint"))
        handles.append(Line2D([], [], color="0.2", lw=1.0, label="disk at the start"))
    return handles


def _draw_misses(right: plt.Axes, dataset: xr.Dataset, plan: _Plan) -> None:
    """Right: miss distance per waypoint, each realisation and the noisy ones' median."""
    strategies, styles, clean, noisy, miss = (plan.strategies, plan.styles, plan.clean,
                                              plan.noisy, plan.miss)
    n_way = plan.wx.size
    positions = np.arange(1, n_way + 1)
    width = 0.6 / max(len(strategies), 1)
    jitter = np.linspace(-0.35, 0.35, len(noisy)) * width if noisy else np.zeros(0)
    for s, strategy in enumerate(strategies):
        color, _ = styles[strategy]
        centre = positions + (s - (len(strategies) - 1) / 2) * width
        if noisy:
            px = (centre[None, :] + jitter[:, None]).ravel()
            right.plot(px, miss[s, noisy].ravel(), "o", color=color, ms=3.5, alpha=0.55,
                       mew=0, gid=f"miss-{strategy}", clip_on=False)
            with warnings.catch_warnings():  # a waypoint no noisy run has a distance to
                warnings.simplefilter("ignore", RuntimeWarning)
                median = np.nanmedian(miss[s, noisy], axis=0)
            right.hlines(median, centre - 0.45 * width, centre + 0.45 * width, color=color,
                         lw=1.5)
        if clean is not None:
            right.plot(centre, miss[s, clean], "D", color=color, mec="black", ms=7,
                       mew=1.0, zorder=4, gid=f"miss-{strategy}-noise-free", clip_on=False)
    diameter = plan.diameter
    if np.isfinite(diameter):
        right.axhline(diameter, color="0.3", ls="--", lw=1.0)
        right.annotate(f"disk diameter {diameter:g} mm", (0.01, diameter),
                       xycoords=("axes fraction", "data"), xytext=(0, 3),
                       textcoords="offset points", fontsize=8, color="0.3")
    if np.array_equal(plan.numbers, positions):
        right.set_xticks(positions)
    else:  # the waypoints selected, by their number
        right.set_xticks(positions, [str(n) for n in plan.numbers])
    right.set_xlim(0.5, n_way + 0.5)
    right.set_ylim(bottom=0.0)
    right.set_xlabel("waypoint")
    right.set_ylabel("miss distance [mm]")
    right.grid(axis="y", color="0.92", lw=0.6)
    right.set_title("distance from each waypoint"
                    + (" (whole runs, not only the times selected)"
                       if "t" in selected_keys(dataset) else ""), fontsize=10)
    miss_handles = [Line2D([], [], marker="o", color=styles[s][0], ls="none", ms=4, alpha=0.7,
                           label=f"{s.replace('_', ' ')}, noisy")
                    for s in strategies if noisy]
    if clean is not None:
        miss_handles += [Line2D([], [], marker="D", color="0.6", mec="black", ls="none",
                                ms=6, label="noise-free")]
    if noisy:
        miss_handles.append(Line2D([], [], color="0.3", lw=1.5, label="median of the noisy"))
    right.legend(handles=miss_handles, fontsize=8, loc="upper center",
                 bbox_to_anchor=(0.5, -0.13), ncol=2, frameon=False)


def _title(dataset: xr.Dataset, plan: _Plan) -> str:
    """The figure's heading: waypoints, strategies, the runs drawn and the plan."""
    noisy, n_way = plan.noisy, plan.wx.size
    noise = f"{len(noisy)} realisation{'s' if len(noisy) != 1 else ''} with heading noise"
    if "realisation_heading_drift" in dataset and noisy:
        drift = angle_values(dataset, "realisation_heading_drift", "steering-plan")[noisy]
        noise += (f" (drift rms {float(np.sqrt(np.nanmean(drift ** 2))):.3g} degree per "
                  "diameter)")
    runs = " and ".join(([] if plan.clean is None else ["noise-free"])
                        + ([noise] if noisy else []))
    title = (f"Steering through {n_way} waypoint{'s' if n_way != 1 else ''}: "
             f"{' vs '.join(s.replace('_', ' ') for s in plan.strategies)}, {runs}")
    text = _plan_text(dataset)
    return title + ("\n" + textwrap.fill(text, 170) if text else "")


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the waypoint plan of a ``steering-plan`` result into ``output.png/.pdf``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A plan scene: waypoints, the open-loop plan, and the paths and miss distances
        of each strategy and realisation.
    output : pathlib.Path
        File stem.

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    return save(_plot(dataset), output, dataset,
                "Steering through waypoints: open-loop plan against closed-loop correction")

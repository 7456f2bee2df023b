"""The paper's Fig. 4A: the disk steered by a sequence of drive frequencies.

Drawn from a ``steering`` result file alone (``study figure steering FILE``), a
trajectory scene: the disk's pose over time and, per segment of the frequency
sequence, its label, drive and outcome. Left: the path in the plane, each segment's
part coloured by its label, the disk's outline and heading arrows at the start, at
every segment boundary and at the end. Right: the heading against time over the
segments. Segments that did not complete (lift-off, not reached, step budget) are
marked in red.

The label colours and the flag decoding are shared with the other steering figures.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch

from study.figures import FigureError
from study.figures.common import restore_dim, save, scene_suptitle, selected_keys
from study.model.units import DEGREE

__all__ = [
    "LABEL_COLORS",
    "SEGMENT_STATUS",
    "angle_values",
    "check_scene_kind",
    "draw",
    "flag_codes",
    "flag_names",
    "label_colors",
    "labels_of",
]

#: Fixed colours of the paper's four commands; any other label takes the next of
#: :data:`OTHER_COLORS` in order of first appearance.
LABEL_COLORS: dict[str, str] = {
    "forward": "tab:blue",
    "backward": "tab:red",
    "left": "tab:green",
    "right": "tab:orange",
}
OTHER_COLORS = ("tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan", "tab:gray")

#: A segment's outcome (``segment_status``) when the file holds no flag attributes.
SEGMENT_STATUS = ("completed", "lift_off", "not_reached", "step_budget")

#: Red markers of the segments that did not complete, by status name.
STATUS_MARKERS = {"lift_off": "x", "not_reached": "o", "step_budget": "+"}


def labels_of(values: Iterable) -> list[str]:
    """Segment labels as ``str`` (a file may hold them as bytes or objects)."""
    return [v.decode() if isinstance(v, bytes) else str(v) for v in values]


def label_colors(labels: Sequence[str]) -> dict[str, str]:
    """Colour of each distinct label: fixed for forward/backward/left/right, the others
    from :data:`OTHER_COLORS` in order of first appearance (cycled)."""
    colors: dict[str, str] = {}
    others = 0
    for label in labels:
        if label in colors:
            continue
        key = label.strip().lower()
        if key in LABEL_COLORS:
            colors[label] = LABEL_COLORS[key]
        else:
            colors[label] = OTHER_COLORS[others % len(OTHER_COLORS)]
            others += 1
    return colors


def flag_names(variable: xr.DataArray, default: Sequence[str]) -> dict[int, str]:
    """Value -> name of a CF flag variable, from its ``flag_values``/``flag_meanings``
    attributes, else ``default`` (the name of value ``i`` at position ``i``)."""
    values = variable.attrs.get("flag_values")
    meanings = variable.attrs.get("flag_meanings")
    if values is not None and meanings:
        values = np.atleast_1d(values)
        names = str(meanings).split()
        if len(names) == len(values):
            return {int(v): name for v, name in zip(values, names, strict=True)}
    return dict(enumerate(default))


def flag_codes(variable: xr.DataArray, missing: int = -1) -> np.ndarray:
    """A flag variable's codes as ints (``missing`` where a reader masked it to NaN)."""
    values = np.asarray(variable.values)
    if np.issubdtype(values.dtype, np.floating):
        values = np.where(np.isfinite(values), values, missing)
    return values.astype(int)


def check_scene_kind(dataset: xr.Dataset, figure: str, kind: str) -> None:
    """Refuse a scene file of another kind (files without the attribute pass).

    Raises
    ------
    FigureError
        Naming the file's kind and the one the figure is drawn from.
    """
    found = dataset.attrs.get("study_scene_kind")
    if found is not None and str(found) != kind:
        raise FigureError(
            f"figure {figure!r} is drawn from a {kind!r} scene, but this file (study "
            f"{dataset.attrs.get('study_name')!r}) holds a {str(found)!r} scene"
        )


def frequency_text(values: Iterable[float]) -> str:
    """Distinct frequencies, compactly: ``"14.2 Hz"`` or ``"7.2, 8.2 Hz"``."""
    distinct = sorted({round(float(v), 3) for v in values if np.isfinite(v)})
    return ", ".join(f"{v:g}" for v in distinct) + " Hz" if distinct else "? Hz"


def value_range_text(values: np.ndarray) -> str:
    """``"8.5"`` for one distinct value, ``"7-9"`` for several."""
    finite = np.unique(np.round(values[np.isfinite(values)], 4))
    if finite.size == 0:
        return "?"
    if finite.size == 1:
        return f"{finite[0]:g}"
    return f"{finite.min():g}-{finite.max():g}"


def angle_values(dataset: xr.Dataset, name: str, figure: str,
                 units: str = DEGREE) -> np.ndarray:
    """The values of an angle (or angular rate) variable, which must be in ``units``.

    Raises
    ------
    FigureError
        When the variable states other units (an older file stored radians; validation
        refuses such a file as stale first).
    """
    found = dataset[name].attrs.get("units")
    if found != units:
        raise FigureError(f"figure {figure!r} reads {name!r} in {units!r}; this file "
                          f"states {found!r}: rerun its spec")
    return dataset[name].values


def heading_arrow(ax: plt.Axes, x: float, y: float, heading: float, length: float,
                  **style) -> None:
    """An arrow of ``length`` from ``(x, y)`` along ``heading`` (degree, from +x)."""
    angle = np.radians(heading)
    end = (x + length * np.cos(angle), y + length * np.sin(angle))
    ax.annotate("", xy=end, xytext=(x, y),
                arrowprops={"arrowstyle": "-|>", "lw": 0.7, "color": "0.2",
                            "shrinkA": 0, "shrinkB": 0, "mutation_scale": 8, **style})


#: A trajectory's variables over time ``t`` and over ``segment``: a selection of one
#: time or one segment keeps them as a dimension of length 1.
ALONG_T = ("x", "y", "heading", "path_length", "slipping", "segment_index")
ALONG_SEGMENT = ("segment_label", "frequency", "acceleration", "duration", "start_time",
                 "end_time", "forward_displacement", "lateral_displacement",
                 "heading_change", "segment_path_length", "segment_status",
                 "edge_contact_margin")


def _selected(dataset: xr.Dataset) -> xr.Dataset:
    """The trajectory as selected: one time or one segment kept as a dimension, the
    samples cut to the segments selected (``--sel segment=2``) and the segments to
    those of the times selected (``--sel t=0:5``)."""
    dataset = restore_dim(dataset, "t", ALONG_T)
    dataset = restore_dim(dataset, "segment", ALONG_SEGMENT)
    if "segment" not in dataset.coords or "segment_index" not in dataset:
        return dataset
    index = dataset["segment_index"].values
    kept = np.isin(index, dataset["segment"].values)
    if kept.all():
        if "t" in selected_keys(dataset):
            ran = np.isin(dataset["segment"].values, index)
            if not ran.all():
                dataset = dataset.isel(segment=np.flatnonzero(ran))
        return dataset
    if kept.any():
        return dataset.isel(t=np.flatnonzero(kept))
    segments = ", ".join(str(v) for v in dataset["segment"].values)
    why = ""
    if "segment_status" in dataset:
        names = flag_names(dataset["segment_status"], SEGMENT_STATUS)
        codes = flag_codes(dataset["segment_status"], missing=0)
        why = " (" + ", ".join(names.get(int(c), f"status {c}") for c in codes) + ")"
    selected = dataset.attrs.get("study_selection")
    left = f"the selection ({selected}) leaves" if selected else "this file holds"
    plural = "s" if dataset.sizes["segment"] != 1 else ""
    raise FigureError(
        f"figure 'steering' draws the trajectory over time in the segments it holds, but "
        f"{left} no sample of segment{plural} {segments}{why}: select segments the disk "
        "ran, and times within them")


def _ends_within(dataset: xr.Dataset, k: int, time: np.ndarray) -> bool:
    """Whether segment ``k`` ends within the times drawn (one without an end time, never
    reached, is marked where the trajectory stops)."""
    if "end_time" not in dataset:
        return True
    end = float(dataset["end_time"].values[k])
    step = float(np.min(np.diff(time))) if time.size > 1 else 0.0
    return not np.isfinite(end) or end <= float(time[-1]) + 0.5 * step


def _segments(dataset: xr.Dataset) -> list[np.ndarray]:
    """Sample indices of each segment (in the order of the ``segment`` dimension)."""
    index = dataset["segment_index"].values
    return [np.flatnonzero(index == value) for value in dataset["segment"].values]


@dataclass(frozen=True)
class _Trajectory:
    """What the steering figure draws, read from the file: positions in mm, heading in
    degree, and per segment its label, samples, number and status."""

    x: np.ndarray
    y: np.ndarray
    heading: np.ndarray
    time: np.ndarray
    labels: list[str]
    frequency: np.ndarray
    colors: dict[str, str]
    samples: list[np.ndarray]
    numbers: np.ndarray
    radius: float
    failed: dict[str, list[int]]  # status name: the segments that did not complete

    def ends(self, segments: list[int]) -> list[int]:
        """The last sample of each segment (the run's last for one never reached)."""
        return [int(self.samples[k][-1]) if self.samples[k].size else self.x.size - 1
                for k in segments]


def _read_trajectory(dataset: xr.Dataset) -> _Trajectory:
    """The trajectory and its segments, checked."""
    for name in ("x", "y", "heading", "segment_index"):
        if dataset[name].dims != ("t",):
            raise FigureError(
                f"figure 'steering' draws one trajectory over time; {name!r} has "
                f"dimensions {dataset[name].dims}"
            )
    x = 1e3 * dataset["x"].values
    y = 1e3 * dataset["y"].values
    heading = angle_values(dataset, "heading", "steering")  # degree
    time = dataset["t"].values
    if x.size == 0:
        raise FigureError("figure 'steering' needs a trajectory with samples; this one is empty")
    labels = labels_of(dataset["segment_label"].values)
    n_segments = len(labels)
    if "segment_status" in dataset:
        status = flag_codes(dataset["segment_status"], missing=0)
        names = flag_names(dataset["segment_status"], SEGMENT_STATUS)
    else:
        status = np.zeros(n_segments, dtype=int)
        names = dict(enumerate(SEGMENT_STATUS))
    cut = "t" in selected_keys(dataset)
    failed: dict[str, list[int]] = {}
    for k in np.flatnonzero(status != 0):
        if cut and not _ends_within(dataset, k, time):
            continue  # the times selected stop before this segment's end
        failed.setdefault(names.get(int(status[k]), f"status {status[k]}"), []).append(int(k))
    return _Trajectory(
        x=x, y=y, heading=heading, time=time, labels=labels,
        frequency=dataset["frequency"].values, colors=label_colors(labels),
        samples=_segments(dataset),
        numbers=(dataset["segment"].values if "segment" in dataset.coords
                 else np.arange(n_segments)),
        radius=1e3 * float(dataset.attrs.get("disk_radius", np.nan)), failed=failed)


def _plot(dataset: xr.Dataset) -> plt.Figure:
    """The steering figure (not saved): path lines carry gid ``segment-K``."""
    check_scene_kind(dataset, "steering", "trajectory")
    dataset = _selected(dataset)
    path = _read_trajectory(dataset)
    fig, (left, right) = plt.subplots(
        1, 2, figsize=(12.0, 5.6), layout="constrained", width_ratios=(1.15, 1.0))
    _draw_path(left, path)
    _draw_heading(right, dataset, path)
    scene_suptitle(fig, dataset, _title(dataset, path), 10)
    return fig


def _draw_path(left: plt.Axes, path: _Trajectory) -> None:
    """Left: the path, coloured by segment label, with the disk, headings and the ends
    of segments that did not complete."""
    x, y, radius, samples, colors = path.x, path.y, path.radius, path.samples, path.colors
    for k, (label, picked) in enumerate(zip(path.labels, samples, strict=True)):
        if picked.size == 0:
            continue
        first, last = int(picked[0]), int(picked[-1])
        span = slice(max(first - 1, 0), last + 1)  # joined to the previous segment's end
        (line,) = left.plot(x[span], y[span], color=colors[label], lw=1.8,
                            solid_capstyle="round", zorder=4)
        line.set_gid(f"segment-{path.numbers[k]}")
    if x.size == 1 or not any(p.size for p in samples):
        left.plot(x, y, ".", color="0.3")
    extent = max(float(np.nanmax(x) - np.nanmin(x)), float(np.nanmax(y) - np.nanmin(y)), 1e-3)
    arrow = radius if np.isfinite(radius) and radius > 0 else 0.05 * extent  # to the rim
    if np.isfinite(radius) and radius > 0:
        left.add_patch(Circle((x[0], y[0]), radius, fill=False, color="0.35", lw=1.0))
        left.add_patch(Circle((x[-1], y[-1]), radius, fill=False, color="0.35", lw=1.0,
                              ls="--"))
    poses = sorted({0, x.size - 1} | {int(p[0]) for p in samples if p.size})
    for i in poses:
        if np.isfinite(x[i]) and np.isfinite(y[i]) and np.isfinite(path.heading[i]):
            heading_arrow(left, x[i], y[i], path.heading[i], arrow)
    left.plot(x[0], y[0], "o", color="black", ms=4)
    left.annotate("start", (x[0], y[0]), xytext=(4, -10), textcoords="offset points",
                  fontsize=8)

    labels = path.labels
    handles: list = [
        Line2D([], [], color=colors[label], lw=2.0,
               label=f"{label} {frequency_text(path.frequency[[lab == label for lab in labels]])}")
        for label in colors
    ]
    handles.append(Line2D([], [], color="black", lw=0.8, marker=r"$\rightarrow$", ms=9,
                          ls="none", label="heading (start, boundaries, end; to the rim)"))
    if np.isfinite(radius):
        handles.append(Patch(fill=False, edgecolor="0.35",
                             label=f"disk, R = {radius:g} mm (start; end dashed)"))

    # Segments that did not complete: red marks at their end (where the run stopped
    # for those never reached).
    for name, segments in path.failed.items():
        marker = STATUS_MARKERS.get(name, "x")
        ends = path.ends(segments)
        face = "none" if marker == "o" else "tab:red"
        left.plot(x[ends], y[ends], marker, ls="none", color="tab:red", mfc=face, ms=9,
                  mew=1.8, gid=f"status-{name}")
        handles.append(Line2D([], [], marker=marker, ls="none", color="tab:red", mfc=face,
                              ms=8, mew=1.8,
                              label=f"{name}: segment{'s' if len(segments) > 1 else ''} "
                                    f"{', '.join(str(path.numbers[k]) for k in segments)}"))
    left.set_aspect("equal", adjustable="datalim")
    left.set_xlabel("x [mm]")
    left.set_ylabel("y [mm]")
    left.grid(color="0.92", lw=0.6)
    left.set_title("path of the disk's centre", fontsize=10)
    left.legend(handles=handles, fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13),
                ncol=2, frameon=False)


def _draw_heading(right: plt.Axes, dataset: xr.Dataset, path: _Trajectory) -> None:
    """Right: heading over time, segments shaded by label."""
    time, samples = path.time, path.samples
    starts = dataset["start_time"].values if "start_time" in dataset else None
    ends_t = dataset["end_time"].values if "end_time" in dataset else None
    for k, label in enumerate(path.labels):
        if starts is not None and ends_t is not None:
            t0, t1 = float(starts[k]), float(ends_t[k])
        elif samples[k].size:
            t0, t1 = float(time[samples[k][0]]), float(time[samples[k][-1]])
        else:
            continue
        if np.isfinite(t0) and np.isfinite(t1) and t1 > t0:
            right.axvspan(t0, t1, color=path.colors[label], alpha=0.18, lw=0)
    degrees = path.heading
    right.plot(time, degrees, color="black", lw=1.2, marker="." if time.size == 1 else None)
    for name, segments in path.failed.items():
        marker = STATUS_MARKERS.get(name, "x")
        ends = path.ends(segments)
        right.plot(time[ends], degrees[ends], marker, ls="none", color="tab:red",
                   mfc="none" if marker == "o" else "tab:red", ms=9, mew=1.8, clip_on=False)
    right.set_xlabel("time t [s]")
    right.set_ylabel("heading [degree] (counterclockwise from +x, unwrapped)")
    right.grid(color="0.92", lw=0.6)
    if time.size > 1:
        right.set_xlim(float(time[0]), float(time[-1]) if time[-1] > time[0] else None)
    right.set_title("heading; segments shaded by label", fontsize=10)


def _title(dataset: xr.Dataset, path: _Trajectory) -> str:
    """The figure's heading: segments (or the pose selected), drive, path length, time."""
    time, n_segments = path.time, len(path.labels)
    parts = [f"{n_segments} segment{'s' if n_segments != 1 else ''}"]
    if time.size == 1:  # one time selected (--sel t=10): the pose then
        parts = [f"the pose at t = {float(time[0]):g} s, in segment "
                 + ", ".join(f"{path.numbers[k]} ({path.labels[k]})" for k in range(n_segments)
                             if path.samples[k].size)]
    if "acceleration" in dataset:
        parts.append(f"a = {value_range_text(dataset['acceleration'].values)} m s$^{{-2}}$")
    if "path_length" in dataset and time.size > 1:
        length = dataset["path_length"].values  # from the start of the file's trajectory
        parts.append(f"path length {1e3 * float(length[-1] - length[0]):.1f} mm")
    if time.size > 1:
        parts.append(f"{float(time[-1] - time[0]):g} s")
    return "Steering the disk by the drive frequency (paper Fig. 4A): " + ", ".join(parts)


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the steered trajectory of a ``steering`` result into ``output.png/.pdf``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A trajectory scene: the pose over time ``t`` and the segments' labels, drive
        and outcome over ``segment``.
    output : pathlib.Path
        File stem.

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    return save(_plot(dataset), output, dataset,
                "Steering the disk: trajectory coloured by segment, heading against time")

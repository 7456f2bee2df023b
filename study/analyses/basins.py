"""Global continuation: each attractor of a basins map followed across the drive.

The ``basins`` observable reports, at every drive point, the attractors its starts reach,
numbered in the order the starts first reach them: slot 0 at one point and slot 0 at
the next need not be the same motion. :func:`follow_attractors` matches the attractors
of every pair of neighbouring drive points (grid neighbours along each drive axis) by
:func:`attractor_distance`, as an assignment with a cutoff
(:data:`MATCH_THRESHOLD`), and joins the matches over the whole grid (union-find), so
that each motion keeps one integer label across the map: it appears where it is born
and disappears where it dies, as Attractors.jl's global continuation does for smooth
systems (Datseris, Rossi & Wagemakers 2023, "Framework for global stability analysis of
dynamical systems", Chaos 33, 073151).

The distance (docs/theory/basins.md, "Following attractors across the map"): two
attractors of different status classes are never the same motion (a periodic orbit of
one period, of another, static, irregular, and each outcome outside the model are
classes of their own); within a class, the larger of the change of the velocity in the
drive's velocity scale ``a / (2 pi f)`` and of the largest hop in its displacement scale
``a / (2 pi f)^2``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from study.model.status import Status

__all__ = [
    "DRIVE_AXES",
    "MATCH_THRESHOLD",
    "attractor_distance",
    "class_name",
    "follow_attractors",
    "fraction_by_label",
    "status_class",
]

#: The drive axes along which neighbours are matched by default (those the dataset has).
DRIVE_AXES = ("f", "a")
#: Two attractors of one class at neighbouring drive points are the same motion when
#: their :func:`attractor_distance` is at most this [1]. Measured at M = 0.99 with
#: flight, 8 starts a point (docs/theory/basins.md): the largest change between grid
#: neighbours along a followed motion is 0.050 along f and 0.23 along a on a
#: 0.05 Hz x 0.1 m s-2 grid of 12-16 Hz x 8-13 m s-2, 0.36 on a 0.125 Hz x 0.25 m s-2
#: grid to 17 Hz, 0.45 between 10 and 12 m s-2; two coexisting motions of one class lie
#: at least 2.07 apart (0.90 in velocity alone). The threshold sits between, a factor
#: of about 2 from each (the number of labels is the same for any threshold from 0.5 to
#: 2 on these grids).
MATCH_THRESHOLD = 1.0
#: The outcomes outside the model (no velocity): each a class of its own.
_OUTSIDE = (Status.LIFT_OFF, Status.NOT_CONVERGED, Status.FRICTION_PARADOX)
_PERIODIC = (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING, Status.BOUNCING)
_IRREGULAR = (Status.CHAOTIC, Status.QUASI_PERIODIC)
#: The per-attractor variables :func:`follow_attractors` reads.
REQUIRED = ("basin_status", "basin_velocity", "basin_largest_hop", "basin_period",
            "basin_fraction")
#: The class code of an empty slot.
_EMPTY = -1


def status_class(status: NDArray, period: NDArray) -> NDArray[np.int64]:
    """The status class of each attractor, as an integer code.

    Periodic orbits (stick-slip, continuous sliding, bouncing: one family, since an orbit
    in contact continues into a bouncing one as its hops grow from 0) are one class per
    period, code ``100 + period``; static is 0; irregular motion (chaotic or
    quasi-periodic: the two can trade places between neighbours) is 1; each outcome
    outside the model (lift-off, not converged, friction paradox) is ``10 + status``; an
    empty slot (status -1) is -1.

    Parameters
    ----------
    status : array_like of int
        :class:`~study.model.status.Status` codes (-1: no attractor).
    period : array_like of int
        Orbit periods [drive periods] (used for the periodic statuses only).

    Returns
    -------
    numpy.ndarray of int64
        The class codes, the shape of ``status``.
    """
    status = np.asarray(status).astype(np.int64)
    period = np.nan_to_num(np.asarray(period, dtype=float)).astype(np.int64)
    code = np.full(status.shape, _EMPTY, dtype=np.int64)
    code = np.where(np.isin(status, [int(s) for s in _PERIODIC]), 100 + period, code)
    code = np.where(status == int(Status.STATIC), 0, code)
    code = np.where(np.isin(status, [int(s) for s in _IRREGULAR]), 1, code)
    for outside in _OUTSIDE:
        code = np.where(status == int(outside), 10 + int(outside), code)
    return code


def class_name(code: int) -> str:
    """A class code of :func:`status_class` in words (``"period 1"``, ``"static"``)."""
    code = int(code)
    if code >= 100:
        return f"period {code - 100}"
    if code == 0:
        return "static"
    if code == 1:
        return "irregular"
    if code >= 10:
        return Status(code - 10).flag.replace("_", " ")
    return "empty"


def _scaled(velocity, error, hop, f, a):
    """Velocity and its error in ``a / (2 pi f)``, hop in ``a / (2 pi f)^2`` [1]; 0 for
    what is NaN (no velocity, no hop) or where the drive vanishes."""
    omega = 2.0 * np.pi * np.asarray(f, dtype=float)
    a = np.asarray(a, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        v = np.where(a > 0, velocity * omega / a, 0.0)
        e = np.where(a > 0, error * omega / a, 0.0)
        h = np.where(a > 0, hop * omega * omega / a, 0.0)
    return np.nan_to_num(v), np.nan_to_num(e), np.nan_to_num(h)


def attractor_distance(first: dict, second: dict) -> NDArray[np.float64]:
    """Distance between the attractors of two neighbouring drive points [1].

    Attractors of different status classes (:func:`status_class`) are infinitely far
    apart (never the same motion), as is an empty slot from anything. Within a class the
    distance is the larger of

    * the change of velocity in the velocity scale ``a / (2 pi f)`` of each point,
      less twice the combined standard error of the two (irregular motion's velocity is
      a time average; an orbit's is exact), and not below 0;
    * the change of the largest hop in the displacement scale ``a / (2 pi f)^2`` of each
      point (the table's displacement amplitude; 0 for motions in contact).

    Static motions and each outcome outside the model carry no velocity: two of the same
    class are at distance 0.

    Parameters
    ----------
    first, second : dict
        The attractors of each point: arrays ``class`` (:func:`status_class`),
        ``velocity`` [m s-1], ``velocity_error`` [m s-1], ``largest_hop`` [m] with the
        attractor axis last, and the drive ``f`` [Hz] and ``a`` [m s-2] of the point
        (broadcast against the leading axes).

    Returns
    -------
    numpy.ndarray
        ``d[..., i, j]``: the distance between attractor ``i`` of the first point and
        ``j`` of the second [1].
    """
    scaled = []
    for side in (first, second):
        f = np.asarray(side["f"], dtype=float)[..., None]
        a = np.asarray(side["a"], dtype=float)[..., None]
        scaled.append(_scaled(side["velocity"], side["velocity_error"],
                              side["largest_hop"], f, a))
    (v1, e1, h1), (v2, e2, h2) = scaled
    dv = np.abs(v1[..., :, None] - v2[..., None, :])
    dv = np.maximum(dv - 2.0 * np.hypot(e1[..., :, None], e2[..., None, :]), 0.0)
    dh = np.abs(h1[..., :, None] - h2[..., None, :])
    c1 = np.asarray(first["class"])[..., :, None]
    c2 = np.asarray(second["class"])[..., None, :]
    same = (c1 == c2) & (c1 != _EMPTY)
    return np.where(same, np.maximum(dv, dh), np.inf)


class _Labels:
    """Union-find over the attractor slots that never joins two slots of one point."""

    def __init__(self, points: NDArray[np.int64]):
        self.parent = np.arange(points.size)
        self.points = [{int(p)} for p in points]

    def root(self, node: int) -> int:
        parent = self.parent
        while parent[node] != node:
            parent[node] = parent[parent[node]]
            node = int(parent[node])
        return node

    def join(self, one: int, two: int) -> bool:
        """Join the motions of two slots, unless that puts two slots of one point under
        one label; returns whether they are (now) one."""
        one, two = self.root(one), self.root(two)
        if one == two:
            return True
        if len(self.points[one]) < len(self.points[two]):
            one, two = two, one
        if not self.points[one].isdisjoint(self.points[two]):
            return False
        self.parent[two] = one
        self.points[one] |= self.points[two]
        self.points[two] = set()
        return True


@dataclass(frozen=True)
class _Flat:
    """The basins variables as ``(point, attractor)`` arrays, and the grid's shape."""

    shape: tuple[int, ...]
    dims: tuple[str, ...]
    klass: NDArray[np.int64]
    velocity: NDArray[np.float64]
    error: NDArray[np.float64]
    hop: NDArray[np.float64]
    f: NDArray[np.float64]
    a: NDArray[np.float64]


def _flat(dataset: xr.Dataset) -> _Flat:
    status = dataset["basin_status"]
    dims = tuple(d for d in status.dims if d != "attractor")
    order = (*dims, "attractor")

    width = status.sizes["attractor"]

    def values(name, fill=np.nan):
        if name not in dataset:
            return np.full((status.size // max(width, 1), width), fill)
        return dataset[name].transpose(*order).values.reshape(-1, width)

    status_values = status.transpose(*order).values.reshape(-1, width)
    klass = status_class(status_values, values("basin_period", 0))
    drive = {}
    grid = status.isel(attractor=0, drop=True)
    for axis in ("f", "a"):
        if axis not in dataset.coords:
            raise ValueError(f"follow_attractors: the dataset has no drive coordinate "
                             f"{axis!r}")
        on_grid = dataset[axis].reset_coords(drop=True).broadcast_like(grid)
        drive[axis] = on_grid.transpose(*dims).values.ravel()
    error = values("basin_velocity_error", 0.0)
    return _Flat(shape=tuple(status.sizes[d] for d in dims), dims=dims, klass=klass,
                 velocity=values("basin_velocity"), error=np.nan_to_num(error),
                 hop=np.nan_to_num(values("basin_largest_hop", 0.0)),
                 f=drive["f"], a=drive["a"])


def _neighbour_matches(flat: _Flat, along: tuple[str, ...], threshold: float):
    """Every accepted match between neighbouring points: ``(distance, node, node)``
    with a node ``point * width + slot``; each pair of neighbours matched as an
    assignment of least total distance among the pairs within ``threshold``."""
    width = flat.klass.shape[1]
    index = np.arange(int(np.prod(flat.shape, dtype=np.int64))).reshape(flat.shape)
    edges = []
    for axis in along:
        position = flat.dims.index(axis)
        if flat.shape[position] < 2:
            continue
        lower = np.take(index, np.arange(flat.shape[position] - 1), axis=position).ravel()
        upper = np.take(index, np.arange(1, flat.shape[position]), axis=position).ravel()

        def side(points):
            return {"class": flat.klass[points], "velocity": flat.velocity[points],
                    "velocity_error": flat.error[points], "largest_hop": flat.hop[points],
                    "f": flat.f[points], "a": flat.a[points]}

        distance = attractor_distance(side(lower), side(upper))
        for pair in np.flatnonzero(np.any(distance <= threshold, axis=(1, 2))):
            d = distance[pair]
            cost = np.where(d <= threshold, d, 1e6 * (1.0 + threshold))
            rows, cols = linear_sum_assignment(cost)
            for i, j in zip(rows, cols, strict=True):
                if d[i, j] <= threshold:
                    edges.append((float(d[i, j]), int(lower[pair]) * width + int(i),
                                  int(upper[pair]) * width + int(j)))
    edges.sort()
    return edges


def follow_attractors(dataset: xr.Dataset, *, along: tuple[str, ...] | None = None,
                      threshold: float = MATCH_THRESHOLD) -> tuple[xr.Dataset, xr.Dataset]:
    """Label each attractor of a basins map so that one motion keeps one label.

    Between every two neighbouring drive points (grid neighbours along each axis of
    ``along``) the attractors are matched as an assignment: the pairing of least total
    :func:`attractor_distance` (``scipy.optimize.linear_sum_assignment``) among pairs at
    most ``threshold`` apart; a pair further apart is not matched. The matches are then
    joined over the grid by union-find, nearest first, never joining two attractors of
    one point (where a path around the grid would, as around a cusp, the farther match
    is dropped): each connected set of matched attractors is one label. A motion that is
    not matched to anything at a neighbour is born or dies between the two points.

    Parameters
    ----------
    dataset : xarray.Dataset
        A basins map: ``basin_status`` (-1: empty slot), ``basin_velocity`` [m s-1],
        ``basin_largest_hop`` [m], ``basin_period`` [drive periods] and
        ``basin_fraction`` [1] over the drive dimensions and ``attractor``;
        ``basin_velocity_error`` [m s-1] if present; coordinates ``f`` [Hz] and ``a``
        [m s-2] (dimensions or scalars). Further dimensions (a structure parameter
        swept) are separate maps unless named in ``along``.
    along : tuple of str, optional
        The dimensions along which neighbours are matched; by default those of
        :data:`DRIVE_AXES` the dataset has as dimensions.
    threshold : float, default :data:`MATCH_THRESHOLD`
        The largest distance of a match [1], > 0.

    Returns
    -------
    labelled : xarray.Dataset
        ``dataset`` with ``attractor_label`` (int32, the dimensions of ``basin_status``;
        -1 in an empty slot). Labels are numbered 0, 1, ... by the number of points they
        hold, most first (ties: the first point in the grid's order).
    summary : xarray.Dataset
        Over dimension ``label``: ``status_class`` (str: ``"period 1"``, ``"static"``,
        ``"irregular"``, ``"lift off"``, ...), ``period`` [drive periods] (0 unless
        periodic), ``points`` [1], ``velocity_min`` and ``velocity_max`` [m s-1],
        ``largest_hop_max`` [m], ``fraction_min`` and ``fraction_max`` [1]; and for each
        axis ``X`` of ``along``, over ``label`` and the dataset's other dimensions,
        ``first_X`` and ``last_X`` (the first and last value of ``X`` at which the label
        is present on that line, NaN where it is absent from the line), ``birth_X`` and
        ``death_X`` (the same, but NaN where that is the grid's edge: a birth or death
        inside the map lies between that grid value and the one before, or after). The
        summary is a separate dataset because its ``label`` dimension is not one of the
        map's: the map's variables keep their dimensions and a file written from it is
        a map as before.

    Raises
    ------
    ValueError
        A variable missing, ``along`` naming no dimension of the map, or a threshold
        not > 0.
    """
    missing = [name for name in REQUIRED if name not in dataset]
    if missing:
        raise ValueError(f"follow_attractors: the dataset lacks {', '.join(missing)} "
                         "(the basins observable's variables)")
    if not np.isfinite(threshold) or threshold <= 0:
        raise ValueError(f"follow_attractors: 'threshold' must be finite and > 0, got "
                         f"{threshold!r}")
    status = dataset["basin_status"]
    if "attractor" not in status.dims:
        raise ValueError("follow_attractors: basin_status has no 'attractor' dimension")
    dims = tuple(d for d in status.dims if d != "attractor")
    if along is None:
        along = tuple(d for d in DRIVE_AXES if d in dims)
    along = tuple(along)
    unknown = [d for d in along if d not in dims]
    if unknown:
        raise ValueError(f"follow_attractors: 'along' names {', '.join(unknown)}, not "
                         f"dimensions of the map ({', '.join(dims)})")
    flat = _flat(dataset)
    width = flat.klass.shape[1]
    nodes = flat.klass.size
    labels = _Labels(np.repeat(np.arange(flat.klass.shape[0]), width))
    for _, one, two in _neighbour_matches(flat, along, threshold):
        labels.join(one, two)
    present = (flat.klass != _EMPTY).ravel()
    roots = np.array([labels.root(n) for n in range(nodes)])
    roots = np.where(present, roots, -1)
    kept = roots[present]
    unique, first, counts = np.unique(kept, return_index=True, return_counts=True)
    order = np.lexsort((first, -counts))  # most points first, then first in the grid
    number = np.full(nodes, -1, dtype=np.int32)
    renumber = dict(zip(unique[order].tolist(), range(unique.size), strict=True))
    number[present] = [renumber[r] for r in kept.tolist()]
    label = number.reshape(*flat.shape, width)
    labelled = dataset.assign(attractor_label=((*dims, "attractor"), label, {
        "long_name": "label of the attractor, the same motion across the map",
        "units": "1",
        "comment": "-1: no attractor in this slot; study.analyses.basins."
                   "follow_attractors, threshold " + f"{threshold:g}"}))
    labelled["attractor_label"] = labelled["attractor_label"].transpose(*status.dims)
    return labelled, _summary(labelled, flat, label, unique.size, along, dims)


def fraction_by_label(labelled: xr.Dataset) -> xr.DataArray:
    """The basin fraction of each label at each drive point [1] (NaN where absent).

    Parameters
    ----------
    labelled : xarray.Dataset
        The first result of :func:`follow_attractors`.

    Returns
    -------
    xarray.DataArray
        Over ``label`` and the map's dimensions.
    """
    label = labelled["attractor_label"]
    count = int(label.max()) + 1 if label.size else 0
    labels = xr.DataArray(np.arange(count), dims="label", name="label")
    fraction = labelled["basin_fraction"].where(label == labels).max("attractor")
    return fraction.rename("fraction").assign_attrs(
        long_name="basin fraction of the labelled attractor", units="1")


def _summary(labelled, flat, label, count, along, dims):
    """The per-label summary of :func:`follow_attractors`."""
    flat_label = label.reshape(-1, label.shape[-1])
    klass = np.zeros(count, dtype=np.int64)
    points = np.zeros(count, dtype=np.int64)
    fraction = labelled["basin_fraction"].transpose(*dims, "attractor").values.reshape(
        flat_label.shape)
    velocity = flat.velocity
    stats = {k: np.full(count, np.nan) for k in ("velocity_min", "velocity_max",
                                                 "largest_hop_max", "fraction_min",
                                                 "fraction_max")}
    for n in range(count):
        rows, slots = np.nonzero(flat_label == n)
        klass[n] = flat.klass[rows[0], slots[0]]
        points[n] = rows.size
        v = velocity[rows, slots]
        if np.any(np.isfinite(v)):
            stats["velocity_min"][n], stats["velocity_max"][n] = np.nanmin(v), np.nanmax(v)
        stats["largest_hop_max"][n] = np.max(flat.hop[rows, slots])
        stats["fraction_min"][n] = np.min(fraction[rows, slots])
        stats["fraction_max"][n] = np.max(fraction[rows, slots])
    units = {"velocity_min": "m s-1", "velocity_max": "m s-1", "largest_hop_max": "m",
             "fraction_min": "1", "fraction_max": "1"}
    summary = xr.Dataset(
        {"status_class": ("label", np.array([class_name(c) for c in klass], dtype=object)),
         "period": ("label", np.where(klass >= 100, klass - 100, 0).astype(np.int32)),
         "points": ("label", points.astype(np.int32)),
         **{k: ("label", v, {"units": units[k]}) for k, v in stats.items()}},
        coords={"label": np.arange(count)})
    presence = fraction_by_label(labelled).notnull()
    for axis in along:
        values = labelled[axis].broadcast_like(presence)
        first = values.where(presence).min(axis)
        last = values.where(presence).max(axis)
        edge_low, edge_high = labelled[axis].values.min(), labelled[axis].values.max()
        summary[f"first_{axis}"] = first
        summary[f"last_{axis}"] = last
        summary[f"birth_{axis}"] = first.where(first > edge_low)
        summary[f"death_{axis}"] = last.where(last < edge_high)
        for kind in ("first", "last", "birth", "death"):
            summary[f"{kind}_{axis}"].attrs = {
                "units": labelled[axis].attrs.get("units", ""),
                "long_name": f"{kind} {axis} at which the label is present on each line"
                + (" inside the map (NaN: at its edge)" if kind in ("birth", "death")
                   else "")}
    return summary

"""Where the forward and backward hops end and coexist, from slow sweeps both ways.

Near ``M = 1`` a structure with flight has, at one drive, a small hop that walks forward
and a big one that walks backward. Swept slowly up in frequency it rides the forward
hop until that hop's fold, where it jumps onto the backward one; swept down it rides
the backward hop until its own fold. The ``jumps`` observable locates each jump at its
bifurcation exactly (:mod:`study.solvers.jumps`). :func:`hop_folds` reads, at each
acceleration of such a study, the two folds of reversal (the first jump swept up from a
forward to a backward motion, the first swept down from a backward to a forward one)
and the band of frequencies between them where both hops exist.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from study.model.bifurcations import JUMP_NONE, JUMP_UNLOCATED
from study.model.units import DIMENSIONLESS, HERTZ, METRE_PER_SECOND
from study.solvers.protocol import reversal_jumps

__all__ = ["EDGES", "hop_folds"]

#: What bounds the band where both hops exist, on either side (``coexistence_low_edge``
#: and ``coexistence_high_edge``): a located fold, a jump between two grid points not
#: located at a bifurcation (the grid point before it), the grid's end, the last grid
#: point of the band where neither sweep reverses next to it, or nothing (the hops do not
#: coexist at that acceleration).
EDGES = ("none", "fold", "unlocated_jump", "grid_end", "grid_point")


def hop_folds(dataset: xr.Dataset) -> xr.Dataset:
    """The reversal folds of the forward and backward hops and where both exist.

    Parameters
    ----------
    dataset : xarray.Dataset
        A study swept slowly along ``f`` both ways (``[sweep] protocol = { along = "f",
        direction = "both" }``) with the ``jumps`` observable: ``velocity``,
        ``jump_bifurcation``, ``jump_f`` and ``jump_velocity`` over ``(direction, ...,
        f, a)``, ``f`` ascending.

    Returns
    -------
    xarray.Dataset
        Over the dataset's dimensions but ``direction`` and ``f``:
        ``forward_fold_f`` [Hz] and ``forward_fold_velocity`` [m s-1], the fold where
        the sweep up leaves a forward motion for a backward one (NaN where it does not,
        or where that jump is not at a located bifurcation); ``backward_fold_f`` and
        ``backward_fold_velocity``, the same swept down from a backward motion to a
        forward one; ``coexistence_low`` and ``coexistence_high`` [Hz], the band where
        the sweep up moves forward and the sweep down backward at once (NaN where they
        never do), each end the located fold, else the last grid point of the band
        (``coexistence_low_edge``, ``coexistence_high_edge``: :data:`EDGES`);
        ``coexistence_width`` [Hz].

    Raises
    ------
    ValueError
        A dataset that is not swept along ``f`` both ways, or lacks the ``jumps``
        observable's variables (the message names what it lacks).
    """
    missing = [name for name in ("velocity", "jump_bifurcation", "jump_f", "jump_velocity")
               if name not in dataset]
    if missing:
        raise ValueError(f"hop_folds needs a slow sweep with the jumps observable: the "
                         f"dataset lacks {', '.join(missing)} (a study with [sweep] "
                         'protocol and observables = [..., "jumps"])')
    if dataset.attrs.get("study_protocol_along", "f") != "f":
        raise ValueError("hop_folds needs a slow sweep along f; this study is swept along "
                         f"{dataset.attrs.get('study_protocol_along')!r}")
    if "direction" not in dataset.dims or set(dataset["direction"].values) != {"up", "down"}:
        raise ValueError("hop_folds needs a slow sweep both ways ([sweep] protocol "
                         'direction = "both"), which needs several values of direction '
                         "(up and down)")
    f = dataset["f"].values
    if f.size < 2 or np.any(np.diff(f) <= 0):
        raise ValueError("hop_folds follows the sweeps along f, which needs several "
                         "values of f (at least 2, ascending)")
    names = ("velocity", "jump_bifurcation", "jump_f", "jump_velocity")
    up = {n: dataset[n].sel(direction="up").transpose(..., "f") for n in names}
    down = {n: dataset[n].sel(direction="down").transpose(..., "f") for n in names}
    template = up["velocity"].isel(f=0, drop=True)
    shape = template.shape
    found = {n: np.full(shape, np.nan) for n in (
        "forward_fold_f", "forward_fold_velocity", "backward_fold_f",
        "backward_fold_velocity", "coexistence_low", "coexistence_high")}
    low_edge = np.zeros(shape, dtype=np.int8)
    high_edge = np.zeros(shape, dtype=np.int8)
    arrays_up = {n: up[n].values for n in names}
    arrays_down = {n: down[n].values for n in names}
    for index in np.ndindex(shape):
        forward = _reversal(f, {n: v[index] for n, v in arrays_up.items()}, +1)
        backward = _reversal(f, {n: v[index] for n, v in arrays_down.items()}, -1)
        found["forward_fold_f"][index], found["forward_fold_velocity"][index] = forward[:2]
        found["backward_fold_f"][index], found["backward_fold_velocity"][index] = backward[:2]
        both = np.flatnonzero((arrays_up["velocity"][index] > 0.0)
                              & (arrays_down["velocity"][index] < 0.0))
        if both.size == 0:
            if forward[0] > backward[0]:
                # Both folds between the same two grid points: a band narrower than a
                # step, bounded by the two located folds.
                found["coexistence_low"][index], found["coexistence_high"][index] = (
                    backward[0], forward[0])
                low_edge[index] = high_edge[index] = EDGES.index("fold")
            continue
        first, last = int(both[0]), int(both[-1])
        # The band's ends: the folds where the sweeps leave their hops, when they lie
        # next to its grid points; the grid's points themselves otherwise.
        found["coexistence_low"][index], low_edge[index] = _edge(
            f, first, backward, first == 0, below=True)
        found["coexistence_high"][index], high_edge[index] = _edge(
            f, last, forward, last == f.size - 1, below=False)
    dims = template.dims
    coords = {name: coord for name, coord in template.coords.items()
              if set(coord.dims) <= set(dims)}
    flag = {"units": DIMENSIONLESS, "flag_values": np.arange(len(EDGES), dtype=np.int8),
            "flag_meanings": " ".join(EDGES)}
    out = xr.Dataset(
        {
            "forward_fold_f": (dims, found["forward_fold_f"], {
                "units": HERTZ, "long_name": "drive frequency of the forward hop's fold "
                "where a sweep up jumps onto a backward motion"}),
            "forward_fold_velocity": (dims, found["forward_fold_velocity"], {
                "units": METRE_PER_SECOND, "long_name": "mean velocity of the forward hop "
                "at its fold"}),
            "backward_fold_f": (dims, found["backward_fold_f"], {
                "units": HERTZ, "long_name": "drive frequency of the backward hop's fold "
                "where a sweep down jumps onto a forward motion"}),
            "backward_fold_velocity": (dims, found["backward_fold_velocity"], {
                "units": METRE_PER_SECOND, "long_name": "mean velocity of the backward "
                "hop at its fold"}),
            "coexistence_low": (dims, found["coexistence_low"], {
                "units": HERTZ, "long_name": "lowest drive frequency where the forward "
                "and backward hops both exist"}),
            "coexistence_high": (dims, found["coexistence_high"], {
                "units": HERTZ, "long_name": "highest drive frequency where the forward "
                "and backward hops both exist"}),
            "coexistence_low_edge": (dims, low_edge, {**flag, "long_name": "what bounds "
                                                      "the band below"}),
            "coexistence_high_edge": (dims, high_edge, {**flag, "long_name": "what bounds "
                                                        "the band above"}),
        },
        coords=coords,
    )
    out["coexistence_width"] = (out["coexistence_high"] - out["coexistence_low"]).assign_attrs(
        units=HERTZ, long_name="width in drive frequency of the band where both hops exist")
    return out


def _reversal(f: np.ndarray, sweep: dict[str, np.ndarray], sign: int
              ) -> tuple[float, float, int]:
    """``(f, velocity, index)`` of the first jump of a sweep that reverses the motion
    (``sign`` +1: up, from a forward to a backward motion; -1: down, from backward to
    forward: :func:`study.solvers.protocol.reversal_jumps`): the located
    bifurcation's drive and velocity (NaN, NaN where the jump is not located), and the
    jumped point's index (-1, with NaNs, where there is none)."""
    velocity = sweep["velocity"]
    jumped = sweep["jump_bifurcation"] != JUMP_NONE
    reversals = reversal_jumps(f, velocity, jumped, "up" if sign > 0 else "down")
    if reversals.size == 0:
        return np.nan, np.nan, -1
    i = int(reversals[0])
    if sweep["jump_bifurcation"][i] == JUMP_UNLOCATED:
        return np.nan, np.nan, i
    return float(sweep["jump_f"][i]), float(sweep["jump_velocity"][i]), i


def _edge(f: np.ndarray, end: int, fold: tuple[float, float, int], at_grid_end: bool,
          *, below: bool) -> tuple[float, int]:
    """One end of the band of grid points ``end``: the fold's drive where the fold's
    jump leaves the band right there (the jumped point the next grid point past it),
    else the grid point, flagged by :data:`EDGES`."""
    where, _, jumped = fold
    neighbour = end - 1 if below else end + 1
    if jumped >= 0 and jumped == neighbour:
        if np.isfinite(where):
            return where, EDGES.index("fold")
        return float(f[end]), EDGES.index("unlocated_jump")
    if at_grid_end:
        return float(f[end]), EDGES.index("grid_end")
    # The band ends at a grid point without a reversal of either sweep next to it (a
    # hop changes there some other way): its grid point.
    return float(f[end]), EDGES.index("grid_point")

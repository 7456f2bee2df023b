"""Basins: every motion a drive point holds, and the share of starts that reach each.

Near M = 1, and wherever the structure bounces, one drive can hold several stable
motions; which one a structure performs then depends on how it was put down. At each
drive point :func:`basins` follows the motion from each of ``starts`` seeded starts
(:func:`basin_starts`) to the attractor it reaches, verified as every start is
(docs/theory/starts.md), groups the outcomes into attractors and reports each one's
motion and its basin fraction: the share of the starts that reach it, with its 95 %
binomial (Wilson) interval. Start 0 is the solver's start (the release by default), so
the attractor it reaches is the one :func:`study.solvers.exact.steady_state` reports.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels.two_way import basins as basin_kernel
from study.model.structure import Structure, check_structure
from study.solvers.settings import (
    SolverSettings,
    check_coupling,
    check_flight,
    check_settings,
    check_start,
    flat_drive,
    kernel_budget,
    kernel_start,
)
from study.solvers.structure_constants import past_lift_off, structure_vector

#: Starts at each drive point by default.
DEFAULT_STARTS = 24
#: The confidence of the basin fractions' intervals, and its normal quantile.
CONFIDENCE = 0.95
_Z = 1.959963984540054
#: With flight, every third start (of those after the first) is a drop from a height
#: drawn log-uniformly between these [m].
DROP_HEIGHT_RANGE = (1e-4, 5e-3)
#: The mode starts at rest on a multiple of its steady stick response drawn uniformly
#: from this range [1].
FACTOR_RANGE = (0.0, 2.0)
#: The status of an attractor slot that holds none (a point with fewer attractors).
NO_ATTRACTOR = -1
#: The coarse slow sweeps whose end states seed each point (:func:`sweep_seeds`): the
#: swept axis and where the sweep begins, as a multiple of the point's value of that
#: axis [1]: down along ``f`` from 1.5 times the point's frequency. Measured on the
#: M = 0.9 line and the basins-flight grid (docs/theory/basins.md): a sweep up along
#: ``f`` from 0.5 or 0.75 f found no motion more (the drawn starts at rest reach what it
#: carries) and cost 1.5-2.7x the 24 starts; down along ``a`` from 2 a found nothing
#: more and cost 70x the sweep down along ``f`` (strong drives are irregular motions,
#: averaged to their budget).
SEED_PATHS = (("f", 1.5),)
#: Steps of each seeding sweep from its first drive to the point's [1].
SEED_STEPS = 8


@dataclass(frozen=True)
class BasinStarts:
    """The starts of :func:`basins`, the same at every drive point.

    Attributes
    ----------
    phase : numpy.ndarray
        Drive phase of each start [periods], in [0, 1).
    factor : numpy.ndarray
        The mode starts at rest on this multiple of its steady stick response at that
        phase [1].
    height : numpy.ndarray
        The base starts at rest this high above the table [m] (0: on it).
    """

    phase: NDArray[np.float64]
    factor: NDArray[np.float64]
    height: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.phase.size)


def basin_starts(starts: int = DEFAULT_STARTS, *, seed: int = 0, flight: bool = False,
                 first: tuple[float, float, float] = (0.0, 1.0, 0.0)) -> BasinStarts:
    """The ``starts`` starts of :func:`basins`: ``first`` (phase, factor, height; the
    solver's start, by default the release), then seeded draws.

    Each drawn start holds the base at rest at a drive phase drawn uniformly from
    [0, 1) periods, the mode at rest on a multiple of its steady stick response at that
    phase drawn uniformly from :data:`FACTOR_RANGE`; on the table, or, with ``flight``,
    for every third draw, above it at a height drawn log-uniformly from
    :data:`DROP_HEIGHT_RANGE`. The draws come from ``numpy.random.default_rng(seed)``,
    so the same ``(starts, seed, flight)`` give the same starts on every machine.

    Raises
    ------
    ValueError
        ``starts`` not an integer >= 1, or ``seed`` not an integer >= 0.
    """
    if isinstance(starts, bool) or not isinstance(starts, (int, np.integer)) or starts < 1:
        raise ValueError(f"basins: 'starts' must be an integer >= 1, got {starts!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"basins: 'seed' must be an integer >= 0, got {seed!r}")
    rng = np.random.default_rng(int(seed))
    drawn = int(starts) - 1
    phase = rng.uniform(0.0, 1.0, drawn)
    factor = rng.uniform(*FACTOR_RANGE, drawn)
    low, high = np.log(DROP_HEIGHT_RANGE)
    heights = np.exp(rng.uniform(low, high, drawn))
    height = np.where((np.arange(drawn) % 3 == 2) & bool(flight), heights, 0.0)
    return BasinStarts(phase=np.concatenate([[first[0]], phase]),
                       factor=np.concatenate([[first[1]], factor]),
                       height=np.concatenate([[first[2]], height]))


def sampling_reach(flight: bool, sweep_steps: int = SEED_STEPS) -> str:
    """What the starts of :func:`basins` reach, in words (a result file's
    ``study_basins_reach``): the ranges of the drawn starts and the seeded states, and
    what a fraction's interval is an interval of."""
    low, high = FACTOR_RANGE
    drawn = (f"drawn starts: the base at rest on the table at a drive phase drawn "
             f"uniformly from [0, 1) periods, the mode at rest on {low:g} to {high:g} times "
             "its steady stick response")
    if flight:
        drawn += (f"; every third one dropped at rest from {1e3 * DROP_HEIGHT_RANGE[0]:g} to "
                  f"{1e3 * DROP_HEIGHT_RANGE[1]:g} mm (log-uniform)")
    if sweep_steps > 0:
        seeded = (f"seeded: the state a slow sweep down along f, from {SEED_PATHS[0][1]:g} f "
                  f"(the release there) in {sweep_steps} steps, settles on at the point, "
                  "counted among the attractors, not in the fractions")
    else:
        seeded = "no seeded state"
    return (f"{drawn}; {seeded}. A motion none of these reaches is not found; a fraction "
            "and its 95 % Wilson interval are over the drawn starts, not over the state "
            "space")


def wilson_interval(successes: ArrayLike, trials: ArrayLike) -> tuple[NDArray[np.float64],
                                                                       NDArray[np.float64]]:
    """The :data:`CONFIDENCE` Wilson score interval ``(low, high)`` of a binomial
    proportion ``successes / trials`` (NaN where ``trials`` is 0)."""
    k = np.asarray(successes, dtype=float)
    n = np.asarray(trials, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        p = k / n
        z2 = _Z * _Z
        centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n)
        half = _Z * np.sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n)) / (1.0 + z2 / n)
    # Rounding can put an end a few ulps inside p itself (at p = 0 or 1): the interval
    # always holds the estimate.
    return (np.clip(np.fmin(centre - half, p), 0.0, 1.0),
            np.clip(np.fmax(centre + half, p), 0.0, 1.0))


def _checked_starts(starts: BasinStarts, flight: bool) -> BasinStarts:
    """Given starts as float64 arrays, checked: one length, at least one, phases in
    [0, 1), factors finite, heights finite and >= 0 (> 0 only with flight)."""
    phase, factor, height = (np.ascontiguousarray(np.asarray(x, dtype=np.float64).ravel())
                             for x in (starts.phase, starts.factor, starts.height))
    if not phase.size or not phase.size == factor.size == height.size:
        raise ValueError("basins: the starts' phase, factor and height must be 1-D arrays "
                         f"of one length >= 1, got {phase.size}, {factor.size} and "
                         f"{height.size}")
    if not np.all((phase >= 0.0) & (phase < 1.0)):
        raise ValueError("basins: a start's phase must be in [0, 1) periods")
    if not np.all(np.isfinite(factor)):
        raise ValueError("basins: a start's factor must be finite")
    if not np.all(np.isfinite(height) & (height >= 0.0)):
        raise ValueError("basins: a start's height must be finite and >= 0 [m]")
    if np.any(height > 0.0) and not flight:
        raise ValueError("basins: a start above the table (height > 0) needs flight=True")
    return BasinStarts(phase=phase, factor=factor, height=height)


def sweep_seeds(structure: Structure, f: ArrayLike, a: ArrayLike, *, flight: bool = False,
                settings: SolverSettings | None = None, parallel: bool | None = None,
                steps: int = SEED_STEPS) -> NDArray[np.float64]:
    """The states that slow sweeps ending at each drive point settle on there: the seeded
    states of :func:`basins`.

    For each point and each path of :data:`SEED_PATHS` a coarse slow sweep of ``steps``
    steps (equal in the swept value) runs from the path's first drive (the release
    there) to the point, the state carried from step to step as
    :func:`study.solvers.protocol.slow_sweep` carries it, each motion followed to its
    verified reach; the state at phase 0 of the motion it settles on at the point is
    that path's seed. A sweep down from above reaches the motions born at stronger or
    faster drives (a big backward hop that no start at rest, drop or ringing plate of
    :func:`basin_starts` reaches), one up from below those born at weaker ones. A
    point's seeds depend on its own drive alone (never on a neighbour of a grid), so a
    map's values do not depend on how its points are grouped.

    Returns
    -------
    numpy.ndarray
        Shape ``(*shape, len(SEED_PATHS), 5)``: ``(delta [m], delta' [m s-1], v [m s-1],
        h [m], h' [m s-1])`` at phase 0; NaN where the path has no state at the point
        (outside the model, not converged) or no extent (along ``a`` at ``a = 0``).
    """
    structure = check_structure(structure)
    coupling = check_coupling("two-way")
    flight = check_flight(flight, coupling, structure)
    settings = check_settings(settings, coupling)
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"basins: 'steps' of the seeding sweeps must be an integer >= 1, "
                         f"got {steps!r}")
    shape, f_flat, a_flat = flat_drive(f, a)
    n, paths = f_flat.size, len(SEED_PATHS)
    fraction = np.arange(steps + 1) / steps
    path_f = np.empty((n, paths, steps + 1))
    path_a = np.empty((n, paths, steps + 1))
    for p, (axis, begin) in enumerate(SEED_PATHS):
        ramp = begin + (1.0 - begin) * fraction
        path_f[:, p] = f_flat[:, None] * (ramp if axis == "f" else 1.0)
        path_a[:, p] = a_flat[:, None] * (ramp if axis == "a" else 1.0)
        path_f[:, p, -1] = f_flat  # the point itself, to the bit
        path_a[:, p, -1] = a_flat
    flat_f = np.ascontiguousarray(path_f.ravel())
    flat_a = np.ascontiguousarray(path_a.ravel())
    bounds = np.arange(0, flat_f.size + 1, steps + 1, dtype=np.int64)
    states = np.empty((n * paths, 5))
    if parallel is None:
        parallel = n >= 16
    kernel = basin_kernel.seed_paths if parallel else basin_kernel.seed_paths_serial
    kernel(structure_vector(structure, coupling, flight), 2.0 * np.pi * flat_f, flat_a,
           past_lift_off(structure, flat_f, flat_a), kernel_budget(settings), bounds,
           states)
    states = states.reshape(n, paths, 5)
    for p, (axis, _) in enumerate(SEED_PATHS):
        if axis == "a":
            states[a_flat == 0.0, p] = np.nan
    return states.reshape(*shape, paths, 5)


def _checked_seeds(seeds: object, shape: tuple[int, ...], flight: bool
                   ) -> NDArray[np.float64]:
    """``basins``' seeded states as a C-contiguous ``(points, m, 5)`` float64 array
    (``m = 0`` for None), checked: the drive's shape, 5 components, finite or NaN rows,
    off the table only with flight."""
    n = int(np.prod(shape, dtype=np.int64))
    if seeds is None:
        return np.empty((n, 0, 5))
    if isinstance(seeds, str):
        raise ValueError(f"basins: 'seeds' must be \"sweeps\", an array of states or "
                         f"None, got {seeds!r}")
    array = np.asarray(seeds, dtype=np.float64)
    if array.ndim < 2 or array.shape[-1] != 5 or array.shape[:-2] != tuple(shape):
        raise ValueError(f"basins: 'seeds' must have shape (*{tuple(shape)}, m, 5), got "
                         f"{array.shape}")
    array = np.ascontiguousarray(array.reshape(n, array.shape[-2], 5))
    bad = ~np.isfinite(array) & ~np.isnan(array)
    if bad.any():
        raise ValueError("basins: a seeded state must be finite (NaN: none)")
    if not flight and np.any(np.nan_to_num(array[..., 3:]) != 0.0):
        raise ValueError("basins: a seeded state off the table (h or h' not 0) needs "
                         "flight=True")
    return array


@dataclass(frozen=True)
class Basins:
    """The attractors at each drive point and their basin fractions.

    Per-attractor fields have the drive's shape plus a last ``attractor`` axis, as long
    as the most attractors any point holds; attractors are numbered at each point in
    the order the starts first reach them (start 0 reaches attractor 0), and a slot a
    point does not fill has ``status`` :data:`NO_ATTRACTOR`, NaN values and fraction 0.

    Attributes
    ----------
    status : numpy.ndarray of int8
        :class:`~study.model.status.Status` code of each attractor; an outcome outside
        the model (lift-off without flight, the friction paradox, not converged) is one
        entry, so that the fractions add up to 1.
    velocity : numpy.ndarray
        Mean velocity on the attractor [m s-1].
    velocity_error : numpy.ndarray
        Its standard error [m s-1] (0 for an orbit's, exact).
    largest_hop : numpy.ndarray
        Largest height of the base above the table over the motion [m].
    orbit_period : numpy.ndarray of int32
        An orbit's period in drive periods [1] (0: static or irregular).
    floquet_multiplier : numpy.ndarray
        An orbit's largest Floquet multiplier modulus [1].
    lyapunov_exponent : numpy.ndarray
        Largest Lyapunov exponent per drive period [1].
    fraction : numpy.ndarray
        Basin fraction [1]: the share of the drawn starts that reach the attractor
        (the seeded states are not draws and do not enter it).
    fraction_low, fraction_high : numpy.ndarray
        Its :data:`CONFIDENCE` Wilson interval [1]: an interval over the drawn starts,
        for the chance that a start drawn as they are reaches the attractor; it says
        nothing of the states the draws never reach.
    seeded : numpy.ndarray of int32
        Seeded states (``seeds``) that reached the attractor [1]: an attractor with
        ``seeded > 0`` and fraction 0 is one the slow sweeps reach and no drawn start.
    count : numpy.ndarray of int32
        Attractors at each point [1].
    default_attractor : numpy.ndarray of int32
        The attractor start 0 (the solver's start, always followed as
        :func:`study.solvers.exact.steady_state` follows it) reaches.
    starts_drawn : numpy.ndarray of int32
        Starts followed at each point [1]: the other starts on the table that the
        model cannot hold there (a negative normal force) are not drawn without
        flight.
    reached : numpy.ndarray of int32
        For each point and start, the attractor it reached (-1: not drawn).
    seeds_followed : numpy.ndarray of int32
        Seeded states followed at each point [1] (those with a state).
    seeded_reached : numpy.ndarray of int32
        For each point and seeded state, the attractor it reached (-1: none).
    starts : BasinStarts
        The starts.
    """

    status: NDArray[np.int8]
    velocity: NDArray[np.float64]
    velocity_error: NDArray[np.float64]
    largest_hop: NDArray[np.float64]
    orbit_period: NDArray[np.int32]
    floquet_multiplier: NDArray[np.float64]
    lyapunov_exponent: NDArray[np.float64]
    fraction: NDArray[np.float64]
    fraction_low: NDArray[np.float64]
    fraction_high: NDArray[np.float64]
    count: NDArray[np.int32]
    default_attractor: NDArray[np.int32]
    starts_drawn: NDArray[np.int32]
    reached: NDArray[np.int32]
    starts: BasinStarts
    seeded: NDArray[np.int32]
    seeds_followed: NDArray[np.int32]
    seeded_reached: NDArray[np.int32]


def basins(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    *,
    starts: int | BasinStarts = DEFAULT_STARTS,
    seed: int = 0,
    flight: bool = False,
    settings: SolverSettings | None = None,
    parallel: bool | None = None,
    seeds: str | ArrayLike | None = None,
) -> Basins:
    """Every attractor the starts reach at each drive point, with its basin fraction.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0.
    a : array_like
        Drive acceleration amplitude [m s-2], >= 0; broadcast against ``f``.
    starts : int or BasinStarts, default 24
        Starts at each point: that many (:func:`basin_starts`: the solver's start, then
        seeded draws), or the given ones (start 0 the one ``default_attractor`` names).
    seed : int, default 0
        Seed of the draws (unused with given starts).
    flight : bool, default False
        Let the base fly and land (as :func:`study.solvers.exact.steady_state`); a third
        of the draws are then drops.
    settings : SolverSettings, optional
        Budgets and the solver's start (start 0); ``continuation`` must be False (every
        start is followed from its own state).
    parallel : bool, optional
        Spread points over all cores; by default with at least 16 points.
    seeds : {"sweeps"} or array_like, optional
        States followed at each point after the drawn starts, to find the motions the
        draws do not reach: ``"sweeps"`` the end states of the coarse slow sweeps of
        :func:`sweep_seeds`, or an array of shape ``(*shape, m, 5)`` of states at phase
        0 (``(delta, delta', v, h, h')`` [m, m s-1, m s-1, m, m s-1]; a row with a NaN
        is none). Each is followed to its verified reach as a start is; the attractors
        they reach are counted (``count``, ``seeded``) but not in the fractions, which
        stay shares of the drawn starts. None (default): no seeded state.

    Returns
    -------
    Basins
        The attractors, their fractions and which one the solver's start reaches.

    Raises
    ------
    ValueError
        Bad ``starts`` or ``seed`` (naming the key), continuation, or drive values out
        of range (as :func:`study.solvers.exact.steady_state`).
    """
    structure = check_structure(structure)
    coupling = check_coupling("two-way")
    flight = check_flight(flight, coupling, structure)
    settings = check_start(check_settings(settings, coupling), None, coupling, flight)
    if settings.continuation:
        raise ValueError("basins follows every start from its own state: solver setting "
                         "'continuation' must be False with it")
    if isinstance(starts, BasinStarts):
        table = _checked_starts(starts, flight)
    else:
        first = kernel_start(settings.start)
        table = basin_starts(starts, seed=seed, flight=flight,
                             first=(first.phase, first.factor, first.height))
    shape, f_flat, a_flat = flat_drive(f, a)
    n, k = f_flat.size, len(table)
    if parallel is None:
        parallel = n >= 16
    seeded_states = _checked_seeds(
        sweep_seeds(structure, f, a, flight=flight, settings=settings, parallel=parallel)
        if isinstance(seeds, str) and seeds == "sweeps" else seeds, shape, flight)
    m = seeded_states.shape[1]
    out = np.empty((n, k + m, basin_kernel.N_BASIN))
    reached = np.empty((n, k + m), dtype=np.int64)
    counts = np.zeros(n, dtype=np.int64)
    kernel = basin_kernel.basins_points if parallel else basin_kernel.basins_points_serial
    kernel(structure_vector(structure, coupling, flight), 2.0 * np.pi * f_flat, a_flat,
           past_lift_off(structure, f_flat, a_flat), kernel_budget(settings),
           table.phase, table.factor, table.height, seeded_states, out, reached, counts)
    width = max(int(counts.max(initial=0)), 1)
    out = out[:, :width]
    seeded_reached = reached[:, k:]
    reached = reached[:, :k]
    drawn = (reached >= 0).sum(axis=1)
    present = np.arange(width)[None, :] < counts[:, None]
    hits = np.where(present, out[..., basin_kernel.B_STARTS], 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        fraction = np.where(drawn[:, None] > 0, hits / drawn[:, None], np.nan)
    low, high = wilson_interval(hits, np.broadcast_to(drawn[:, None], hits.shape))

    def per_attractor(column: int, dtype: type = np.float64, fill: float = np.nan):
        values = np.where(present, out[..., column], fill)
        return values.astype(dtype).reshape(*shape, width)

    return Basins(
        status=per_attractor(basin_kernel.B_STATUS, np.int8, NO_ATTRACTOR),
        velocity=per_attractor(basin_kernel.B_VELOCITY),
        velocity_error=per_attractor(basin_kernel.B_VELOCITY_ERROR),
        largest_hop=per_attractor(basin_kernel.B_HOP),
        orbit_period=per_attractor(basin_kernel.B_PERIOD, np.int32, 0),
        floquet_multiplier=per_attractor(basin_kernel.B_MULTIPLIER),
        lyapunov_exponent=per_attractor(basin_kernel.B_EXPONENT),
        fraction=np.where(present, fraction, 0.0).reshape(*shape, width),
        fraction_low=np.where(present, low, 0.0).reshape(*shape, width),
        fraction_high=np.where(present, high, 0.0).reshape(*shape, width),
        count=counts.astype(np.int32).reshape(shape),
        default_attractor=reached[:, 0].astype(np.int32).reshape(shape),
        starts_drawn=drawn.astype(np.int32).reshape(shape),
        reached=reached.astype(np.int32).reshape(*shape, k),
        starts=table,
        seeded=per_attractor(basin_kernel.B_SEEDED, np.int32, 0),
        seeds_followed=(seeded_reached >= 0).sum(axis=1).astype(np.int32).reshape(shape),
        seeded_reached=seeded_reached.astype(np.int32).reshape(*shape, m),
    )

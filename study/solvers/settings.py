"""The exact solver's settings and argument checks: budgets, the start, the coupling
and the lift-off law, as the wrappers of :mod:`study.solvers.exact` and the other solvers
take them, and their packing into the kernels' named arguments."""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels.budget import Budget
from study.kernels.start import Start
from study.model import (
    as_acceleration,
    as_frequency,
)
from study.model.contact import (
    COUPLINGS,
)
from study.model.inputs import InputTypeError, instance_of
from study.model.starts import (
    DEFAULT_START,
    Drop,
    as_start,
    canonical,
    kernel_fields,
    refusal,
)
from study.model.structure import Structure

__all__ = [
    "AVERAGING_SETTINGS",
    "DEFAULT_SETTINGS",
    "MAX_SOLVER_BUDGET",
    "MIN_SOLVER_BUDGET",
    "VELOCITY_TOLERANCE_RANGE",
    "SolverSettings",
    "check_coupling",
    "check_flight",
    "check_settings",
    "check_start",
    "flat_drive",
    "kernel_budget",
    "kernel_start",
]


#: Largest budget of each :class:`SolverSettings` field: 100 times the default slip
#: events (a budget only bounds pathological points; at about 1 us an event, 1e6 events
#: and 1e6 circle-map iterations of 1e6 events each bound a point's work), and far
#: below the int64 the kernels take (2**63 wrapped to a negative budget and answered
#: NOT_CONVERGED). The spec schema's ``[solver]`` maxima are exported from it.
MAX_SOLVER_BUDGET = {"max_events": 1_000_000, "max_map_iterations": 1_000_000,
                     "max_average_periods": 1_000_000}
#: Smallest budget of each :class:`SolverSettings` field (1 but for the averaged
#: periods: an irregular motion's averages are first examined after 256 periods).
MIN_SOLVER_BUDGET = {"max_events": 1, "max_map_iterations": 1, "max_average_periods": 256}
#: The settings of the averaging of irregular motions.
AVERAGING_SETTINGS = ("velocity_tolerance", "max_average_periods")
#: Range of :attr:`SolverSettings.velocity_tolerance` [1], open below.
VELOCITY_TOLERANCE_RANGE = (0.0, 1.0)

def kernel_start(start: str | Drop) -> Any:
    """The kernels' :data:`~study.kernels.start.Start` of a checked ``start`` (its
    declared :func:`~study.model.starts.kernel_fields`)."""
    return Start(*kernel_fields(start))


@dataclass(frozen=True)
class SolverSettings:
    """Budgets of the exact steady-state solver, and whether two-way orbits are continued
    along a sweep.

    Parameters
    ----------
    max_events : int
        Slip events followed from rest before a point is declared not converged
        (``NonConvergence.EVENT_BUDGET``), 1 to 1e6 (:data:`MAX_SOLVER_BUDGET`). An
        orbit with a stick closes after a few events; the budget only bounds
        pathological points.
    max_map_iterations : int
        Iterations of the continuous-sliding circle map searched for an attracting
        cycle before ``NonConvergence.NO_PERIODIC_ORBIT``, 1 to 1e6.
    velocity_tolerance : float
        An irregular motion (no stable cycle within reach: ``CHAOTIC`` or
        ``QUASI_PERIODIC``) is averaged over the period map's iterates (one-way: the
        continuous-sliding circle map's) until the 95 % confidence half-width of its
        mean velocity is within this fraction of ``a / (2 pi f)`` [1], in (0, 1].
        Default 1e-3 (about 1100 periods of a chaotic bouncing motion).
    max_average_periods : int
        Periods an irregular motion is averaged over at most (one-way: circle-map
        iterates), 256 to 1e6; a motion whose mean is still outside the tolerance then is
        ``NOT_CONVERGED`` (``NonConvergence.AVERAGE_BUDGET``), its partial averages'
        error, periods and exponent kept. Default 20 000.
    continuation : bool
        Two-way coupling only: start each orbit's Newton search from the fixed points of
        the points before it along its line of the sweep (a column of accelerations at
        one frequency, or a row of frequencies at one acceleration) instead of from rest.
        Two to four times faster on a fine map, the same orbit as from rest wherever only
        one is stable; where several are, the continued orbit follows its neighbours'
        branch, as a slowly swept drive would (docs/theory/two-way.md), and a point's
        value depends on the grid it is part of. Default False: every point from rest.
        Not with a ``start`` other than ``"release"``: a start is a protocol for each
        point, which continuing from the neighbours would replace.
    start : str or Drop
        Two-way coupling only: the state each point's motion starts from, a physical
        protocol (docs/theory/starts.md): ``"release"`` (default: the base at rest on the
        table at drive phase 0, the mode on its steady stick response, as if held down
        while the table shakes, then let go), ``"switch-on"`` (the base at rest on the
        table, the mode at rest at ``delta = delta' = 0``, the drive switched on at phase
        0), or a :class:`Drop` (the base held at rest above the table, mode at rest at
        0, let go at a drive phase; needs ``flight=True``). A mapping ``{"drop": height,
        "phase": phase}`` is taken for a :class:`Drop`. Where several motions are
        stable, the start decides which one the point reports.

    Raises
    ------
    ValueError
        A budget that is not an integer (:class:`study.model.inputs.InputTypeError`, also
        a TypeError) or is outside its range, naming the field; ``continuation`` not a
        bool (an InputTypeError); a ``start`` that is none of the allowed values, or
        other than ``"release"`` with ``continuation``.
    """

    max_events: int = 10_000
    max_map_iterations: int = 5_000
    continuation: bool = False
    velocity_tolerance: float = 1e-3
    max_average_periods: int = 20_000
    start: str | Drop = DEFAULT_START

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", as_start(self.start))
        if not isinstance(self.continuation, bool | np.bool_):
            raise InputTypeError(
                f"solver setting 'continuation' must be True or False, got "
                f"{type(self.continuation).__name__}: {self.continuation!r}")
        object.__setattr__(self, "continuation", bool(self.continuation))
        for name, largest in MAX_SOLVER_BUDGET.items():
            value = getattr(self, name)
            smallest = MIN_SOLVER_BUDGET[name]
            if isinstance(value, bool | np.timedelta64) or not isinstance(
                    value, int | np.integer):
                raise InputTypeError(
                    f"solver setting {name!r} must be an integer >= {smallest} and <= "
                    f"{largest}, got {value!r}")
            if not smallest <= value <= largest:
                raise ValueError(
                    f"solver setting {name!r} must be an integer >= {smallest} and <= "
                    f"{largest}, got {value!r}")
        tolerance = self.velocity_tolerance
        low, high = VELOCITY_TOLERANCE_RANGE
        if isinstance(tolerance, bool) or not isinstance(tolerance, int | float | np.floating
                                                          | np.integer):
            raise InputTypeError(
                f"solver setting 'velocity_tolerance' must be a number in ({low:g}, "
                f"{high:g}], got {tolerance!r}")
        if not low < float(tolerance) <= high:
            raise ValueError(
                f"solver setting 'velocity_tolerance' must be in ({low:g}, {high:g}] (a "
                f"fraction of a / (2 pi f)), got {tolerance!r}")
        object.__setattr__(self, "velocity_tolerance", float(tolerance))
        if self.continuation and self.start != "release":
            raise ValueError(_CONTINUED_START.format(start=self.start))

    def averaging_changes(self) -> dict[str, float | int]:
        """The averaging settings of irregular motions (``velocity_tolerance``,
        ``max_average_periods``) that differ from their defaults: canonical specs and
        cache keys name them only then, so that those written before them keep their
        fingerprints."""
        return {name: getattr(self, name) for name in AVERAGING_SETTINGS
                if getattr(self, name) != getattr(DEFAULT_SETTINGS, name)}

    def start_changes(self) -> dict[str, str | dict[str, float]]:
        """``{"start": ...}`` (the name, or a drop's ``{"drop": height, "phase":
        phase}``) when the start is not the release, else nothing: canonical specs and
        cache keys name it only then, so that those written before starts were named
        keep their fingerprints."""
        if self.start == DEFAULT_START:
            return {}
        return {"start": canonical(self.start)}


#: Why continuation and a start other than the release exclude each other.
_CONTINUED_START = (
    "solver setting 'start' = {start!r} with continuation = True: a start is the protocol "
    "each point's motion begins with, and continuing from the neighbours' orbits would "
    "replace it; allowed: start = \"release\" with continuation, or continuation = False")


#: The settings of ``settings=None``: frozen, so one instance serves every call.
DEFAULT_SETTINGS = SolverSettings()


def check_settings(settings: object, coupling: str | None = None) -> SolverSettings:
    """``settings``, or the defaults for None; a TypeError naming the argument for
    anything but a :class:`SolverSettings`, and a ValueError for ``continuation`` with
    a ``coupling`` other than two-way (the one-way solver has no orbit to continue)."""
    if settings is None:
        return DEFAULT_SETTINGS
    settings = instance_of("settings", settings, SolverSettings, "a study.SolverSettings")
    if settings.continuation and coupling is not None and coupling != "two-way":
        raise ValueError(
            f"SolverSettings(continuation=True) needs coupling='two-way', got "
            f"coupling={coupling!r}: the one-way solver has no orbit to continue")
    return settings


def check_start(settings: SolverSettings, start: object, coupling: str,
                flight: bool) -> SolverSettings:
    """``settings`` with the ``start`` keyword (None: ``settings.start``) checked against
    the model: a start other than the release needs ``coupling="two-way"`` (the one-way
    model has no state of the mode to start: its transient decays on its own), a drop
    needs ``flight=True`` (the base starts off the table); the keyword and a
    ``settings.start`` other than the release must agree. ValueErrors name ``start``,
    the value and the allowed values."""
    if start is not None:
        start = as_start(start)
        if settings.start != "release" and start != settings.start:
            raise ValueError(
                f"start={start!r} and settings.start={settings.start!r} differ: give the "
                "start once (the keyword overrides the default of the settings, not "
                "another start)")
        if start != settings.start:
            if settings.continuation and start != "release":
                raise ValueError(_CONTINUED_START.format(start=start))
            settings = dataclasses.replace(settings, start=start)
    problem = refusal(settings.start, coupling=coupling, flight=flight)
    if problem is not None:
        raise ValueError(problem)
    return settings


def check_coupling(coupling: object) -> str:
    """``coupling`` if it is one of :data:`COUPLINGS`, else a ValueError naming them."""
    if not isinstance(coupling, str) or coupling not in COUPLINGS:
        raise ValueError(f"coupling must be one of {', '.join(map(repr, COUPLINGS))}; "
                         f"got {coupling!r}")
    return str(coupling)


def check_flight(flight: object, coupling: str, structure: Structure) -> bool:
    """``flight`` as a bool, where the exact solver can follow a flight.

    Raises
    ------
    TypeError
        ``flight`` is not a bool (:class:`study.model.inputs.InputTypeError`, also a
        ValueError).
    ValueError
        ``flight=True`` with ``coupling="one-way"`` (the one-way model's mode is driven
        by the table alone, which no longer holds once the base leaves the table) or
        with ``M = 1`` (a massless base: the impact's mass matrix
        ``W = I + M/(1 - M) e e^T`` is unbounded).
    """
    if not isinstance(flight, bool | np.bool_):
        raise InputTypeError(f"flight must be True or False, got {type(flight).__name__}: "
                             f"{flight!r}")
    flight = bool(flight)
    if flight and coupling != "two-way":
        raise ValueError(
            f"flight=True needs coupling='two-way', got coupling={coupling!r}: the "
            "one-way model's mode is driven by the table alone, which does not hold once "
            "the base leaves the table")
    if flight and not structure.M < 1.0:
        raise ValueError(
            f"flight=True needs a mass ratio M < 1, got M={structure.M!r}: at M = 1 the "
            "base is massless and the impact's mass matrix W = I + M/(1 - M) e e^T is "
            "unbounded (use M <= 0.999)")
    return flight


@functools.lru_cache(maxsize=64)
def kernel_budget(settings: SolverSettings) -> Budget:
    """The kernels' :class:`~study.kernels.budget.Budget` of ``settings`` (frozen and
    hashable: a call with the same settings reuses it)."""
    return Budget(int(settings.max_events), int(settings.max_map_iterations),
                  float(settings.velocity_tolerance), int(settings.max_average_periods))


def flat_drive(
    f: ArrayLike, a: ArrayLike,
) -> tuple[tuple[int, ...], NDArray[np.float64], NDArray[np.float64]]:
    """The broadcast shape of the checked drive ``f``, ``a`` and both flattened
    (float64, contiguous); a ValueError for shapes that do not broadcast."""
    f_arr, a_arr = as_frequency(f), as_acceleration(a)
    # Arrays of one shape (two scalars, a fit's rows) need no broadcast, whose views
    # cost a small call more than its checks. Broadcast ones are copied: numba reading
    # the flags of a broadcast view gets numpy's FutureWarning about its writeability.
    if f_arr.shape != a_arr.shape:
        f_arr, a_arr = (np.array(x, dtype=float) for x in np.broadcast_arrays(f_arr, a_arr))
    return (f_arr.shape, np.ascontiguousarray(f_arr, dtype=float).ravel(),
            np.ascontiguousarray(a_arr, dtype=float).ravel())

"""The observables a study can ask for, each declared once.

An :class:`Observable` names its variables (declared in :mod:`study.studies.variables`),
the grid it lives on, what it requires, whether its values are worth keeping for
reuse, and how it is computed. The spec schema, the sweep, the result file and its
validation all take it from here: adding an observable is one entry in
:data:`OBSERVABLES` (and its variables in :mod:`study.studies.variables`).

Closed-form observables (``grid = "row"``) cost microseconds per frequency, less
than reading them back, so they are recomputed and never cached; solver
observables (``grid = "point"``) are cached point by point.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.model import lift_off_acceleration, mode_response, thresholds
from study.model.contact import (
    COUPLINGS,
    DEFAULT_COUPLING,
    DEFAULT_FRICTION,
    Friction,
    check_friction,
)
from study.model.statistics import Z_95
from study.model.structure import Structure
from study.solvers.attractors import attractors
from study.solvers.basins import (
    DEFAULT_STARTS,
    NO_ATTRACTOR,
    SEED_STEPS,
    basins,
    sweep_seeds,
)
from study.solvers.exact import steady_state
from study.solvers.fold_curves import fold_curves
from study.solvers.frontier import frontier_from_grid
from study.solvers.integrator import IntegratorSettings, integrated_steady_state
from study.solvers.jumps import sweep_jumps
from study.solvers.protocol import SweptState, slow_sweep
from study.solvers.section import SECTION_PERIODS, phase_section
from study.solvers.settings import SolverSettings
from study.solvers.steady import SteadyState
from study.solvers.sweep_branches import swept_branches
from study.studies.variables import DEFAULT_MAX_ATTRACTORS, VARIABLES, Variable

__all__ = [
    "BASIN_KEYS",
    "METHODS",
    "OBSERVABLES",
    "UNSWEPT_VARIABLES",
    "BasinSettings",
    "CurveWork",
    "Method",
    "Observable",
    "PointWork",
    "resolve",
    "solution_values",
    "unmet_needs",
    "variables_of",
    "velocity_interval",
]

#: Velocity solvers a spec can choose with ``[solver] method``.
METHODS = ("exact", "integrator")

#: The keys of a spec's ``[basins]`` table (:class:`BasinSettings`).
BASIN_KEYS = ("starts", "seed", "max_attractors", "sweep_steps")


@dataclass(frozen=True)
class BasinSettings:
    """How the ``basins`` observable samples each drive point (a spec's ``[basins]``).

    Attributes
    ----------
    starts : int
        Starts followed at each point (:func:`study.solvers.basins.basin_starts`: the
        solver's start, then seeded draws), >= 1; default 24.
    seed : int
        Seed of the draws, >= 0; default 0 (the same starts at every point and on
        every machine).
    max_attractors : int
        Attractor slots per point (the ``attractor`` dimension), >= 1; default 8. A
        point with more attractors keeps the first ones its starts reach;
        ``attractor_count`` stays exact.
    sweep_steps : int
        Steps of the slow sweep down along ``f`` whose end state seeds each point
        (:func:`study.solvers.basins.sweep_seeds`: from 1.5 times the point's
        frequency), >= 0; default 8; 0: no seeded state (the drawn starts alone, as
        before study 0.5).
    """

    starts: int = DEFAULT_STARTS
    seed: int = 0
    max_attractors: int = DEFAULT_MAX_ATTRACTORS
    sweep_steps: int = SEED_STEPS

    def __post_init__(self) -> None:
        for key, lowest in (("starts", 1), ("seed", 0), ("max_attractors", 1),
                            ("sweep_steps", 0)):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
                    or value < lowest:
                raise ValueError(f"{key} = {value!r}: an integer >= {lowest}")
            object.__setattr__(self, key, int(value))

    def canonical(self) -> dict[str, int]:
        """The settings as plain JSON data (in the canonical spec and the cache key of
        the basins observable's values)."""
        return {key: getattr(self, key) for key in BASIN_KEYS}


@dataclass(frozen=True)
class Method:
    """How steady velocities are computed: solver, coupling and their settings.

    Attributes
    ----------
    name : {"exact", "integrator"}
        The exact event-driven solver, or time integration until the orbit repeats.
    coupling : {"one-way", "two-way"}
        Whether the sliding base also forces the mode.
    solver : SolverSettings
        Budgets of the exact solver.
    integrator : IntegratorSettings
        Accuracy and budgets of the time integrator.
    friction : Friction
        The friction law (:mod:`study.model.contact`); the solver must implement it.
    flight : bool
        Past lift-off the base flies and lands by impacts (the lift-off law
        ``flight``); default False: the solver stops with ``LIFT_OFF`` there.
    protocol : tuple of str or None
        ``(along, direction)`` of a slow sweep (``[sweep] protocol``,
        :func:`study.solvers.protocol.slow_sweep`): a block ``f x a`` is solved as the
        runs of that sweep, each holding every value of ``along``; None (default):
        every point from its start.
    basins : BasinSettings or None
        How the ``basins`` observable samples each point (a spec's ``[basins]``); None:
        the defaults. Not in :meth:`canonical` (the velocity's values do not depend on
        it): it enters the cache key of the basins observable's values alone
        (:attr:`Observable.settings`).
    """

    name: str = "exact"
    coupling: str = DEFAULT_COUPLING
    solver: SolverSettings = field(default_factory=SolverSettings)
    integrator: IntegratorSettings = field(default_factory=IntegratorSettings)
    friction: Friction = field(default_factory=Friction)
    flight: bool = False
    protocol: tuple[str, str] | None = None
    basins: BasinSettings | None = None

    def __post_init__(self) -> None:
        check_friction(self.friction, self.name)

    def canonical(self) -> dict[str, Any]:
        """The settings that decide the numbers, as plain JSON data."""
        if self.name == "exact":
            settings = {"max_events": self.solver.max_events,
                        "max_map_iterations": self.solver.max_map_iterations}
            if self.solver.continuation:  # only when on, as flight below
                settings["continuation"] = True
            # Only where not the default, as continuation.
            settings.update(self.solver.averaging_changes())
            settings.update(self.solver.start_changes())
        else:
            settings = {
                "tolerance": self.integrator.tolerance,
                "steps_per_period": self.integrator.steps_per_period,
                "max_periods": self.integrator.max_periods,
                "max_orbit_period": self.integrator.max_orbit_period,
                "period_tolerance": self.integrator.resolved_period_tolerance,
            }
        if self.friction.law != DEFAULT_FRICTION:
            settings["friction"] = self.friction.canonical()
        if self.flight:  # only when on: the keys of values kept without it stay theirs
            settings["flight"] = True
        if self.protocol is not None:  # likewise: values kept without it keep their keys
            settings["protocol"] = {"along": self.protocol[0], "direction": self.protocol[1]}
        return {"method": self.name, "coupling": self.coupling, **settings}

    @property
    def flight_keyword(self) -> dict[str, bool]:
        """``{"flight": True}`` with flight, else nothing: the solvers' default."""
        return {"flight": True} if self.flight else {}

    def solve(self, structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
              parallel: bool = False) -> SteadyState:
        """Steady state at ``(f, a)`` (broadcast) [Hz, m s-2] by this method (with a
        protocol, ``f`` and ``a`` span the block ``f x a`` of whole runs: :meth:`sweep`)."""
        if self.protocol is not None:
            return self.sweep(structure, np.ravel(f), np.ravel(a), parallel).state
        if self.name == "integrator":
            return integrated_steady_state(structure, f, a, coupling=self.coupling,
                                           friction=self.friction, settings=self.integrator,
                                           parallel=parallel, **self.flight_keyword)
        return steady_state(structure, f, a, self.solver, coupling=self.coupling,
                            parallel=parallel, **self.flight_keyword)

    def sweep(self, structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
              parallel: bool = False) -> SweptState:
        """The slow sweep of :attr:`protocol` over the grid ``f x a`` (1-D axes, each
        run whole: every value of the swept axis)."""
        if self.protocol is None:
            raise ValueError("Method.sweep needs a protocol")
        along, direction = self.protocol
        return slow_sweep(structure, f, a, along=along, direction=direction,
                          flight=self.flight, settings=self.solver, parallel=parallel)


class _solved_once:
    """``functools.cached_property`` without its lock.

    Before Python 3.12, ``cached_property`` holds one lock per property shared by
    *all* instances while it computes: worker threads solving different tasks would
    take turns, one core doing the work of all. A :class:`PointWork` belongs to one
    task on one thread, so its values need no lock.
    """

    def __init__(self, function: Callable[[Any], Any]) -> None:
        self.function = function
        self.__doc__ = function.__doc__

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, instance: Any, owner: type | None = None) -> Any:
        if instance is None:
            return self
        # Stored under the same name: the instance's value hides this descriptor.
        value = instance.__dict__[self.name] = self.function(instance)
        return value


@dataclass
class PointWork:
    """Drive points of one task and the solves its observables share.

    Attributes
    ----------
    structure : Structure
    f, a : numpy.ndarray
        Drive frequencies [Hz] and accelerations [m s-2], broadcast together
        (``f[:, None]`` and ``a[None, :]`` for a block of the grid).
    method : Method
    """

    structure: Structure
    f: NDArray[np.float64]
    a: NDArray[np.float64]
    method: Method

    @_solved_once
    def solution(self) -> SteadyState:
        """Steady state by the study's method (computed once per task)."""
        if self.method.protocol is not None:
            return self.swept.state
        return self.method.solve(self.structure, self.f, self.a)

    @_solved_once
    def swept(self) -> SweptState:
        """The slow sweep of the study's protocol over the block (whole runs)."""
        return self.method.sweep(self.structure, np.ravel(self.f), np.ravel(self.a))

    @_solved_once
    def unswept(self) -> SteadyState:
        """Steady state by the study's method without its protocol: each point from the
        declared start alone, as the same study without ``[sweep] protocol`` solves it."""
        return replace(self.method, protocol=None).solve(self.structure, self.f, self.a)

    @_solved_once
    def one_way(self) -> SteadyState:
        """Steady state of the paper's one-way model by the exact solver (from the
        release, whatever the study's start: the one-way mode has no state to start)."""
        return steady_state(self.structure, self.f, self.a,
                            replace(self.method.solver, start="release"), parallel=False)

    @_solved_once
    def without_flight(self) -> SteadyState:
        """Steady state by the study's method with the run stopped at lift-off."""
        return replace(self.method, flight=False).solve(self.structure, self.f, self.a)


@dataclass(frozen=True)
class Observable:
    """What a spec can ask for under ``[study] observables``.

    Attributes
    ----------
    name : str
    summary : str
        One line for docs and error messages.
    grid : {"row", "point", "frontier", "curves", "branches"}
        ``row``: closed form per frequency; ``point``: per drive point, by the
        solver; ``frontier``: found from whole velocity rows after the grid;
        ``curves``: continued over the drive plane after the grid, per structure;
        ``branches``: the branches a slow sweep rides, continued after the grid, per
        structure (each after-the-grid observable's phase:
        :mod:`study.studies.phases`).
    variables : tuple of str
        Names of its variables in :data:`study.studies.variables.VARIABLES`.
    requires : tuple of str
        Observables it implies (their variables are written too).
    flight_variables : tuple of str
        Variables it also writes when the study flies (``[solver] flight = true``):
        names in :data:`study.studies.variables.VARIABLES`.
    protocol_variables : tuple of str
        Variables it also writes in a slow sweep (``[sweep] protocol``): ``jumped``
        beside the velocity, since every swept point has jumped or not (not an
        observable of its own: it means nothing without a protocol, and a spec asking
        for it would be refused beside ``frontier``).
    unswept : bool
        Its values are each point's from the declared start alone, beside a slow sweep
        (``[sweep] protocol``): solved by the study's method without the protocol,
        once whatever the sweep's direction (no ``direction`` dimension), and kept
        under the key of a study without a protocol. Only with a protocol: without one
        they would be the velocity itself.
    swept : bool
        Its values are about the slow sweep's path (where it jumped), so it needs
        ``[sweep] protocol``; with one it is computed in each direction, like the
        velocity.
    cached : bool
        Whether computed values are kept for reuse by later runs.
    settings : callable or None
        ``settings(method) -> dict``: what its values depend on beyond the method's
        :meth:`Method.canonical` (the basins observable's ``[basins]``), added to the
        cache key of its values alone; None: nothing.
    function : callable
        What :meth:`compute` calls: ``row``: ``function(structure, f) -> {name:
        (n_f,)}``; ``point``: ``function(work: PointWork) -> {name: array}``;
        ``frontier``: ``function(structure, f, a, velocity, status, method, tolerance,
        progress=None)``, each array ``(n_a, n_branch)`` (``progress(solves)`` after each
        bisection step); ``curves``: ``function(work: CurveWork, progress=None)``,
        arrays over the grids of its variables, ``(hop, a)``, ``(hop, curve_end)``
        and ``(a,)`` (``progress(steps)`` after each sweep, branch and acceleration of a
        curve).
    methods : tuple of str or None
        The velocity solvers (:data:`METHODS`, ``[solver] method``) that compute it;
        None: any.
    couplings : tuple of str or None
        The couplings (:data:`study.model.contact.COUPLINGS`, ``[solver] coupling``) it
        applies to; None: any.
    flight : bool or None
        True: only beside flight (``[solver] flight = true``); False: only without;
        None: either.
    why : str
        Why it needs what ``methods``, ``couplings`` and ``flight`` say: the reason a
        refusal gives (:func:`unmet_needs`).
    """

    name: str
    summary: str
    grid: str
    variables: tuple[str, ...]
    function: Callable[..., dict[str, NDArray[Any]]] = field(repr=False)
    requires: tuple[str, ...] = ()
    flight_variables: tuple[str, ...] = ()
    protocol_variables: tuple[str, ...] = ()
    unswept: bool = False
    swept: bool = False
    cached: bool = False
    settings: Callable[[Method], dict[str, Any]] | None = field(default=None, repr=False)
    methods: tuple[str, ...] | None = None
    couplings: tuple[str, ...] | None = None
    flight: bool | None = None
    why: str = ""

    def __post_init__(self) -> None:
        for key, declared, allowed in (("methods", self.methods, METHODS),
                                       ("couplings", self.couplings, COUPLINGS)):
            if declared is not None and (not declared or set(declared) - set(allowed)):
                raise ValueError(f"observable {self.name!r}: {key} {declared!r} must be "
                                 f"some of {allowed!r} (or None: any)")
        if self.needs_anything and not self.why:
            raise ValueError(f"observable {self.name!r}: say why it needs what it needs")

    def compute(self, *args: Any, **kwargs: Any) -> dict[str, NDArray[Any]]:
        """Its values, by :attr:`function`; a point observable first refuses a method
        it does not apply to (the spec refuses it before; a direct caller gets the
        same words)."""
        if self.grid in ("point", "curves", "branches") and self.needs_anything:
            method = args[0].method
            unmet = unmet_needs((self.name,), method.name, method.coupling, method.flight,
                                method.protocol is not None)
            if unmet:
                raise ValueError(unmet[0])
        return self.function(*args, **kwargs)

    @property
    def needs_anything(self) -> bool:
        """Whether it applies to some methods, couplings or flight only (or with a slow
        sweep only: :attr:`unswept`)."""
        return (self.methods, self.couplings, self.flight) != (None, None, None) \
            or self.unswept or self.swept

    def needs(self) -> str:
        """What it needs of ``[solver]``, in the words of a spec: ``coupling =
        "two-way" with method = "exact"``; ``""`` if any method, coupling and flight
        do."""
        return " with ".join(text for _, text in self._needs())

    def allowed(self) -> str:
        """Every ``[solver]`` setting it allows, the ones it does not care about too."""
        return ", ".join([self.needs() or "any method and coupling"]
                         + (["any method"] if self.needs_anything and self.methods is None
                            else [])
                         + (["any coupling"] if self.needs_anything and self.couplings is None
                            and not self.flight else [])  # flight has its coupling
                         + (["with or without flight"] if self.flight is None else []))

    def _needs(self) -> list[tuple[str, str]]:
        """(key, what it must be) for each ``[solver]`` key it needs a value of."""
        found = []
        if self.couplings is not None:
            found.append(("coupling", "coupling = " + _either(self.couplings)))
        if self.methods is not None:
            found.append(("method", "method = " + _either(self.methods)))
        if self.flight is not None:
            found.append(("flight", 'flight = true (with coupling = "two-way")' if self.flight
                          else "flight = false"))
        return found

    def sweeping(self) -> Observable:
        """The observable of a study with a slow sweep: its protocol variables too."""
        if not self.protocol_variables:
            return self
        return replace(self, variables=(*self.variables, *self.protocol_variables),
                       protocol_variables=())

    def flying(self) -> Observable:
        """The observable of a study with flight: its flight variables written too."""
        if not self.flight_variables:
            return self
        return replace(self, variables=(*self.variables, *self.flight_variables),
                       flight_variables=())

    @property
    def needs_acceleration(self) -> bool:
        """Whether the sweep needs the drive acceleration axis ``a``."""
        return self.grid != "row"


def _either(values: tuple[str, ...]) -> str:
    """``"exact"`` or ``"exact" or "integrator"``."""
    return " or ".join(f'"{v}"' for v in values)


def unmet_needs(requested: tuple[str, ...] | list[str], method: str, coupling: str,
                flight: bool, protocol: bool = False) -> list[str]:
    """The requested observables that do not apply to ``method``, ``coupling`` and
    ``flight`` (as :attr:`Observable.methods`, :attr:`Observable.couplings` and
    :attr:`Observable.flight` declare) or, for an :attr:`Observable.unswept` one, to a
    study without a slow sweep (``protocol`` False), one line each in
    :data:`OBSERVABLES` order: the observable, what it needs and why, the settings
    given and what is allowed. Empty where every one applies. The spec reader prefixes
    each with its file."""
    given = {"method": f'method = "{method}"', "coupling": f'coupling = "{coupling}"',
             "flight": f"flight = {'true' if flight else 'false'}"}
    lines = []
    unprotocolled = ", ".join(n for n, other in OBSERVABLES.items()
                              if not other.unswept and not other.swept)
    for name, o in OBSERVABLES.items():
        if name not in requested:
            continue
        if (o.unswept or o.swept) and not protocol:
            lines.append(
                f'[study] observable "{name}" needs [sweep] protocol: {o.why}; got no '
                f'protocol (allowed: with [sweep] protocol = {{ along = "f" or "a", '
                f'direction = "up", "down" or "both" }}; observables without a protocol: '
                f"{unprotocolled})")
            continue
        if ((o.methods is None or method in o.methods)
                and (o.couplings is None or coupling in o.couplings)
                and (o.flight is None or flight == o.flight)):
            continue
        keys = [key for key, _ in o._needs()]
        lines.append(
            f'[study] observable "{name}" needs [solver] {o.needs()}: {o.why}; got '
            f"{', '.join(given[key] for key in keys)} (allowed: {o.allowed()})")
    return lines


def _resonance(structure: Structure, f: NDArray[np.float64]) -> dict[str, NDArray[Any]]:
    response = structure.omega0**2 * mode_response(structure, f)
    # The phase lag in degree (0 at low frequency, 90 at resonance, towards 180 above).
    return {"mode_gain": np.abs(response), "mode_phase": np.degrees(-np.angle(response))}


def _thresholds(structure: Structure, f: NDArray[np.float64]) -> dict[str, NDArray[Any]]:
    plus, minus = thresholds(structure, f)
    return {"a_star_plus": plus, "a_star_minus": minus}


def _lift_off(structure: Structure, f: NDArray[np.float64]) -> dict[str, NDArray[Any]]:
    return {"lift_off_acceleration": lift_off_acceleration(structure, f)}


def solution_values(work: PointWork, names: tuple[str, ...]) -> dict[str, NDArray[Any]]:
    """The result variables ``names``, each read from the study's solution by the
    :class:`~study.solvers.steady.SteadyState` field it declares
    (:attr:`study.studies.variables.Variable.field`)."""
    values = {name: getattr(work.solution, VARIABLES[name].field) for name in names}
    missing = [name for name, value in values.items() if value is None]
    if missing:
        # A declaration error, not a user's: tests/unit/test_solver_output_declarations.py
        # checks that every kernel an observable runs on has each of its columns.
        raise RuntimeError(
            f"the solver computed no {', '.join(VARIABLES[n].field for n in missing)} for "
            f"the variables {', '.join(missing)}: its kernel's OUTPUT_COLUMNS lack the "
            "column (add it there, or restrict the observable's couplings)")
    return values


#: The variables of the velocity observable, of its flight and of the diagnostics: each
#: a solver output (:func:`study.studies.variables.solver_output`).
_VELOCITY = ("velocity", "status")
_VELOCITY_FLIGHT = ("airborne_fraction", "largest_hop", "impacts_per_period")
_DIAGNOSTICS = ("slips_per_period", "forward_slip_fraction", "backward_slip_fraction",
                "orbit_period", "nonconvergence")


def _velocity(work: PointWork) -> dict[str, NDArray[Any]]:
    values = solution_values(work, _VELOCITY)
    if work.method.protocol is not None:
        values["jumped"] = work.swept.jumped.astype(np.int8)
    if work.method.flight:
        values.update(solution_values(work, _VELOCITY_FLIGHT))
    return values


def _diagnostics(work: PointWork) -> dict[str, NDArray[Any]]:
    return solution_values(work, _DIAGNOSTICS)


def velocity_interval(mean: ArrayLike, error: ArrayLike
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The 95 % confidence interval ``(low, high)`` [m s-1] of an averaged velocity
    ``mean`` [m s-1] with standard error ``error`` [m s-1]: ``mean -+ Z_95 error``, the
    normal quantile of the averaging's own tolerance
    (:data:`study.model.statistics.Z_95`; batch means of at least 32 batches). NaN
    where either is."""
    mean = np.asarray(mean, dtype=np.float64)
    half = Z_95 * np.asarray(error, dtype=np.float64)
    return mean - half, mean + half


def _floquet(work: PointWork) -> dict[str, NDArray[Any]]:
    return solution_values(work, ("floquet_multiplier",))


def _irregular(work: PointWork) -> dict[str, NDArray[Any]]:
    # In the file's order: the 95 % interval right after the error it is made from.
    values = solution_values(work, ("averaged_velocity", "velocity_error"))
    low, high = velocity_interval(values["averaged_velocity"], values["velocity_error"])
    values.update(averaged_velocity_low=low, averaged_velocity_high=high)
    values.update(solution_values(work, ("averaged_periods", "lyapunov_exponent",
                                         "lyapunov_error")))
    return values


def _section(work: PointWork) -> dict[str, NDArray[Any]]:
    found = phase_section(work.structure, work.f, work.a, work.method.solver,
                          solution=work.solution, **work.method.flight_keyword)
    values = {"section_delta": found.delta, "section_delta_rate": found.delta_rate,
              "section_speed": found.speed}
    if work.method.flight:
        values["section_gap"] = found.gap
    return values


def _attractors(work: PointWork) -> dict[str, NDArray[Any]]:
    found = attractors(work.structure, work.f, work.a, work.method.solver,
                       coupling=work.method.coupling, parallel=False,
                       **work.method.flight_keyword)
    return {"attractor_count": found.count, "attractor_velocity_spread": found.velocity_spread,
            "attractor_starts_converged": found.starts_converged}


def basin_settings(method: Method) -> BasinSettings:
    """The ``basins`` observable's settings of a method (the defaults if none)."""
    return method.basins if method.basins is not None else BasinSettings()


def _basin_key(method: Method) -> dict[str, Any]:
    return {"basins": basin_settings(method).canonical()}


#: Each per-attractor variable of the basins observable: the field of
#: :class:`study.solvers.basins.Basins` it is, and the value of an empty slot.
_PER_ATTRACTOR = {
    "basin_status": ("status", NO_ATTRACTOR),
    "basin_velocity": ("velocity", np.nan),
    "basin_velocity_error": ("velocity_error", np.nan),
    "basin_largest_hop": ("largest_hop", np.nan),
    "basin_period": ("orbit_period", 0),
    "basin_multiplier": ("floquet_multiplier", np.nan),
    "basin_exponent": ("lyapunov_exponent", np.nan),
    "basin_fraction": ("fraction", np.nan),
    "basin_fraction_low": ("fraction_low", np.nan),
    "basin_fraction_high": ("fraction_high", np.nan),
}


def _basins(work: PointWork) -> dict[str, NDArray[Any]]:
    """:func:`study.solvers.basins.basins` at the block, its attractors in
    ``max_attractors`` slots (the first ones reached; empty slots filled), the count
    exact."""
    settings = basin_settings(work.method)
    seeds = None
    if settings.sweep_steps > 0:  # each point's own sweep: no value depends on a unit
        seeds = sweep_seeds(work.structure, work.f, work.a, flight=work.method.flight,
                            settings=work.method.solver, parallel=False,
                            steps=settings.sweep_steps)
    found = basins(work.structure, work.f, work.a, starts=settings.starts,
                   seed=settings.seed, flight=work.method.flight,
                   settings=work.method.solver, parallel=False, seeds=seeds)
    slots = settings.max_attractors
    width = min(found.status.shape[-1], slots)
    present = np.arange(slots) < np.minimum(found.count, slots)[..., None]
    values: dict[str, NDArray[Any]] = {}
    for name, (source, empty) in _PER_ATTRACTOR.items():
        computed = getattr(found, source)
        array = np.full((*found.count.shape, slots), empty, dtype=VARIABLES[name].dtype)
        array[..., :width] = computed[..., :width]
        values[name] = np.where(present, array, np.asarray(empty, dtype=array.dtype))
    values.update({"attractor_count": found.count.astype(np.int32),
                   "default_attractor": found.default_attractor.astype(np.int32),
                   "starts_drawn": found.starts_drawn.astype(np.int32)})
    return values


def _jumps(work: PointWork) -> dict[str, NDArray[Any]]:
    # A task of a slow sweep holds whole runs: the point before each jump is in it.
    located = sweep_jumps(work.structure, np.ravel(work.f), np.ravel(work.a), work.swept,
                          flight=work.method.flight, settings=work.method.solver)
    return {"jump_bifurcation": located.kind, "jump_f": located.f, "jump_a": located.a,
            "jump_velocity": located.velocity,
            "jump_multiplier_modulus": located.multiplier_modulus,
            "jump_multiplier_angle": np.degrees(located.multiplier_angle)}


def _unswept(work: PointWork) -> dict[str, NDArray[Any]]:
    s = work.unswept
    return {"velocity_unswept": s.velocity, "status_unswept": s.status}


def _paper_model(work: PointWork) -> dict[str, NDArray[Any]]:
    return {"velocity_one_way": work.one_way.velocity, "status_one_way": work.one_way.status}


def _without_flight(work: PointWork) -> dict[str, NDArray[Any]]:
    s = work.without_flight
    return {"velocity_without_flight": s.velocity, "status_without_flight": s.status}


def _frontier(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
              velocity: NDArray[np.float64], status: NDArray[np.int8], method: Method,
              tolerance: float, progress: Callable[[int], None] | None = None
              ) -> dict[str, NDArray[Any]]:
    found = frontier_from_grid(structure, f, a, velocity, status, tolerance=tolerance,
                               settings=method.solver, solve=method.solve, progress=progress)
    return {"frontier_frequency": found.frequency, "frontier_kind": found.kind,
            "frontier_direction": found.direction, "frontier_bracket": found.width}


@dataclass(frozen=True)
class CurveWork:
    """What a ``curves`` observable is computed from: one structure, the study's whole
    drive axes ``f`` [Hz] and ``a`` [m s-2] (1-D) and its method."""

    structure: Structure
    f: NDArray[np.float64]
    a: NDArray[np.float64]
    method: Method


def _fold_curves(work: CurveWork, progress: Callable[[int], None] | None = None
                 ) -> dict[str, NDArray[Any]]:
    found = fold_curves(work.structure, work.f, work.a, flight=work.method.flight,
                        settings=work.method.solver, progress=progress)
    return {"fold_f": found.f, "fold_velocity": found.velocity, "fold_status": found.status,
            "fold_end": found.end, "fold_end_last": found.end_last,
            "fold_end_past": found.end_past, "doubling_f": found.doubling_f,
            "doubling_velocity": found.doubling_velocity,
            "doubling_status": found.doubling_status}


def _swept_branches(work: CurveWork, progress: Callable[[int], None] | None = None
                    ) -> dict[str, NDArray[Any]]:
    """The branches the study's slow sweeps ride (each direction's sweep solved again
    over the whole grid, as the map's), one per piece of each run on one motion."""
    method = work.method
    along, direction = method.protocol  # type: ignore[misc]
    sweeps = [slow_sweep(work.structure, work.f, work.a, along=along, direction=way,
                         flight=method.flight, settings=method.solver)
              for way in (("up", "down") if direction == "both" else (direction,))]
    found = swept_branches(work.structure, work.f, work.a, sweeps, flight=method.flight,
                           settings=method.solver, progress=progress)
    ways = np.array([{"up": 0, "down": 1}[swept.direction] for swept in sweeps], np.int8)
    return {
        "branch_sweep": ways[found.sweep], "branch_start_f": found.start_f,
        "branch_start_a": found.start_a, "branch_end": found.end,
        "branch_steps": found.steps, "branch_orbit_period": found.periods,
        "branch_bifurcations": found.count, "branch_f": found.f, "branch_a": found.a,
        "branch_velocity": found.velocity, "branch_stable": found.stable,
        "branch_largest_multiplier": found.largest_multiplier,
        "branch_largest_hop": found.largest_hop, "branch_bifurcation_kind": found.kind,
        "branch_bifurcation_f": found.bifurcation_f,
        "branch_bifurcation_a": found.bifurcation_a,
        "branch_bifurcation_velocity": found.bifurcation_velocity,
        "branch_bifurcation_multiplier_modulus": found.multiplier_modulus,
        "branch_bifurcation_multiplier_angle": np.degrees(found.multiplier_angle),
        "branch_bifurcation_step": found.step,
        "branch_bifurcation_location": found.location,
    }


_DECLARED = (
    Observable("resonance", "gain and phase of the plate's first mode", "row",
               ("mode_gain", "mode_phase"), _resonance),
    Observable("thresholds", "drive accelerations at which forward/backward slips start",
               "row", ("a_star_plus", "a_star_minus"), _thresholds),
    Observable("lift_off", "drive acceleration at which the normal force vanishes", "row",
               ("lift_off_acceleration",), _lift_off),
    Observable("velocity", "steady mean velocity and the solver's status (with flight also "
               "the airborne fraction, largest hop and impacts per period)", "point",
               _VELOCITY, _velocity, cached=True, flight_variables=_VELOCITY_FLIGHT,
               protocol_variables=("jumped",)),
    Observable("diagnostics", "slips per period, slip fractions, orbit period, why not "
               "converged", "point",
               _DIAGNOSTICS, _diagnostics, requires=("velocity",),
               cached=True),
    Observable("floquet", "largest Floquet multiplier of the orbit (exact two-way solver "
               "only)", "point", ("floquet_multiplier",), _floquet, requires=("velocity",),
               cached=True, methods=("exact",), couplings=("two-way",),
               why="the exact two-way solver is the one that computes the orbit's Floquet "
               "multipliers"),
    Observable("irregular", "time averages of motions without a stable cycle within reach "
               "(chaotic, quasi-periodic): the averaged velocity, its standard error and "
               "95 % interval, the periods averaged, the largest Lyapunov exponent and its "
               "error (exact two-way solver only)", "point",
               ("averaged_velocity", "velocity_error", "averaged_velocity_low",
                "averaged_velocity_high", "averaged_periods", "lyapunov_exponent",
                "lyapunov_error"), _irregular, requires=("velocity",),
               cached=True, methods=("exact",), couplings=("two-way",),
               why="the exact two-way solver is the one that averages irregular motions "
               "and computes their Lyapunov exponent"),
    Observable("section", "the phase-0 Poincare section: the state at drive phase 0 in "
               f"{SECTION_PERIODS} consecutive periods of the motion (what a bifurcation "
               "diagram plots; "
               "exact two-way solver only)", "point",
               ("section_delta", "section_delta_rate", "section_speed"), _section,
               requires=("velocity",), flight_variables=("section_gap",), cached=True,
               methods=("exact",), couplings=("two-way",),
               why="the exact two-way solver is the one that follows the period map's "
               "state"),
    Observable("attractors", "multistability: distinct stable orbits from 12 starting "
               "states and their velocity spread (exact solver; 12 solves per point)", "point",
               ("attractor_count", "attractor_velocity_spread", "attractor_starts_converged"),
               _attractors, requires=("velocity",), cached=True, methods=("exact",),
               why="the exact solver is the one that finds the stable orbits from several "
               "starting states"),
    Observable("basins", "every attractor at each point and its basin fraction: the motions "
               "that seeded starts reach ([basins] starts, 24 by default: the solver's "
               "start, then drive phases, mode amplitudes and, with flight, drops) and the "
               "state a slow sweep down along f settles on ([basins] sweep_steps), each "
               "one's status, velocity, largest hop, period, Floquet multiplier or Lyapunov "
               "exponent, and the share of the drawn starts that reach it with its 95 % "
               "Wilson interval over those starts (exact two-way solver; one solve per "
               "start and point, and one per sweep step)", "point",
               ("basin_status", "basin_velocity", "basin_velocity_error", "basin_largest_hop",
                "basin_period", "basin_multiplier", "basin_exponent", "basin_fraction",
                "basin_fraction_low", "basin_fraction_high", "attractor_count",
                "default_attractor", "starts_drawn"),
               _basins, requires=("velocity",), cached=True, settings=_basin_key,
               methods=("exact",), couplings=("two-way",),
               why="the exact two-way solver is the one that follows each start to the "
               "attractor it reaches, verified"),
    Observable("paper_model", "the paper's one-way velocity beside a two-way study", "point",
               ("velocity_one_way", "status_one_way"), _paper_model, requires=("velocity",),
               cached=True, couplings=("two-way",),
               why="it is the one-way model beside a two-way study; a one-way study's "
               "velocity already is the paper's model"),
    Observable("without_flight", "the same method's velocity where the run stops at lift-off, "
               "beside a study with flight", "point",
               ("velocity_without_flight", "status_without_flight"), _without_flight,
               requires=("velocity",), cached=True, flight=True,
               why="it is the velocity stopped at lift-off beside a study with flight; "
               "without flight the study's velocity already stops there"),
    Observable("unswept", "beside a slow sweep, the velocity each point reaches from the "
               "declared start alone (the same study without its protocol: one more map "
               "of the solver)", "point", ("velocity_unswept", "status_unswept"), _unswept,
               requires=("velocity",), cached=True, unswept=True,
               why="it is each point's answer from its start alone beside the swept "
               "velocity; without a protocol the study's velocity already is that answer"),
    Observable("jumps", "where a slow sweep jumps, located exactly: at each jumped point "
               "the bifurcation (a fold, a lift-off, a non-smooth end, a loss of stability) "
               "at which the branch of the previous point's orbit, followed by "
               "pseudo-arclength continuation towards this drive, stops being the stable "
               "motion the sweep rode, its drive to 1e-10, its velocity and multiplier "
               "(one branch traced per jump)", "point",
               ("jump_bifurcation", "jump_f", "jump_a", "jump_velocity",
                "jump_multiplier_modulus", "jump_multiplier_angle"), _jumps,
               requires=("velocity",), cached=True, swept=True,
               why="it locates where the slow sweep jumped; without a protocol nothing "
               "is swept"),
    Observable("frontier", "zero-velocity frontier f*(a), refined by bisection", "frontier",
               ("frontier_frequency", "frontier_kind", "frontier_direction",
                "frontier_bracket"), _frontier, requires=("velocity",)),
    Observable("fold_curves", "the folds that bound where the forward and the backward "
               "hop coexist, as curves f_fold(a): slow sweeps up and down along the "
               "study's f at each a locate where each hop's branch folds (the forward "
               "hop's swept up, the backward hop's swept down), and one fold of each is "
               "continued over the study's a axis both ways, exact at each a, its ends "
               "(a cusp, another bifurcation) bracketed; and the forward hop's period "
               "doubling below its fold in f, the hop's other edge, continued likewise "
               "(after the map, per structure)",
               "curves", ("fold_f", "fold_velocity", "fold_status", "fold_end",
                          "fold_end_last", "fold_end_past", "doubling_f",
                          "doubling_velocity", "doubling_status"), _fold_curves,
               requires=("velocity",), methods=("exact",), couplings=("two-way",),
               why="the exact two-way solver's period map is what slow sweeps carry the "
               "state on and branches are continued on"),
    Observable("branches", "the branches the slow sweeps ride, continued over the swept "
               "range: each piece of a run on one motion (between jumps, and where its "
               "orbit's period changes) is the branch of the orbit of its last point, "
               "continued by pseudo-arclength continuation back to the piece's first "
               "drive and on to the end of the swept axis, through its fold onto the "
               "unstable part, each step's velocity and stability and each bifurcation "
               "on it located exactly (after the map, per structure; one or two short "
               "branches per piece)", "branches",
               ("branch_sweep", "branch_start_f", "branch_start_a", "branch_end",
                "branch_steps", "branch_orbit_period", "branch_bifurcations", "branch_f",
                "branch_a", "branch_velocity", "branch_stable", "branch_largest_multiplier",
                "branch_largest_hop", "branch_bifurcation_kind", "branch_bifurcation_f",
                "branch_bifurcation_a", "branch_bifurcation_velocity",
                "branch_bifurcation_multiplier_modulus",
                "branch_bifurcation_multiplier_angle", "branch_bifurcation_step",
                "branch_bifurcation_location"),
               _swept_branches, requires=("velocity", "diagnostics"), swept=True,
               methods=("exact",), couplings=("two-way",),
               why="it continues the motions a slow sweep rides, on the exact two-way "
               "solver's period map"),
)

#: name -> Observable, in the order they appear in a dataset.
OBSERVABLES: dict[str, Observable] = {o.name: o for o in _DECLARED}

#: Variables of the :attr:`Observable.unswept` observables: the same whatever the slow
#: sweep's direction (no ``direction`` dimension).
UNSWEPT_VARIABLES = frozenset(v for o in _DECLARED if o.unswept for v in o.variables)


def resolve(requested: tuple[str, ...] | list[str], flight: bool = False,
            protocol: bool = False) -> tuple[Observable, ...]:
    """The requested observables and those they require, in :data:`OBSERVABLES` order
    (with ``flight``, each writing its flight variables too; with ``protocol``, a slow
    sweep, its protocol variables)."""
    wanted = set(requested)
    for name in list(wanted):
        wanted.update(OBSERVABLES[name].requires)
    found = tuple(o.flying() if flight else o
                  for name, o in OBSERVABLES.items() if name in wanted)
    return tuple(o.sweeping() for o in found) if protocol else found


def variables_of(requested: tuple[str, ...] | list[str], flight: bool = False,
                 protocol: bool = False) -> tuple[Variable, ...]:
    """Every variable a study with these observables (and ``flight``, a ``protocol``)
    writes, in file order."""
    names = {v for o in resolve(requested, flight, protocol) for v in o.variables}
    return tuple(v for name, v in VARIABLES.items() if name in names)

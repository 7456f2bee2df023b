"""Property tier of the public API's inputs (issue 19): any argument, of any type or
size, gives a result or a TypeError/ValueError whose message names the argument; never
another exception, never a hang, never NaN without a status that flags it.

Each case replaces one argument of a working call by a value drawn from wrong types
(None, strings, lists of strings, dicts, booleans, complex numbers, dates, empty and
3-D arrays, objects) and extreme numbers (NaN, infinities, 0, negative, 1e-300,
denormals, 1e300, huge integers). Seeded (``derandomize``) and repeatable; every case
runs under a deadline (:func:`deadline`). ``CASES`` counts them.
"""

from __future__ import annotations

import faulthandler
import math
import re
import signal
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest
import xarray as xr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import study
from study.analyses import export as export_module
from study.analyses import fit, fit_model, fit_search, fit_spec, selection
from study.analyses.design_margins import disk_limits
from study.analyses.design_spec import load_design_spec, parse_design_spec
from study.model import disk as disk_model
from study.model.structure import tilt_warnings
from study.scenes import planar_model as planar
from study.scenes import planner
from study.solvers import integrator as transient
from study.solvers import planar as planar_solver
from study.solvers import planar_periodic
from tests.support.tiers import headline

#: Seconds one case may take: a call that has not returned by then hangs (the slowest
#: valid calls here take well under a second).
CASE_SECONDS = 20.0
#: A call stuck in compiled code cannot be interrupted: after this long the process
#: dumps every thread's stack and exits, failing the run instead of hanging it.
HARD_SECONDS = 120.0
#: Examples per function: derandomized, so every run tries the same cases.
EXAMPLES = 40

PROPERTY = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow,
                                           HealthCheck.function_scoped_fixture])


class Hung(Exception):
    """A case that did not return within :data:`CASE_SECONDS`."""


@contextmanager
def deadline(seconds: float = CASE_SECONDS) -> Iterator[None]:
    """Raise :class:`Hung` in the test if the block runs longer than ``seconds``
    (SIGALRM: Python-level loops); and exit the process with every stack dumped after
    :data:`HARD_SECONDS` (loops in numba's compiled code do not see signals)."""

    def expired(signum, frame):
        raise Hung(f"no answer within {seconds} s")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    faulthandler.dump_traceback_later(HARD_SECONDS, exit=True, file=sys.stderr)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)
        faulthandler.cancel_dump_traceback_later()


# -- what is drawn ----------------------------------------------------------------------

EXTREME_FLOATS = st.sampled_from([
    math.nan, math.inf, -math.inf, 0.0, -0.0, -1.0, 1e-300, 5e-324, 2.2e-308, 1e300,
    -1e300, 1.7976931348623157e308, 1e-15, 1e6, 1e7,
])
WRONG_TYPES = st.one_of(
    st.none(),
    st.text(max_size=6),
    st.lists(st.text(max_size=3), min_size=1, max_size=3),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
    st.booleans(),
    st.complex_numbers(allow_nan=False, allow_infinity=False, max_magnitude=1e3),
    st.just(np.datetime64("2020-01-01")),
    st.just(np.timedelta64(5, "s")),
    st.just(np.array([])),
    st.just(np.ones((2, 2, 2))),
    st.just(object()),
    st.just(b"14"),
)
NUMBERS = st.one_of(
    EXTREME_FLOATS,
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.just(2**63), st.just(-(2**63)),
)
ANY_VALUE = st.one_of(WRONG_TYPES, NUMBERS)

# -- the calls --------------------------------------------------------------------------

S = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
PLATE = disk_model.Plate(14.44, 17.5, 64.0, 0.08, 0.0, (0.005, 0.0), "head")
DISK = disk_model.Disk(radius=0.02, plates=(PLATE,), cs=0.25)
SCHEDULE = transient.Schedule(np.array([14.2]), np.array([7.0]), np.array([0.2]))
COMMANDS = {
    "forward": planner.Command("forward", 14.2, 7.0, 0.01, 0.001, 0.01),
    "backward": planner.Command("backward", 15.2, 7.0, -0.01, 0.0, 0.0),
    "left": planner.Command("left", 7.2, 7.0, 0.0, 0.0, 0.5),
    "right": planner.Command("right", 8.2, 7.0, 0.0, 0.0, -0.5),
}
DATASET = xr.Dataset({"v": (("f",), np.arange(3.0), {"units": "m s-1"})},
                     coords={"f": ("f", [13.0, 14.0, 15.0], {"units": "Hz"})})
PARAMS = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25}


def call(function: Callable[..., Any], *args: Any, **kwargs: Any
         ) -> tuple[Callable[..., Any], tuple[Any, ...], dict[str, Any]]:
    return function, args, kwargs


#: name -> (function, positional arguments, keyword arguments) of a call that works.
#: Each test replaces one argument (by position or keyword) by a drawn value.
CALLS = {
    "Structure": call(study.Structure, **PARAMS),
    "SolverSettings": call(study.SolverSettings, max_events=100, max_map_iterations=100),
    "steady_state": call(study.steady_state, S, 14.0, 8.0, None, coupling="one-way"),
    "steady_state two-way": call(study.steady_state, S, 14.0, 8.0, coupling="two-way"),
    "steady_velocity": call(study.steady_velocity, S, 14.0, 8.0, None),
    "thresholds": call(study.thresholds, S, 14.0),
    "lift_off_acceleration": call(study.lift_off_acceleration, S, 14.0),
    "mode_response": call(study.mode_response, S, 14.0),
    "force_amplitudes": call(study.force_amplitudes, S, 14.0, 8.0),
    "normal_force": call(study.normal_force, S, 14.0, 8.0, 0.01),
    "tangential_force": call(study.tangential_force, S, 14.0, 8.0, 0.01),
    "frontier": call(study.frontier, S, [8.0], (12.0, 16.0), num=9, tolerance=1e-4,
                     settings=None, coupling="one-way"),
    "minimum_threshold": call(study.minimum_threshold, S, (12.0, 16.0), tolerance=1e-6,
                              coupling="one-way"),
    "branch": call(study.branch, S, 14.0, 8.0, along="a", to=9.0),
    "compute_map": call(study.compute_map, S, [13.0, 14.0], [8.0], workers=1,
                        observables=("velocity",), coupling="one-way", settings=None),
    "open_result": call(study.open_result, "/nonexistent/result.nc"),
    "Plate": call(disk_model.Plate, 14.44, 17.5, 64.0, 0.08, 0.0, (0.005, 0.0), "head"),
    "Disk": call(disk_model.Disk, 0.02, (PLATE,), 0.25, None, 9.8, None, None),
    "contact_margins": call(planar.contact_margins, DISK, 14.0, 7.0, samples=16),
    "steady_plate_states": call(planar.steady_plate_states, DISK, 14.0, 7.0, 0.0),
    "rest_state": call(planar.rest_state, DISK, (0.0, 0.0, 0.0), None),
    "state_names": call(planar_solver.state_names, DISK),
    "describe_disk": call(disk_model.describe_disk, DISK),
    "periodic_motion": call(planar.periodic_motion, DISK, 14.0, 7.0, max_periods=3,
                            max_orbit_period=2, settings=None),
    "integrated_periodic_motion": call(planar_periodic.integrated_periodic_motion, DISK,
                                       14.0, 7.0, max_periods=3, max_orbit_period=2,
                                       settings=None),
    "simulate_planar": call(planar_solver.simulate_planar, DISK, SCHEDULE, max_events=10,
                            heading_noise=0.0, settings=None),
    "arc_displacement": call(planner.arc_displacement, COMMANDS["left"], 1.0),
    "plan_leg": call(planner.plan_leg, (0.0, 0.0, 90.0), (0.0, 0.01), COMMANDS, 20),
    "plan_route": call(planner.plan_route, (0.0, 0.0, 90.0), np.array([[0.0, 0.01]]),
                       COMMANDS),
    "IntegratorSettings": call(transient.IntegratorSettings, tolerance=1e-8, max_periods=50),
    "Schedule": call(transient.Schedule, np.array([14.0]), np.array([8.0]),
                     np.array([0.2])),
    "simulate": call(transient.simulate, S, SCHEDULE, max_events=10, settings=None),
    "steady_mode_state": call(transient.steady_mode_state, S, 14.0, 8.0),
    "model_parameters": call(transient.model_parameters, S, "one-way"),
    "integrated_steady_state": call(transient.integrated_steady_state, S, 14.0, 8.0,
                                    settings=transient.IntegratorSettings(max_periods=50)),
    "disk_parameters": call(planar_solver.disk_parameters, DISK),
    "load_fit_spec": call(fit_spec.load_fit_spec, "/nonexistent/fit.toml"),
    "load_design_spec": call(load_design_spec, "/nonexistent/design.toml"),
    "bound_side": call(fit_search.bound_side, 1.0, 0.0, 2.0),
    "chi2_p_value": call(fit_search.chi2_p_value, 3.0, 2),
    "fitted_structure": call(fit_model.fitted_structure, PARAMS, 0.0),
    "parse_fit_spec": call(fit_spec.parse_fit_spec, "[fit]\n"),
    "parse_design_spec": call(parse_design_spec, "[design]\n"),
    "disk_limits": call(disk_limits, DISK, 14.0, samples=16),
    "parse_selection": call(selection.parse_selection, ["f=14"]),
    "select": call(selection.select, DATASET, ["f=14"]),
    "available": call(selection.available, DATASET),
    "tables": call(export_module.tables, DATASET, None),
}

#: How a refusal may name an argument when not by its own name.
ALIASES = {
    "f": r"\bf\b|frequenc", "a": r"\ba\b|accelerat", "t": r"\btime t\b",
    "f_range": r"f_range", "text": r"spec text|TOML|\[fit\]|\[design\]|spec",
    "texts": r"sel|selection", "selections": r"sel|selection",
    "frequency": r"frequenc", "drive": r"drive|\bf\b|\ba\b", "acceleration": r"accelerat",
    "duration": r"duration",
    "plates": r"plates", "waypoints": r"waypoints", "phase": r"phase",
    "chi2": r"chi2|chi\^2", "dof": r"dof|degrees of freedom",
    # open_result('') says ".: no such file": the path as resolved
    "path": r"path|file|folder|directory|\.nc|\.toml",
    "variables": r"variables|--var",
}


def _slots(name: str) -> list[tuple[str, int | str]]:
    function, args, kwargs = CALLS[name]
    import inspect

    parameters = list(inspect.signature(function).parameters)
    return ([(parameters[i], i) for i in range(len(args))]
            + [(key, key) for key in kwargs])


SLOTS = [(name, parameter, where) for name in CALLS for parameter, where in _slots(name)]


def _nan_is_flagged(result: Any) -> bool:
    """A solver's NaN velocities only where the status flags them."""
    if isinstance(result, study.SteadyState):
        flagged = np.isin(result.status, [study.Status.LIFT_OFF, study.Status.NOT_CONVERGED,
                                          study.Status.FRICTION_PARADOX])
        return bool(np.all(np.isnan(result.velocity) == flagged))
    if isinstance(result, tuple) and len(result) == 2 and isinstance(
            result[1], np.ndarray | np.integer) and np.asarray(result[1]).dtype == np.int8:
        velocity, status = (np.asarray(r) for r in result)
        flagged = np.isin(status, [study.Status.LIFT_OFF, study.Status.NOT_CONVERGED,
                                   study.Status.FRICTION_PARADOX])
        return bool(np.all(np.isnan(velocity) == flagged))
    return True


#: Cases tried, by outcome (a run prints them with -s; the docs quote a run's counts).
CASES: dict[str, int] = {"result": 0, "refused": 0}
#: The slots whose cases ran in this process (a tier or a selection may run a few).
RAN: set[tuple[str, str]] = set()


@pytest.mark.parametrize(("name", "parameter", "where"),
                         headline(SLOTS, per=lambda name, parameter, where: name),
                         ids=[f"{n}-{p}" for n, p, _ in SLOTS])
@PROPERTY
@given(value=ANY_VALUE)
def test_any_argument_gives_a_result_or_an_error_naming_it(name, parameter, where, value):
    RAN.add((name, parameter))
    function, args, kwargs = CALLS[name]
    args, kwargs = list(args), dict(kwargs)
    if isinstance(where, int):
        args[where] = value
    else:
        kwargs[where] = value
    try:
        with deadline(), tilt_warnings(False):
            result = function(*args, **kwargs)
    except (TypeError, ValueError) as err:
        message = str(err)
        pattern = ALIASES.get(parameter, re.escape(parameter))
        assert re.search(pattern, message, re.IGNORECASE), (
            f"{name}({parameter}={value!r}): the message does not name {parameter!r}: "
            f"{message}")
        CASES["refused"] += 1
    else:
        assert _nan_is_flagged(result), f"{name}({parameter}={value!r}): unflagged NaN"
        CASES["result"] += 1


#: Public functions not fuzzed here, and why: each runs a whole computation from a file
#: or a spec object whose own inputs are fuzzed above (the file readers, the spec
#: parsers, the settings, Structure, Disk), or writes files named by its arguments.
NOT_FUZZED = {
    "run": "runs a spec file (the spec parser and the CLI fuzz cover its inputs)",
    "export_csv": "writes files named by its arguments; its dataset check is tables'",
    "calibrate_commands": "a periodic_motion per command (fuzzed above)",
    "refined_legs": "simulates plan_leg's legs (both fuzzed above)",
    "refined_route": "simulates plan_route's legs (both fuzzed above)",
    "run_plan": "simulates routes (fuzzed above) for minutes",
    "fit": "takes a FitSpec, made only by the fit spec parser (fuzzed above)",
    "fit_dataset": "takes a FitSpec and a FitResult",
    "model_values": "the fit's model on a measurement dataset (the wp-csv fuzz)",
    "structure_groups": "a measurement dataset (the wp-csv fuzz)",
    "design": "takes a DesignSpec, made only by the design spec parser (fuzzed above)",
    "design_dataset": "takes a DesignSpec and a DesignResult",
    "evaluate": "takes a DesignSpec",
    "bifurcation_curve": "takes a branch's dataset (branch, fuzzed above) and the index "
                         "of one of its bifurcations",
    "doubled_branch": "takes a branch's dataset (branch, fuzzed above) and the index of "
                      "one of its period doublings",
    "max_steady_periods": "takes no argument",
    **{name: "the plates' steady response at a drive already checked (by "
             "steady_plate_states, contact_margins and integrated_periodic_motion, fuzzed "
             "above)" for name in ("mode_amplitude", "steady_plate_response")},
    "tolerance_scales": "the integrators' tolerance scales of a disk and drive already "
                        "checked (by simulate_planar and integrated_periodic_motion, fuzzed "
                        "above)",
    "integrator_budget_maxima": "takes no argument",
    **{name: "a validator, run by every call above" for name in (
        "check_commands", "check_disk", "check_drive", "check_integrator_settings",
        "check_samples", "check_slaving")},
}


def test_every_public_function_is_fuzzed_or_says_why_not():
    import inspect

    from study.analyses import design, design_margins, design_search, design_spec, selection
    from study.analyses import export as export_module
    from study.model import disk as disk_model
    from study.scenes import planar_model as planar
    from study.scenes import planner
    from study.solvers import integrator as transient
    from study.solvers import planar as planar_solver
    from study.solvers import planar_periodic

    modules = [study, disk_model, planar, planar_solver, planar_periodic, planner, transient,
               fit, fit_spec, fit_model, fit_search, design, design_spec, design_margins,
               design_search, selection, export_module]
    public = {name for module in modules for name in module.__all__
              if inspect.isfunction(getattr(module, name))}
    covered = {name.split()[0] for name in CALLS}
    assert public - covered - set(NOT_FUZZED) == set()
    assert len(SLOTS) * EXAMPLES >= 5000  # the cases a run tries (docs quote it)


def test_the_tier_s_counts_are_recorded_for_the_docs():
    """Runs after the cases above (pytest keeps file order): ``make fuzz`` records what
    this tier tried, beside the fuzz tiers, for the reliability table of the docs."""
    from tests.support.reliability import record

    tried = CASES["result"] + CASES["refused"]
    if len(RAN) < len(SLOTS):
        pytest.skip(f"{len(RAN)} of {len(SLOTS)} slots ran in this process (a tier, a "
                    "selection or a test worker): the counts are of a whole run")
    record("tests/property/test_api_inputs.py",
           "arguments of every public function: wrong types and extreme numbers",
           cases=tried, faults=tried, results_checked=CASES["result"])
    assert tried >= len(SLOTS)

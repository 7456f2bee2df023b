"""Inputs that would hang, overflow or answer nonsense are refused, naming the argument
(issue 19): tolerances finer than doubles resolve, budgets beyond what the kernels take,
dates as frequencies, objects of the wrong type. Each refusal is compared against the
behaviour it replaces (a hang, NOT_CONVERGED, an AttributeError) by the rule that decides
it (the spacing of doubles, int64, the declared maxima)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import study
from study.analyses.thresholds import lowest_threshold
from study.model.inputs import InputTypeError
from study.solvers.frontier import (
    MAX_SCAN_POINTS,
    TOLERANCE_SPACINGS,
    finest_tolerance,
    frontier_from_grid,
)
from study.solvers.settings import MAX_SOLVER_BUDGET
from study.studies.schema import spec_schema

S = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)


# -- tolerances -------------------------------------------------------------------------

def test_the_finest_tolerance_is_a_few_spacings_of_doubles() -> None:
    for f in (1e-3, 14.44, 1e6):
        assert finest_tolerance(f) == TOLERANCE_SPACINGS * np.spacing(f)
    # 1e-15 Hz near 20 Hz is below one spacing (3.6e-15): bisection can never reach it.
    assert np.spacing(20.0) > 1e-15


@pytest.mark.parametrize("tolerance", [1e-15, 0.0, -1.0, math.nan, math.inf, 1e-300])
def test_frontier_refuses_a_tolerance_it_cannot_reach(tolerance) -> None:
    """It never returned for 1e-15 (the bracket stops shrinking at a spacing)."""
    with pytest.raises(ValueError, match=r"tolerance = .* out of range; allowed: finite and "
                                         r">= 1\.42e-14 Hz"):
        study.frontier(S, [8.0], (12.0, 20.0), num=5, tolerance=tolerance)


@pytest.mark.parametrize("tolerance", [0, 0.0, -1e-9, 1e-16, math.nan, math.inf])
def test_minimum_threshold_refuses_a_tolerance_it_cannot_reach(tolerance) -> None:
    """It never returned for 0 (the golden-section bracket stops at a few spacings)."""
    finest = finest_tolerance(2.0 * S.f0)
    with pytest.raises(ValueError, match=f"allowed: finite and >= {finest:.3g} Hz"):
        study.minimum_threshold(S, tolerance=tolerance)
    with pytest.raises(ValueError, match="tolerance"):
        lowest_threshold(S, tolerance=tolerance)


def test_the_finest_tolerance_is_reached() -> None:
    """At the finest tolerance allowed both searches end, and agree with a coarse one."""
    f_max = 20.0
    fine = study.frontier(S, [8.0], (12.0, f_max), num=41, tolerance=finest_tolerance(f_max))
    coarse = study.frontier(S, [8.0], (12.0, f_max), num=41, tolerance=1e-6)
    np.testing.assert_allclose(fine["frontier_frequency"], coarse["frontier_frequency"],
                               rtol=0, atol=1e-6)
    assert float(fine["frontier_bracket"].max()) <= finest_tolerance(f_max)
    low = study.minimum_threshold(S, tolerance=finest_tolerance(2 * S.f0))
    high = study.minimum_threshold(S, tolerance=1e-6)
    np.testing.assert_allclose(float(low["f_min"]), float(high["f_min"]), rtol=0, atol=1e-5)


def test_frontier_from_grid_refuses_the_same() -> None:
    f = np.array([13.0, 14.0])
    with pytest.raises(ValueError, match="tolerance = 1e-15"):
        frontier_from_grid(S, f, [8.0], np.zeros((2, 1)), np.zeros((2, 1)), tolerance=1e-15)


def test_a_spec_uses_the_same_rule() -> None:
    from study.engine.spec_files import SpecError
    from study.studies.spec import parse_spec

    text = ('[study]\nname = "x"\nobservables = ["frontier"]\n[structure]\n'
            "f0 = 14.44\nQ = 17.5\nalpha = 64.0\nM = 0.08\ncs = 0.25\n"
            "[sweep]\nf = { start = 12.0, stop = 20.0, num = 5 }\na = { values = [8.0] }\n"
            "[solver]\nfrontier_tolerance = 1e-12\n")
    parse_spec(text)  # 1e-12 > finest_tolerance(20)
    with pytest.raises(SpecError, match=f"allowed: >= {finest_tolerance(1e6):.3g} Hz"):
        parse_spec(text.replace("stop = 20.0", "stop = 1000000.0"))


# -- f_range and num ----------------------------------------------------------------------

@pytest.mark.parametrize("f_range", [
    (np.datetime64(10, "s"), np.datetime64(20, "s")),  # a TypeError traceback before
    ("10", "20"),  # read as 10 and 20 before
    (20.0, 10.0), (0.0, 10.0), (-5.0, 10.0), (10.0, math.inf), (math.nan, 10.0),
    (10.0,), (1.0, 2.0, 3.0), None, 5.0, {"x": 1},
])
def test_a_bad_f_range_names_f_range(f_range) -> None:
    with pytest.raises(ValueError, match="f_range"):
        study.frontier(S, [8.0], f_range, num=5)
    if f_range is not None:  # None is minimum_threshold's default range
        with pytest.raises(ValueError, match="f_range"):
            study.minimum_threshold(S, f_range)


@pytest.mark.parametrize("num", [1, 0, -3, 2.5, "5", None, True, MAX_SCAN_POINTS + 1, 2**70])
def test_a_bad_num_names_num(num) -> None:
    with pytest.raises(ValueError, match="num"):
        study.frontier(S, [8.0], (12.0, 16.0), num=num)


def test_a_scan_too_large_to_hold_is_refused_before_any_work() -> None:
    with pytest.raises(ValueError, match="num x a = 5000000 x 3 scanning points"):
        study.frontier(S, [6.0, 7.0, 8.0], (12.0, 16.0), num=5_000_000)


def test_a_frontier_needs_1d_accelerations() -> None:
    with pytest.raises(ValueError, match="a must be a scalar or 1-D"):
        study.frontier(S, np.ones((2, 2)), (12.0, 16.0), num=5)


# -- solver budgets -----------------------------------------------------------------------

@pytest.mark.parametrize("name", ["max_events", "max_map_iterations"])
@pytest.mark.parametrize("value", [2**63, 2**62, np.iinfo(np.int64).max, 10**18,
                                   1_000_001])
def test_a_budget_beyond_its_maximum_is_refused(name, value) -> None:
    """2**63 wrapped to a negative int64 in the kernel and answered NOT_CONVERGED."""
    with pytest.raises(ValueError, match=f"'{name}' must be an integer >= 1 and <= 1000000"):
        study.SolverSettings(**{name: value})


def test_the_largest_budget_is_accepted_and_changes_nothing() -> None:
    largest = study.SolverSettings(**MAX_SOLVER_BUDGET)
    v, status = study.steady_velocity(S, 14.0, 8.0, largest)
    v0, status0 = study.steady_velocity(S, 14.0, 8.0)
    assert status == status0 == study.Status.STICK_SLIP
    assert v == v0  # the budget bounds pathological points only


def test_the_spec_schema_maxima_are_the_solver_maxima() -> None:
    solver = spec_schema()["properties"]["solver"]["properties"]
    assert {k: solver[k]["maximum"] for k in MAX_SOLVER_BUDGET} == MAX_SOLVER_BUDGET


@pytest.mark.parametrize("bad", ["x", 3, {"max_events": 5}, study.Structure])
def test_settings_of_another_type_name_settings(bad) -> None:
    for call in (lambda: study.steady_state(S, 14.0, 8.0, bad),
                 lambda: study.steady_velocity(S, 14.0, 8.0, bad),
                 lambda: study.frontier(S, [8.0], (12.0, 16.0), num=5, settings=bad)):
        with pytest.raises(TypeError, match=r"settings must be a study\.SolverSettings"):
            call()


# -- dates, times and structures ------------------------------------------------------------

DATE = np.datetime64("2020-01-01")


@pytest.mark.parametrize("call", [
    lambda: study.steady_state(S, DATE, 8.0),
    lambda: study.steady_velocity(S, DATE, 8.0),
    lambda: study.thresholds(S, DATE),
    lambda: study.lift_off_acceleration(S, DATE),
    lambda: study.mode_response(S, DATE),
    lambda: study.force_amplitudes(S, DATE, 8.0),
    lambda: study.normal_force(S, DATE, 8.0, 0.0),
    lambda: study.tangential_force(S, DATE, 8.0, 0.0),
    lambda: study.compute_map(S, [DATE], [8.0]),
    lambda: study.frontier(S, [8.0], (DATE, DATE)),
    lambda: study.minimum_threshold(S, (DATE, DATE)),
], ids=["steady_state", "steady_velocity", "thresholds", "lift_off_acceleration",
        "mode_response", "force_amplitudes", "normal_force", "tangential_force",
        "compute_map", "frontier", "minimum_threshold"])
def test_a_date_is_never_a_frequency(call) -> None:
    with pytest.raises(InputTypeError, match=r"(f|f_range\[0\]) must be (a )?real number"):
        call()


@pytest.mark.parametrize("t", ["0.1", np.datetime64(1, "s"), math.nan, [0.0, math.inf]])
def test_a_time_that_is_not_a_finite_number_names_t(t) -> None:
    for force in (study.normal_force, study.tangential_force):
        with pytest.raises(ValueError, match="time t"):
            force(S, 14.0, 8.0, t)


@pytest.mark.parametrize("function", [
    study.thresholds, study.lift_off_acceleration, study.mode_response])
@pytest.mark.parametrize("bad", [None, "S", {"f0": 14.0}, 14.44])
def test_a_structure_of_another_type_names_structure(function, bad) -> None:
    """An AttributeError ('NoneType' object has no attribute 'g') before."""
    with pytest.raises(TypeError, match=r"structure must be a study\.Structure"):
        function(bad, 14.0)


@pytest.mark.parametrize("bad", [None, "S"])
def test_the_force_functions_name_structure(bad) -> None:
    for call in (lambda: study.force_amplitudes(bad, 14.0, 8.0),
                 lambda: study.normal_force(bad, 14.0, 8.0, 0.0),
                 lambda: study.tangential_force(bad, 14.0, 8.0, 0.0)):
        with pytest.raises(TypeError, match=r"structure must be a study\.Structure"):
            call()


# -- the disk, the integrator and the planner ---------------------------------------------

def _disk():
    from study.model.disk import Disk, Plate

    return Disk(radius=0.02, plates=(Plate(14.44, 17.5, 64.0, 0.08, 0.0, (0.005, 0.0)),),
                cs=0.25)


@pytest.mark.parametrize("f", [1e-300, 5e-324, 1e-101, 1e300, 1e4 * (1 + 1e-15)])
def test_a_disk_drive_outside_the_finite_physics_names_f(f) -> None:
    """periodic_motion(f=1e-300) ended in a ZeroDivisionError, f=1e300 in an
    OverflowError; contact_margins and disk_limits in an OverflowError."""
    from study.analyses.design_margins import disk_limits
    from study.scenes.planar_model import contact_margins, periodic_motion

    for call in (lambda: periodic_motion(_disk(), f, 7.0, max_periods=2),
                 lambda: contact_margins(_disk(), f, 7.0, samples=8),
                 lambda: disk_limits(_disk(), f, samples=8)):
        with pytest.raises(ValueError, match=r"^f = .* is out of range; allowed: finite and "
                                             r">= 1e-100 Hz and <= 10000 Hz"):
            call()


def test_the_lowest_disk_drive_is_computed() -> None:
    from study.scenes.planar_model import contact_margins
    from study.solvers.planar import MIN_DISK_FREQUENCY

    rim, normal = contact_margins(_disk(), MIN_DISK_FREQUENCY, 7.0, samples=8)
    assert math.isfinite(rim) and math.isfinite(normal)


def test_a_short_calibration_keeps_its_default_orbit_length() -> None:
    """max_periods = 2 is schema-valid for a calibration: the default max_orbit_period
    (8) is bounded by its own maximum, not by max_periods."""
    from study.scenes.planar_model import periodic_motion

    motion = periodic_motion(_disk(), 14.2, 7.0, max_periods=2)
    assert motion.periods <= 2


@pytest.mark.parametrize(("name", "value", "largest"), [
    ("max_steps", 2**62, 1_000_000_000), ("max_periods", 10**9, 100_000),
    ("steps_per_period", 10**6, 10_000), ("max_orbit_period", 10**4, 1000)])
def test_integrator_budgets_are_bounded_as_in_a_spec(name, value, largest) -> None:
    from study.solvers.integrator import IntegratorSettings, integrator_budget_maxima

    assert integrator_budget_maxima()[name] == largest
    IntegratorSettings(**{name: largest})
    with pytest.raises(ValueError, match=f"'{name}' = {value} is out of range; allowed: an "
                                         f"integer >= 1 and <= {largest}"):
        IntegratorSettings(**{name: value})


@pytest.mark.parametrize("max_events", [2**40, -1, 1.5, math.inf, "10"])
def test_recorded_events_are_bounded(max_events) -> None:
    """2**40 allocated terabytes; inf ended in an OverflowError."""
    from study.solvers.integrator import Schedule, simulate
    from study.solvers.planar import simulate_planar

    schedule = Schedule(np.array([14.2]), np.array([7.0]), np.array([0.1]))
    with pytest.raises(ValueError, match="max_events"):
        simulate_planar(_disk(), schedule, max_events=max_events)
    with pytest.raises(ValueError, match="max_events"):
        simulate(S, schedule, max_events=max_events)


def test_the_planner_bounds_its_loops_and_names_its_arguments() -> None:
    from study.scenes.planner import MAX_PLAN_ITERATIONS, Command, plan_leg, refined_legs

    commands = {name: Command(name, 14.0, 7.0, 0.01, 0.0, 0.1) for name in
                ("forward", "backward", "left", "right")}
    with pytest.raises(ValueError, match="iterations = 100001 is out of range"):
        plan_leg((0.0, 0.0, 0.0), (0.01, 0.0), commands, MAX_PLAN_ITERATIONS + 1)
    with pytest.raises(ValueError, match="commands must hold forward, backward, left, right; "
                                         "missing: backward, left, right"):
        plan_leg((0.0, 0.0, 0.0), (0.01, 0.0), {"forward": commands["forward"]})
    with pytest.raises(ValueError, match="pose must be 3 finite numbers"):
        plan_leg([], (0.01, 0.0), commands)  # an IndexError before
    state = np.zeros(8)
    with pytest.raises(ValueError, match="iterations = 4611686018427387904 is out of range"):
        refined_legs(_disk(), state, 0.0, (0.01, 0.0), commands, iterations=2**62)


@pytest.mark.parametrize("call", [
    lambda: __import__("study.analyses.selection", fromlist=["x"]).select(None, ["f=1"]),
    lambda: __import__("study.analyses.selection", fromlist=["x"]).available(None),
    lambda: __import__("study.analyses.export", fromlist=["x"]).tables(None),
    lambda: __import__("study.solvers.planar", fromlist=["x"]).state_names(None),
    lambda: __import__("study.model.disk", fromlist=["x"]).describe_disk(None),
    lambda: __import__("study.solvers.integrator",
                       fromlist=["x"]).steady_mode_state(None, 14.0, 8.0),
], ids=["select", "available", "tables", "state_names", "describe_disk", "steady_mode_state"])
def test_none_for_the_main_argument_names_it(call) -> None:
    """Each ended in "AttributeError: 'NoneType' object has no attribute ..."."""
    with pytest.raises(TypeError, match=r"^(dataset|disk|structure) must be "):
        call()


@pytest.mark.parametrize("parse", ["study.analyses.fit_spec.parse_fit_spec",
                                   "study.analyses.design_spec.parse_design_spec"])
def test_a_spec_text_that_is_not_text_is_refused(parse) -> None:
    import importlib

    module, name = parse.rsplit(".", 1)
    with pytest.raises(TypeError, match="the spec text must be a string"):
        getattr(importlib.import_module(module), name)(None)


@pytest.mark.parametrize("duration", [1e12, 1e300])
def test_a_default_output_grid_too_large_to_hold_is_refused(duration) -> None:
    """A 1e12 s schedule asked simulate for 6.4 PiB (MemoryError); 1e300 s ended in
    numpy's "Maximum allowed size exceeded"."""
    from study.solvers.integrator import MAX_OUTPUT_SAMPLES, Schedule, simulate
    from study.solvers.planar import simulate_planar

    schedule = Schedule(np.array([14.0]), np.array([8.0]), np.array([duration]))
    for run in (lambda: simulate(S, schedule), lambda: simulate_planar(_disk(), schedule)):
        with pytest.raises(ValueError, match=r"the default output_times .* samples; allowed "
                                             rf"at most {re.escape(f'{MAX_OUTPUT_SAMPLES:.3g}')}"):
            run()
    with pytest.raises(TypeError, match=r"output_times must be real numbers \[s\]"):
        simulate(S, schedule, output_times=["0.1"])

"""The fold_curves observable (:mod:`study.solvers.fold_curves`): each hop's fold where
a slow sweep along the study's f jumps, continued over its a axis.

Each curve is checked against what it does not use: study.bifurcation_curve's curve of
the same fold (from a branch of its own, at its own samples), the bracket of a fine slow
sweep, and the measured backward fold at M = 0.95. Its phase is kept like the frontier:
a rerun reuses it, another f axis computes it again.
"""

from __future__ import annotations

import signal
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

import study
from study.engine.interrupts import RunInterrupted
from study.engine.runner import run_study
from study.engine.spec_files import SpecError
from study.engine.validation import seal
from study.engine.validation.files import validate_file
from study.model.bifurcations import kind_named
from study.solvers import fold_curves as fold_module
from study.solvers.exact import steady_state
from study.solvers.integrator import Schedule, simulate
from study.solvers.protocol import slow_sweep
from study.solvers.settings import SolverSettings
from study.studies.spec import parse_spec
from tests.support.sealed_results import rewrite

M099 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
M095 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.95, cs=0.25)
FOLD = kind_named("fold").code
DOUBLING = kind_named("period_doubling").code
DOUBLING_STATUS = dict(zip(fold_module.DOUBLING_STATUS_FLAGS, range(4), strict=True))
F = np.linspace(12.0, 17.0, 11)
STATUS = dict(zip(fold_module.FOLD_STATUS_FLAGS, range(4), strict=True))
END = dict(zip(fold_module.FOLD_END_FLAGS, fold_module.FOLD_END_VALUES, strict=True))


@pytest.fixture(scope="module")
def m099():
    """The M = 0.99 map with flight over a = 7.5, 8, 10, 11 (the cusp below 8)."""
    return study.compute_map(M099, F, [7.5, 8.0, 10.0, 11.0],
                             observables=["velocity", "fold_curves"], coupling="two-way",
                             flight=True)


def test_the_forward_fold_is_bifurcation_curves_and_ends_in_its_cusp(m099):
    forward = m099.sel(hop="forward")
    assert m099.fold_f.dims == ("hop", "a") and m099.fold_end.dims == ("hop", "curve_end")
    assert m099.fold_f.attrs["units"] == "Hz"
    assert forward.fold_status.values.tolist() == [STATUS["no_fold"]] + [STATUS["found"]] * 3
    # study.bifurcation_curve of the same fold from its own branch at a = 10.
    lead = slow_sweep(M099, [14.8, 15.4, 15.9], [10.0], along="f", direction="up",
                      flight=True)
    hop = study.branch(M099, 15.9, 10.0, along="f", to=16.2, flight=True,
                       start=lead.state.phase_state[-1, 0],
                       periods=int(lead.state.orbit_period[-1, 0]))
    fold = int(np.flatnonzero(hop.bifurcation_kind.values == FOLD)[0])
    down = study.bifurcation_curve(M099, hop, fold, to=8.0, num=3)
    up = study.bifurcation_curve(M099, hop, fold, to=11.0, num=2)
    expected = {float(a): (f, v) for curve in (down, up)
                for f, a, v in zip(curve.f.values, curve.a.values, curve.velocity.values,
                                   strict=True)}
    for a in (8.0, 10.0, 11.0):
        assert_allclose(forward.fold_f.sel(a=a).item(), expected[a][0], rtol=1e-9, atol=0)
        assert_allclose(forward.fold_velocity.sel(a=a).item(), expected[a][1], rtol=1e-7,
                        atol=0)
    assert_allclose(forward.fold_f.values[1:], [20.849, 16.0545378, 14.5603459], rtol=0,
                    atol=1e-3)
    # Below 8 m s-2 the fold vanishes in a cusp, bracketed; above, it reaches the axis.
    below, above = forward.fold_end.values
    assert (below, above) == (END["vanished"], END["reached"])
    last, past = forward.fold_end_last.values[0], forward.fold_end_past.values[0]
    assert 7.92 < past < last < 7.93 and last - past <= 1e-6 * last
    assert np.isnan(forward.fold_end_last.values[1]) and np.isnan(forward.fold_f.values[0])
    # No sweep down along 12-17 Hz leaves the backward hop at a fold, and where the
    # sweeps ride it to 12 Hz its branch followed on down to 7 Hz meets none: not found.
    backward = m099.sel(hop="backward")
    assert (backward.fold_status.values == STATUS["not_found"]).all()
    assert (backward.fold_end.values == END["not_found"]).all()
    assert np.isnan(backward.fold_f.values).all()


def test_the_forward_hops_period_doubling_is_bifurcation_curves(m099):
    assert m099.doubling_f.dims == ("a",) and m099.doubling_f.attrs["units"] == "Hz"
    assert m099.doubling_velocity.attrs["units"] == "m s-1"
    # Seeded at the forward fold's a = 10, continued down to 7.5 (below the fold's
    # cusp: the hop exists there, its fold does not) and up to 11, past where the
    # curve vanishes (it meets a grazing of the hop's branch near 10.73 m s-2).
    assert m099.doubling_status.values.tolist() == [DOUBLING_STATUS["found"]] * 3 + [
        DOUBLING_STATUS["no_doubling"]]
    assert np.isnan(m099.doubling_f.values[3]) and np.isnan(m099.doubling_velocity.values[3])
    # study.bifurcation_curve of the same period doubling, from a branch of its own (the
    # release's forward hop at 12.5 Hz, continued down in f).
    hop = study.branch(M099, 12.5, 10.0, along="f", to=11.5, flight=True)
    doubling = int(np.flatnonzero(hop.bifurcation_kind.values == DOUBLING)[0])
    assert_allclose(hop.bifurcation_multiplier_modulus.values[doubling], 1.0, rtol=0,
                    atol=1e-8)
    assert_allclose(hop.bifurcation_multiplier_angle.values[doubling], np.pi, rtol=0,
                    atol=1e-8)
    curve = study.bifurcation_curve(M099, hop, doubling, to=7.5, num=6)
    for a in (7.5, 8.0, 10.0):
        k = int(np.flatnonzero(curve.a.values == a)[0])
        assert_allclose(m099.doubling_f.sel(a=a).item(), curve.f.values[k], rtol=1e-9,
                        atol=0)
        assert_allclose(m099.doubling_velocity.sel(a=a).item(), curve.velocity.values[k],
                        rtol=1e-7, atol=0)
        # The multiplier there is -1.
        assert_allclose(curve.multiplier_modulus.values[k], 1.0, rtol=0, atol=1e-8)
        assert_allclose(curve.multiplier_angle.values[k], np.pi, rtol=0, atol=1e-8)
    assert_allclose(m099.doubling_f.values[:3], [13.41124, 13.220089, 12.0305257], rtol=0,
                    atol=1e-6)
    # The forward hop moves forward at its doubling.
    assert (m099.doubling_velocity.values[:3] > 0).all()


def _period_velocities(f: float, state: np.ndarray, held: int = 400, last: int = 6
                       ) -> np.ndarray:
    """The integrator's mean velocity [m s-1] over each of the last ``last`` of ``held``
    drive periods at ``(f, 10 m s-2)`` from a phase-0 state ``(delta, delta', v, h,
    h')`` (x = 0)."""
    times = np.arange(held - last, held + 1) / f
    run = simulate(M099, Schedule(np.array([f]), np.array([10.0]), np.array([held / f])),
                   coupling="two-way", flight=True, output_times=times,
                   initial_state=np.array([state[0], state[1], 0.0, *state[2:]]))
    assert run.outcome == "completed"
    return np.diff(run.x) * f


def test_across_the_doubling_the_integrator_leaves_the_forward_hop_for_period_2(m099):
    doubling = m099.doubling_f.sel(a=10.0).item()
    inside, outside = doubling + 0.02, doubling - 0.02
    orbit = steady_state(M099, inside, 10.0, SolverSettings(), coupling="two-way",
                         flight=True)
    assert int(orbit.orbit_period) == 1
    state = np.asarray(orbit.phase_state, dtype=float).reshape(5)
    scale = 10.0 / (2 * np.pi * inside)
    # Inside, disturbed, the integrator comes back to the forward hop of period 1.
    disturbed = state.copy()
    disturbed[0] *= 1.001
    velocities = _period_velocities(inside, disturbed)
    assert_allclose(velocities / scale, float(orbit.velocity) / scale, rtol=0, atol=1e-7)
    # Past the doubling, carried there as a slow sweep down would, it leaves it for a
    # forward motion of period 2: one period's velocity alternates with the next's.
    velocities = _period_velocities(outside, state)
    assert (velocities > 0).all()
    assert_allclose(velocities[2:], velocities[:-2], rtol=1e-6, atol=0)
    assert np.abs(np.diff(velocities)).min() > 1e-3 * scale


def test_the_forward_fold_lies_in_a_fine_sweeps_bracket(m099):
    fine = np.round(np.arange(16.0, 16.0601, 0.0005), 6)
    f = np.unique(np.concatenate([np.round(np.arange(12.0, 16.0, 0.1), 6), fine]))
    swept = slow_sweep(M099, f, [10.0], along="f", direction="up", flight=True)
    i = int(np.flatnonzero(swept.jumped[:, 0] & (f >= 16.0))[0])
    fold = m099.fold_f.sel(hop="forward", a=10.0).item()
    assert f[i - 1] < fold < f[i] and f[i] - f[i - 1] == pytest.approx(0.0005, abs=1e-9)


def _stepped_velocities(steps: list[tuple[float, float]], state: np.ndarray,
                        held: int = 150, last: int = 4) -> np.ndarray:
    """The integrator's mean velocity [m s-1] over the last ``last`` drive periods of
    each step ``(f, a)`` [Hz, m s-2] of a stepped sweep, each held ``held`` periods, from
    a phase-0 state ``(delta, delta', v, h, h')`` (x = 0)."""
    f = np.array([step[0] for step in steps])
    a = np.array([step[1] for step in steps])
    ends = np.cumsum(held / f)
    times = np.concatenate([end - np.arange(last, -1, -1) / fk
                            for end, fk in zip(ends, f, strict=True)])
    run = simulate(M099, Schedule(f, a, held / f), coupling="two-way", flight=True,
                   output_times=times,
                   initial_state=np.array([state[0], state[1], 0.0, *state[2:]]))
    assert run.outcome == "completed"
    x = np.asarray(run.x).reshape(len(steps), last + 1)
    return (x[:, -1] - x[:, 0]) * f / last


def test_a_fold_no_sweep_meets_is_found_off_the_sweeps_and_the_integrator_agrees():
    # At 9 m s-2 a sweep down from 17 Hz starts on the forward hop and rides it to
    # 12 Hz: it never meets the backward hop, whose stable branch ends inside the grid.
    # The hop is carried there along a from 9.5 m s-2, where the sweep starts on it.
    f, a = np.linspace(12.0, 17.0, 11), [9.0, 9.5]
    found = study.compute_map(M099, f, a, observables=["velocity", "fold_curves"],
                              coupling="two-way", flight=True)
    backward = found.sel(hop="backward")
    swept = slow_sweep(M099, f, a, along="f", direction="down", flight=True)
    assert swept.state.velocity[-1, 0] > 0 > swept.state.velocity[-1, 1]
    assert not swept.jumped.any()
    assert (backward.fold_status.values == STATUS["found"]).all()
    fold = backward.fold_f.sel(a=9.0).item()
    assert_allclose(backward.fold_f.values, [13.1110140, 9.4640998], rtol=0, atol=1e-6)
    assert (backward.fold_velocity.values < 0).all()
    # The integrator's stepped sweep, from the backward hop at (17 Hz, 9.5 m s-2): down
    # in a to 9, then down in f. It rides the backward hop to 0.02 Hz above the fold and
    # leaves it for the forward hop 0.02 Hz below.
    hop = steady_state(M099, 17.0, 9.5, SolverSettings(), coupling="two-way", flight=True)
    assert float(hop.velocity) < 0
    steps = [(17.0, 9.5), (17.0, 9.25), (17.0, 9.0), *((f, 9.0) for f in (
        16.0, 15.0, 14.0, 13.5, fold + 0.1, fold + 0.02, fold - 0.02))]
    velocities = _stepped_velocities(steps, np.asarray(hop.phase_state, dtype=float).ravel())
    assert (velocities[:-1] < 0).all() and velocities[-1] > 0
    # Ridden up to there, the hop's velocity meets the fold's.
    assert_allclose(velocities[-2], backward.fold_velocity.sel(a=9.0).item(), rtol=0.05,
                    atol=0)


def test_a_fold_past_the_axis_is_the_curve_continued_from_inside_it():
    # At 10 m s-2 the sweeps down ride the backward hop to the axis's end: on a 10-17 Hz
    # axis its branch, followed past 10 Hz, folds at 6.08 Hz (the seed at this a). On a
    # 12-17 Hz axis with 9 m s-2 the curve is seeded at 9 (inside the grid) and
    # continued to 10: the same fold.
    past = study.compute_map(M099, np.linspace(10.0, 17.0, 8), [10.0],
                             observables=["velocity", "fold_curves"], coupling="two-way",
                             flight=True).sel(hop="backward")
    continued = study.compute_map(M099, np.linspace(12.0, 17.0, 11), [9.0, 10.0],
                                  observables=["velocity", "fold_curves"],
                                  coupling="two-way", flight=True).sel(hop="backward")
    assert (past.fold_status.values == STATUS["found"]).all()
    assert (continued.fold_status.values == STATUS["found"]).all()
    assert_allclose(past.fold_f.item(), continued.fold_f.sel(a=10.0).item(), rtol=1e-9,
                    atol=0)
    assert_allclose(past.fold_velocity.item(), continued.fold_velocity.sel(a=10.0).item(),
                    rtol=1e-7, atol=0)
    assert 6.0 < past.fold_f.item() < 6.2 and past.fold_velocity.item() < 0


def test_the_backward_hops_fold_at_m_095():
    found = study.compute_map(M095, np.linspace(11.0, 17.0, 13), [10.0],
                              observables=["velocity", "fold_curves"], coupling="two-way",
                              flight=True)
    assert (found.fold_status.values == STATUS["found"]).all()
    assert_allclose(found.fold_f.values[:, 0], [15.0575, 12.1499], rtol=0, atol=1e-4)
    forward, backward = found.fold_velocity.values[:, 0]
    assert forward > 0 > backward


SPEC = """
[study]
name = "kept-curves"
observables = ["velocity", "fold_curves"]
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.95
cs = 0.25
[sweep]
f = {{ start = 11.0, stop = 17.0, num = {num} }}
a = {{ values = [10.0, 10.5] }}
[solver]
coupling = "{coupling}"
flight = true
"""


def _spec(tmp_path: Path, num: int = 13, coupling: str = "two-way") -> Path:
    path = tmp_path / f"curves-{num}-{coupling}.toml"
    path.write_text(SPEC.format(num=num, coupling=coupling))
    return path


def test_a_rerun_reuses_the_curves_and_another_f_axis_computes_them(tmp_path, monkeypatch,
                                                                    capsys):
    calls: list[int] = []
    original = fold_module.slow_sweep

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(fold_module, "slow_sweep", counted)
    cache = tmp_path / "cache"
    study.run(_spec(tmp_path), tmp_path / "first.nc", cache=cache, workers=1)
    assert len(calls) == 2  # a sweep each way
    study.run(_spec(tmp_path), tmp_path / "second.nc", cache=cache, workers=1,
              progress=True)
    assert len(calls) == 2
    assert "fold curves of 1 of 1 structures reused" in capsys.readouterr().err
    with xr.open_dataset(tmp_path / "first.nc") as a, \
            xr.open_dataset(tmp_path / "second.nc") as b:
        for name in ("fold_f", "fold_velocity", "fold_status", "fold_end", "fold_end_last",
                     "fold_end_past", "doubling_f", "doubling_velocity", "doubling_status"):
            assert np.array_equal(a[name].values, b[name].values,
                                  equal_nan=a[name].dtype.kind == "f"), name
        assert list(a.hop.values) == ["forward", "backward"]
        assert_allclose(a.fold_f.sel(a=10.0).values, [15.0575, 12.1499], rtol=0, atol=1e-4)
        assert a.doubling_f.dims == ("a",)
    validate_file(tmp_path / "first.nc")  # raises on a problem
    # A file written before the doubling curve (without its variables) stays valid.
    earlier = rewrite(tmp_path / "first.nc", tmp_path / "earlier.nc",
                      drop=("doubling_f", "doubling_velocity", "doubling_status"))
    seal(earlier)
    assert validate_file(earlier) == "study result"
    study.run(_spec(tmp_path, num=25), tmp_path / "finer.nc", cache=cache, workers=1)
    assert len(calls) == 4


def test_a_solver_that_cannot_compute_the_curves_is_refused_naming_the_key(tmp_path):
    with pytest.raises(SpecError, match=r'observable "fold_curves" needs \[solver\] '
                       r'coupling = "two-way"'):
        parse_spec(SPEC.format(num=13, coupling="one-way").replace("flight = true", ""),
                   "one-way.toml")
    with pytest.raises(SpecError, match=r'\[sweep\] f has 1 value; the observable '
                       '"fold_curves"'):
        parse_spec(SPEC.format(num=1, coupling="two-way"), "one-f.toml")


def test_ctrl_c_in_the_curves_phase_keeps_the_map_and_the_rerun_finishes(
        tmp_path, monkeypatch, python_sigint):
    original = fold_module.slow_sweep

    def interrupting(*args, **kwargs):
        swept = original(*args, **kwargs)
        signal.raise_signal(signal.SIGINT)  # as Ctrl-C, after the first sweep
        return swept

    monkeypatch.setattr(fold_module, "slow_sweep", interrupting)
    spec, output, cache = _spec(tmp_path), tmp_path / "stop.nc", tmp_path / "cache"
    with pytest.raises(RunInterrupted) as stopped:
        study.run(spec, output, cache=cache, workers=1)
    assert stopped.value.kept == stopped.value.points == 26
    assert not output.exists()
    monkeypatch.undo()
    report = run_study(spec, output, cache=cache, progress=False, workers=1)
    assert (report.points_reused, report.points_computed) == (26, 0)
    with xr.open_dataset(output) as done:
        assert_allclose(done.fold_f.sel(a=10.0).values, [15.0575, 12.1499], rtol=0,
                        atol=1e-4)

"""The fold_curves observable (:mod:`study.solvers.fold_curves`): each hop's fold where
a slow sweep along the study's f jumps, continued over its a axis.

Each curve is checked against what it does not use: study.bifurcation_curve's curve of
the same fold (from a branch of its own, at its own samples), the bracket of a fine slow
sweep, and the measured backward fold at M = 0.95. Its phase is kept like the frontier:
a rerun reuses it, another f axis computes it again.
"""

from __future__ import annotations

import signal
import threading
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

import study
from study.engine.interrupts import RunInterrupted
from study.engine.runner import run_study
from study.engine.spec_files import SpecError
from study.engine.validation.files import validate_file
from study.model.bifurcations import kind_named
from study.solvers import fold_curves as fold_module
from study.solvers.protocol import slow_sweep
from study.studies.spec import parse_spec

M099 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
M095 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.95, cs=0.25)
FOLD = kind_named("fold").code
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
    # No sweep down along 12-17 Hz leaves the backward hop at a fold: not found.
    backward = m099.sel(hop="backward")
    assert (backward.fold_status.values == STATUS["not_found"]).all()
    assert (backward.fold_end.values == END["not_found"]).all()
    assert np.isnan(backward.fold_f.values).all()


def test_the_forward_fold_lies_in_a_fine_sweeps_bracket(m099):
    fine = np.round(np.arange(16.0, 16.0601, 0.0005), 6)
    f = np.unique(np.concatenate([np.round(np.arange(12.0, 16.0, 0.1), 6), fine]))
    swept = slow_sweep(M099, f, [10.0], along="f", direction="up", flight=True)
    i = int(np.flatnonzero(swept.jumped[:, 0] & (f >= 16.0))[0])
    fold = m099.fold_f.sel(hop="forward", a=10.0).item()
    assert f[i - 1] < fold < f[i] and f[i] - f[i - 1] == pytest.approx(0.0005, abs=1e-9)


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
                     "fold_end_past"):
            assert np.array_equal(a[name].values, b[name].values,
                                  equal_nan=a[name].dtype.kind == "f"), name
        assert list(a.hop.values) == ["forward", "backward"]
        assert_allclose(a.fold_f.sel(a=10.0).values, [15.0575, 12.1499], rtol=0, atol=1e-4)
    validate_file(tmp_path / "first.nc")  # raises on a problem
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


@pytest.fixture
def python_sigint():
    """SIGINT with Python's own handler, in the main thread (as tests/unit/
    test_work_units.py's)."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers run in the main thread only")
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


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

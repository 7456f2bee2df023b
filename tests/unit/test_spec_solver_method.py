"""``[solver] method`` and ``coupling`` in specs, and studies run by the time integrator."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from study import Structure
from study.engine.runner import run_study
from study.engine.store import open_result
from study.model.status import Status
from study.solvers.attractors import attractors
from study.solvers.exact import steady_state
from study.solvers.integrator import integrated_steady_state
from study.studies.spec import SpecError, parse_spec

BASE = """\
[study]
name = "method-under-test"
observables = ["velocity", "diagnostics"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = {{ start = 13.0, stop = 16.0, num = 4 }}
a = {{ start = 6.0, stop = 9.0, num = 3 }}

[solver]
{solver}
"""
PATH = "workflows/method-under-test.toml"


def parse(solver: str):
    return parse_spec(BASE.format(solver=solver), PATH)


def test_default_is_the_exact_solver_with_one_way_coupling():
    spec = parse("")
    assert (spec.method, spec.coupling) == ("exact", "one-way")
    assert spec.canonical["solver"]["method"] == "exact"


def test_two_way_coupling_defaults_to_the_exact_solver():
    spec = parse('coupling = "two-way"')
    assert (spec.method, spec.coupling) == ("exact", "two-way")
    assert spec.canonical["solver"]["method"] == "exact"
    assert spec.canonical["solver"]["coupling"] == "two-way"


def test_floquet_needs_the_exact_two_way_solver():
    spec = parse_spec(BASE.replace('"diagnostics"', '"floquet"')
                      .format(solver='coupling = "two-way"'), PATH)
    assert spec.observables == ("velocity", "floquet")
    for solver in ("", 'method = "integrator"\ncoupling = "two-way"'):
        with pytest.raises(SpecError) as caught:
            parse_spec(BASE.replace('"diagnostics"', '"floquet"').format(solver=solver), PATH)
        message = str(caught.value)
        for fragment in (PATH, '"floquet"', 'coupling = "two-way"', 'method = "exact"'):
            assert fragment in message, (fragment, message)


def test_integrator_settings_are_read():
    spec = parse('method = "integrator"\ntolerance = 1e-8\nmax_periods = 300')
    assert spec.integrator.tolerance == 1e-8
    assert spec.integrator.max_periods == 300
    assert spec.coupling == "one-way"


def test_method_changes_the_hash_spelled_defaults_do_not():
    assert parse("").sha256 == parse('method = "exact"\ncoupling = "one-way"').sha256
    assert parse("").sha256 != parse('method = "integrator"').sha256
    assert (parse('coupling = "two-way"').sha256
            == parse('method = "exact"\ncoupling = "two-way"\nmax_events = 10000').sha256)
    assert parse('coupling = "two-way"').sha256 != parse("").sha256
    assert (parse('method = "integrator"\ncoupling = "two-way"').sha256
            == parse('method = "integrator"\ncoupling = "two-way"\ntolerance = 1e-10').sha256)


@pytest.mark.parametrize(
    ("solver", "fragments"),
    [
        ('method = "rk4"', ["method", "exact", "integrator"]),
        ('coupling = "twoway"', ["coupling", "one-way", "two-way"]),
        ("tolerance = 1e-8", ["tolerance", '"exact"', "max_events"]),
        ('method = "integrator"\nmax_events = 10', ["max_events", '"integrator"', "tolerance"]),
        ('method = "integrator"\ntolerance = -1.0', ["tolerance"]),
        ('method = "integrator"\nsteps_per_period = 0', ["steps_per_period"]),
    ],
)
def test_bad_method_settings_are_refused_by_name(solver, fragments):
    with pytest.raises(SpecError) as caught:
        parse(solver)
    message = str(caught.value)
    assert PATH in message
    for fragment in fragments:
        assert fragment in message, (fragment, message)


def test_attractors_need_the_exact_solver():
    text = BASE.replace('"diagnostics"', '"attractors"')
    for solver in ("", 'coupling = "two-way"'):
        assert parse_spec(text.format(solver=solver), PATH).observables == (
            "velocity", "attractors")
    with pytest.raises(SpecError) as caught:
        parse_spec(text.format(solver='method = "integrator"'), PATH)
    for fragment in (PATH, '"attractors"', 'method = "exact"', '"integrator"'):
        assert fragment in str(caught.value), (fragment, str(caught.value))


def test_an_exact_two_way_study_holds_the_solvers_values(tmp_path):
    spec = tmp_path / "exact-two-way.toml"
    spec.write_text(BASE.replace('"diagnostics"', '"diagnostics", "floquet", "attractors"')
                    .format(solver='coupling = "two-way"\nchunk_points = 3'))
    run_study(spec, tmp_path / "exact-two-way.nc", progress=False, workers=2)
    dataset = open_result(tmp_path / "exact-two-way.nc")
    assert dataset.attrs["study_solver_method"] == "exact"
    assert dataset.attrs["study_coupling"] == "two-way"
    assert "two-way" in dataset.attrs["source"] and "Newton" in dataset.attrs["source"]
    paper = Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f = dataset["f"].values[:, None]
    a = dataset["a"].values[None, :]
    direct = steady_state(paper, f, a, coupling="two-way")
    np.testing.assert_array_equal(dataset["status"].values, direct.status)
    np.testing.assert_array_equal(dataset["velocity"].values, direct.velocity)
    np.testing.assert_array_equal(dataset["slips_per_period"].values, direct.slips_per_period)
    np.testing.assert_array_equal(dataset["floquet_multiplier"].values,
                                  direct.floquet_multiplier)
    found = attractors(paper, f, a, coupling="two-way")
    np.testing.assert_array_equal(dataset["attractor_count"].values, found.count)
    np.testing.assert_array_equal(dataset["attractor_velocity_spread"].values,
                                  found.velocity_spread)
    np.testing.assert_array_equal(dataset["attractor_starts_converged"].values,
                                  found.starts_converged)


@pytest.fixture(scope="module")
def two_way_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("two-way")
    spec = folder / "two-way.toml"
    spec.write_text(BASE.format(
        solver='method = "integrator"\ncoupling = "two-way"\nchunk_points = 3'))
    run_study(spec, folder / "two-way.nc", progress=False, workers=2)
    return open_result(folder / "two-way.nc")


def test_two_way_study_holds_the_integrators_values_and_says_so(two_way_run):
    dataset = two_way_run
    assert dataset.attrs["study_solver_method"] == "integrator"
    assert dataset.attrs["study_coupling"] == "two-way"
    assert "two-way" in dataset.attrs["source"]
    provenance = json.loads(dataset.attrs["provenance"])
    assert provenance["run"]["solver_settings"]["coupling"] == "two-way"
    paper = Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f = dataset["f"].values[:, None]
    a = dataset["a"].values[None, :]
    direct = integrated_steady_state(paper, f, a, coupling="two-way")
    assert np.array_equal(dataset["status"].values, direct.status)
    assert_allclose(dataset["velocity"].values, direct.velocity, rtol=0, atol=0)
    # Two-way coupling changes the numbers: not the exact one-way solver's result.
    one_way = steady_state(paper, f, a)
    moving = dataset["status"].values == Status.STICK_SLIP
    assert np.any(moving)
    assert np.max(np.abs(dataset["velocity"].values[moving] - one_way.velocity[moving])) > 1e-5


def test_integrator_method_reproduces_the_exact_study(tmp_path):
    text = BASE.format(solver='method = "integrator"\ntolerance = 1e-11')
    (tmp_path / "s.toml").write_text(text)
    run_study(tmp_path / "s.toml", tmp_path / "s.nc", progress=False, workers=1)
    integrated = open_result(tmp_path / "s.nc")
    exact_text = BASE.format(solver="")
    (tmp_path / "e.toml").write_text(exact_text)
    run_study(tmp_path / "e.toml", tmp_path / "e.nc", progress=False, workers=1)
    exact = open_result(tmp_path / "e.nc")
    assert exact.attrs["study_solver_method"] == "exact"
    assert np.array_equal(integrated["status"].values, exact["status"].values)
    assert_allclose(integrated["velocity"].values, exact["velocity"].values,
                    rtol=1e-7, atol=1e-12)
    assert Path(tmp_path / "s.nc").stat().st_size > 0

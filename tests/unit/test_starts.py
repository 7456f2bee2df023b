"""Named starts (issue 36, item 1): release, switch-on and a drop, each a physical
protocol, as a solver setting (``SolverSettings.start``, ``[solver] start``), a keyword
of the API and of the integrator, and recorded in every result.

The physics (docs/theory/starts.md): at M = 0.99, 13 Hz, 12 m s-2 with flight two
motions are stable; the release settles on a small forward hop (+0.0800 m/s), the
switch-on on a big backward hop (-0.1640 m/s). The exact solver, the project's
integrator and the independent event-driven reference (``tests/reference/flight.py``)
are each run from the same states.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import study
from study.kernels.start import RELEASE, SWITCH_ON, Start
from study.model.starts import START_ALLOWED, Drop, start_attributes, start_label
from study.model.status import Status
from study.solvers.exact import steady_state, steady_velocity
from study.solvers.integrator import integrated_steady_state
from study.solvers.settings import SolverSettings, kernel_start
from study.studies.checks import method_problems
from study.studies.layout import method_attributes, protocol_attributes
from study.studies.maps import compute_map
from study.studies.spec import SpecError, parse_spec
from tests.reference.flight import steady_motion

#: Two stable motions (the issue's point): a small forward hop and a big backward one.
BISTABLE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
F, A = 13.0, 12.0
FORWARD_HOP = 0.0800   # m/s, from the release (issue 36)
BACKWARD_HOP = -0.1640  # m/s, from the switch-on (issue 36)
PAPER = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)


def _solve(start, f=F, a=A, structure=BISTABLE, flight=True):
    return steady_state(structure, f, a, coupling="two-way", flight=flight, start=start)


# ---------------------------------------------------------------------------
# The two motions, from their starts, against independent solvers


def test_release_and_switch_on_reach_the_two_hops_of_the_issue():
    release = _solve("release")
    switch_on = _solve("switch-on")
    assert Status(int(release.status)) is Status.BOUNCING
    assert Status(int(switch_on.status)) is Status.BOUNCING
    assert_allclose(release.velocity, FORWARD_HOP, rtol=0, atol=5e-5)
    assert_allclose(switch_on.velocity, BACKWARD_HOP, rtol=0, atol=5e-5)


def test_both_starts_agree_with_the_event_driven_reference():
    """The reference's "rest" is the release, its "still" the switch-on (mode at rest at
    delta = delta' = 0, drive from phase 0): the same states, followed independently."""
    for start, reference in (("release", "rest"), ("switch-on", "still")):
        exact = _solve(start)
        other = steady_motion(BISTABLE, F, A, start=reference)
        assert other.status == "bouncing"
        assert_allclose(exact.velocity, other.velocity, rtol=1e-8, atol=0)


@pytest.mark.parametrize(("start", "expected"), [
    ("release", FORWARD_HOP),
    ("switch-on", BACKWARD_HOP),
    (Drop(0.002, 0.25), BACKWARD_HOP),
    (Drop(0.001, 0.0), FORWARD_HOP),
])
def test_every_start_agrees_with_the_integrator_from_the_same_state(start, expected):
    exact = _solve(start)
    integrated = integrated_steady_state(BISTABLE, F, A, coupling="two-way", flight=True,
                                         start=start)
    assert Status(int(integrated.status)) is Status.BOUNCING
    assert_allclose(exact.velocity, expected, rtol=0, atol=5e-5)
    assert_allclose(integrated.velocity, exact.velocity, rtol=1e-6, atol=0)


def test_switch_on_without_flight_agrees_with_the_integrator():
    """The paper's structure, two-way, on the table: the switch-on's transient decays
    onto the orbit the integrator reaches from all states 0."""
    f = np.array([13.0, 14.0, 15.5])
    a = np.array([6.0, 8.0, 9.0])
    exact = steady_state(PAPER, f, a, coupling="two-way", start="switch-on")
    integrated = integrated_steady_state(PAPER, f, a, coupling="two-way", start="switch-on")
    assert_array_equal(exact.status, integrated.status)
    assert_allclose(exact.velocity, integrated.velocity, rtol=1e-6, atol=1e-9)


def test_a_switch_on_that_never_slips_is_static():
    """Far below the thresholds the switch-on's transient cannot slip either: the motion
    settles on the stick, reported STATIC as a static release is."""
    switch_on = steady_state(PAPER, 14.0, 0.5, coupling="two-way", start="switch-on")
    release = steady_state(PAPER, 14.0, 0.5, coupling="two-way")
    assert Status(int(switch_on.status)) is Status.STATIC
    assert switch_on.velocity == 0.0
    assert_allclose(switch_on.floquet_multiplier, release.floquet_multiplier, rtol=1e-12)


def test_steady_velocity_gives_steady_state_s_velocity_from_each_start():
    f = np.array([12.5, 13.0, 13.5])
    for start in ("switch-on", Drop(0.002, 0.25)):
        v, status = steady_velocity(BISTABLE, f, A, coupling="two-way", flight=True,
                                    start=start)
        full = _solve(start, f=f)
        assert_array_equal(v, full.velocity)
        assert_array_equal(status, full.status)


# ---------------------------------------------------------------------------
# The default keeps every bit


def test_the_default_start_is_the_release_bit_for_bit():
    rng = np.random.default_rng(36)
    f = rng.uniform(11.0, 18.0, 24)
    a = rng.uniform(2.0, 14.0, 24)
    for structure, flight in ((BISTABLE, True), (PAPER, False)):
        plain = steady_state(structure, f, a, coupling="two-way", flight=flight)
        named = steady_state(structure, f, a, coupling="two-way", flight=flight,
                             start="release")
        settings = steady_state(structure, f, a, SolverSettings(start="release"),
                                coupling="two-way", flight=flight)
        for field in dataclasses.fields(plain):
            for other in (named, settings):
                assert_array_equal(getattr(other, field.name), getattr(plain, field.name),
                                   strict=True)
    integrated = integrated_steady_state(PAPER, f[:3], a[:3], coupling="two-way")
    named = integrated_steady_state(PAPER, f[:3], a[:3], coupling="two-way",
                                    start="release")
    assert_array_equal(named.velocity, integrated.velocity)


def test_the_kernel_starts():
    assert kernel_start("release") == RELEASE == Start(0.0, 1.0, 0.0)
    assert kernel_start("switch-on") == SWITCH_ON == Start(0.0, 0.0, 0.0)
    assert kernel_start(Drop(0.002, 0.25)) == Start(0.25, 0.0, 0.002)


# ---------------------------------------------------------------------------
# Settings and keywords: values and their errors


def test_a_drop_is_made_from_a_spec_s_table_and_labelled():
    settings = SolverSettings(start={"drop": 0.002, "phase": 0.25})
    assert settings.start == Drop(0.002, 0.25)
    assert SolverSettings(start={"drop": 0.001}).start == Drop(0.001, 0.0)
    assert start_label(Drop(0.002, 0.25)) == "drop 0.002 m at phase 0.25"
    assert start_attributes(Drop(0.002, 0.25)) == {
        "start": "drop 0.002 m at phase 0.25", "start_kind": "drop",
        "start_height": 0.002, "start_phase": 0.25}
    assert start_attributes("switch-on") == {"start": "switch-on", "start_kind": "switch-on"}


@pytest.mark.parametrize(("value", "words"), [
    ("switch_on", "'switch_on'"),
    ("", "''"),
    (3, "int: 3"),
    ({"drop": 0.002, "phaze": 0.5}, "unknown key 'phaze'"),
    ({"phase": 0.5}, "no key 'drop'"),
    ({"drop": -0.002}, "drop = -0.002 m"),
    ({"drop": 0.0}, "drop = 0.0 m"),
    ({"drop": 0.002, "phase": 1.0}, "phase = 1.0"),
    ({"drop": 0.002, "phase": -0.1}, "phase = -0.1"),
    ({"drop": "high"}, "drop must be a number"),
])
def test_a_bad_start_is_refused_naming_the_key_and_the_allowed_values(value, words):
    with pytest.raises(ValueError, match="start") as caught:
        SolverSettings(start=value)
    message = str(caught.value)
    assert words in message
    assert START_ALLOWED in message


def test_a_start_the_model_cannot_take_is_refused():
    with pytest.raises(ValueError, match="start 'switch-on' needs coupling='two-way'"):
        steady_state(PAPER, 14.0, 8.0, coupling="one-way", start="switch-on")
    with pytest.raises(ValueError, match="start 'switch-on' needs coupling='two-way'"):
        steady_velocity(PAPER, 14.0, 8.0, coupling="one-way",
                        settings=SolverSettings(start="switch-on"))
    with pytest.raises(ValueError, match=r"start 'drop 0.002 m at phase 0.0' needs "
                                         r"flight=True"):
        steady_state(PAPER, 14.0, 8.0, coupling="two-way", start=Drop(0.002))
    with pytest.raises(ValueError, match="needs flight=True"):
        integrated_steady_state(PAPER, 14.0, 8.0, coupling="two-way", start=Drop(0.002))
    with pytest.raises(ValueError, match="needs coupling='two-way'"):
        integrated_steady_state(PAPER, 14.0, 8.0, coupling="one-way", start="switch-on")


def test_keyword_and_settings_must_agree_and_continuation_is_refused():
    settings = SolverSettings(start="switch-on")
    same = steady_state(BISTABLE, F, A, settings, coupling="two-way", flight=True,
                        start="switch-on")
    assert_allclose(same.velocity, BACKWARD_HOP, rtol=0, atol=5e-5)
    with pytest.raises(ValueError, match="differ: give the start once"):
        steady_state(BISTABLE, F, A, settings, coupling="two-way", flight=True,
                     start=Drop(0.002))
    with pytest.raises(ValueError, match="with continuation = True"):
        SolverSettings(continuation=True, start="switch-on")
    with pytest.raises(ValueError, match="with continuation = True"):
        steady_state(PAPER, 14.0, 8.0, SolverSettings(continuation=True),
                     coupling="two-way", start="switch-on")


# ---------------------------------------------------------------------------
# Specs: the key, its errors, the fingerprint


SPEC = """[study]
name = "starts"
observables = ["velocity"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.99
cs = 0.25

[sweep]
f = {{ values = [12.5, 13.0] }}
a = {{ values = [12.0] }}

[solver]
coupling = "{coupling}"
{extra}
"""


def _spec(extra="", coupling="two-way"):
    return parse_spec(SPEC.format(coupling=coupling, extra=extra), "starts.toml")


def test_the_spec_key_takes_each_start_and_the_fingerprint_names_it_only_when_set():
    plain = _spec()
    release = _spec('start = "release"')
    switch_on = _spec('start = "switch-on"')
    drop = _spec('flight = true\nstart = { drop = 0.002, phase = 0.25 }')
    flown = _spec("flight = true")
    assert plain.solver.start == release.solver.start == "release"
    assert switch_on.solver.start == "switch-on"
    assert drop.solver.start == Drop(0.002, 0.25)
    assert "start" not in plain.canonical["solver"]
    assert release.sha256 == plain.sha256
    assert switch_on.sha256 != plain.sha256
    assert switch_on.canonical["solver"]["start"] == "switch-on"
    assert drop.canonical["solver"]["start"] == {"drop": 0.002, "phase": 0.25}
    assert drop.sha256 != flown.sha256


@pytest.mark.parametrize(("extra", "coupling", "words"), [
    ('start = "switch_on"', "two-way", "[solver] start: 'switch_on' does not match any "
                                       "allowed form"),
    ("start = 0.002", "two-way", "[solver] start: 0.002 does not match any allowed form"),
    ("start = { drop = 0.002, phaze = 0.5 }\nflight = true", "two-way",
     "unknown key 'phaze'; allowed keys: drop, phase"),
    ("start = { drop = -0.002 }\nflight = true", "two-way", "start.drop = -0.002 is out "
                                                            "of range"),
    ("start = { drop = 0.002, phase = 0.25 }", "two-way",
     "[solver] start = { drop = 0.002, phase = 0.25 } (drop 0.002 m at phase 0.25) needs "
     "flight = true"),
    ('start = "switch-on"', "one-way", '[solver] start = "switch-on" (switch-on) needs '
                                       'coupling = "two-way"'),
    ('start = "switch-on"\ncontinuation = true', "two-way",
     "'start' = 'switch-on' with continuation = True"),
    ('start = "switch-on"\nmethod = "integrator"', "two-way",
     '[solver] start do not apply to method = "integrator"'),
])
def test_a_bad_spec_start_is_refused_with_its_key(extra, coupling, words):
    with pytest.raises(SpecError) as caught:
        _spec(extra, coupling)
    assert words in str(caught.value)


# ---------------------------------------------------------------------------
# Results record their start


def test_every_result_records_its_start_and_old_files_mean_the_release():
    plain = _spec()
    assert protocol_attributes(plain) == {"study_start": "release",
                                          "study_start_kind": "release"}
    drop = _spec('flight = true\nstart = { drop = 0.002, phase = 0.25 }')
    assert protocol_attributes(drop) == {
        "study_start": "drop 0.002 m at phase 0.25", "study_start_kind": "drop",
        "study_start_height": 0.002, "study_start_phase": 0.25}
    # A file written before starts were named has none of them: the release.
    old = {k: v for k, v in method_attributes(plain).items() if not k.startswith("study_start")}
    assert method_problems(old, plain) == []
    switch_on = _spec('start = "switch-on"')
    old = {k: v for k, v in method_attributes(switch_on).items()
           if not k.startswith("study_start")}
    assert method_problems(old, switch_on) == [
        "study_start differs from the embedded spec ('switch-on')",
        "study_start_kind differs from the embedded spec ('switch-on')"]


def test_compute_map_takes_the_start_and_records_it():
    f, a = [12.5, 13.0], [12.0]
    released = compute_map(BISTABLE, f, a, observables=("velocity",), coupling="two-way",
                           flight=True)
    assert released.attrs["study_start"] == "release"
    assert "start" not in released.attrs["study_spec"]
    dropped = compute_map(BISTABLE, f, a, observables=("velocity",), coupling="two-way",
                          flight=True, start=Drop(0.002, 0.25))
    assert dropped.attrs["study_start"] == "drop 0.002 m at phase 0.25"
    assert dropped.attrs["study_start_kind"] == "drop"
    assert dropped.attrs["study_start_height"] == 0.002
    assert dropped.attrs["study_start_phase"] == 0.25
    assert parse_spec(dropped.attrs["study_spec"], "map.toml").solver.start == Drop(0.002,
                                                                                   0.25)
    direct = _solve(Drop(0.002, 0.25), f=np.array(f)[:, None], a=np.array(a)[None, :])
    assert_array_equal(dropped["velocity"].values, direct.velocity)


def test_a_drop_is_refused_beside_without_flight_and_the_paper_model_starts_by_release():
    with pytest.raises(SpecError, match="with the observable without_flight"):
        parse_spec(SPEC.format(coupling="two-way",
                               extra="flight = true\nstart = { drop = 0.002 }").replace(
            'observables = ["velocity"]', 'observables = ["velocity", "without_flight"]'),
            "starts.toml")
    f, a = [13.0, 14.0], [8.0]
    switched = compute_map(PAPER, f, a, observables=("velocity", "paper_model"),
                           coupling="two-way", start="switch-on")
    released = compute_map(PAPER, f, a, observables=("velocity", "paper_model"),
                           coupling="two-way")
    assert_array_equal(switched["velocity_one_way"].values,
                       released["velocity_one_way"].values)


def test_a_study_file_records_its_start_and_validates(tmp_path):
    spec = tmp_path / "starts.toml"
    spec.write_text(SPEC.format(coupling="two-way", extra='flight = true\nstart = "switch-on"'),
                    encoding="utf-8")
    result = study.run(spec, tmp_path / "starts.nc")
    assert result.attrs["study_start"] == "switch-on"
    assert result.attrs["study_start_kind"] == "switch-on"
    assert_allclose(result["velocity"].sel(f=13.0, a=12.0).item(), BACKWARD_HOP, rtol=0,
                    atol=5e-5)


def test_kept_values_of_one_start_are_never_lent_to_another():
    """The cache key (the method's canonical settings) names the start only when it is
    not the release: keys of values kept before starts were named are unchanged."""
    from study.studies.observables import Method

    released = Method(coupling="two-way", solver=SolverSettings()).canonical()
    assert "start" not in released
    switched = Method(coupling="two-way", solver=SolverSettings(start="switch-on")).canonical()
    assert switched == {**released, "start": "switch-on"}
    dropped = Method(coupling="two-way", flight=True,
                     solver=SolverSettings(start=Drop(0.002, 0.25))).canonical()
    assert dropped["start"] == {"drop": 0.002, "phase": 0.25}


def test_the_method_line_names_a_start_other_than_the_release():
    from study.engine.contact_attributes import method_summary

    released = method_attributes(_spec())
    assert "start" not in method_summary(released)
    switched = method_attributes(_spec('start = "switch-on"'))
    assert method_summary(switched).endswith(", start switch-on")
    dropped = method_attributes(_spec("flight = true\nstart = { drop = 0.002, phase = 0.25 }"))
    assert method_summary(dropped).endswith("start drop 0.002 m at phase 0.25")


def test_drops_below_lift_off_land_on_the_one_orbit_on_the_table():
    """The paper's structure below lift-off (8 m s-2) has one orbit on the table: every
    start reaches it, the drops after their landing (the flight kernel from the drop,
    the contact kernel from the release), and the integrator from the drop at half a
    period (simulated to phase 0 first)."""
    f = np.array([13.0, 14.0, 15.0])
    release = steady_state(PAPER, f, 8.0, coupling="two-way", flight=True)
    for start in ("switch-on", Drop(0.001, 0.0), Drop(0.0005, 0.5)):
        other = steady_state(PAPER, f, 8.0, coupling="two-way", flight=True, start=start)
        assert_array_equal(other.status, release.status)
        assert_array_equal(other.impacts_per_period, 0.0)
        assert_allclose(other.velocity, release.velocity, rtol=1e-9, atol=0)
    integrated = integrated_steady_state(PAPER, f, 8.0, coupling="two-way", flight=True,
                                         start=Drop(0.0005, 0.5))
    assert_array_equal(integrated.status, release.status)
    assert_allclose(integrated.velocity, release.velocity, rtol=1e-6, atol=0)


def test_an_integrated_drop_that_does_not_reach_phase_0_has_no_motion():
    from study.solvers.integrator import IntegratorSettings

    lost = integrated_steady_state(BISTABLE, F, A, coupling="two-way", flight=True,
                                   start=Drop(0.002, 0.25),
                                   settings=IntegratorSettings(max_steps=2))
    assert Status(int(lost.status)) is Status.NOT_CONVERGED
    assert np.isnan(lost.velocity)

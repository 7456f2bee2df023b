"""Defects the spec-run fuzz tier (tests/fuzz/test_spec_runs.py) found, one test each.

Each was a traceback, a hang or an unhelpful message of ``study run`` on a mutated
workflow; these tests pin the fix on the smallest spec that showed it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from study.cli import main
from study.engine.spec_files import SpecError
from study.scenes.scene_spec import MAX_TRAJECTORY_PERIODS, parse_scene, period_weight
from study.studies.spec import parse_spec

REPO = Path(__file__).resolve().parents[2]


def workflow(name: str) -> str:
    return (REPO / "workflows" / f"{name}.toml").read_text(encoding="utf-8")


def refusal(parse, text: str, path: str = "case.toml") -> str:
    with pytest.raises(SpecError) as excinfo:
        parse(text, path)
    message = str(excinfo.value)
    assert message.startswith(f"{path}: ")
    return message


# --------------------------------------------------------------------------- integers


@pytest.mark.parametrize(
    ("name", "old", "new", "key"),
    [
        # Was a TypeError in range() deep in the calibration.
        ("steering-calibration", "max_periods = 400", "max_periods = 400.0",
         "[calibration] max_periods"),
        ("steering-plan", "realisations = 4", "realisations = 4.0", "[plan] realisations"),
        ("steering-plan", "seed = 7", "seed = 7.0", "[plan] seed"),
        ("frontier", "num = 131", "num = 131.0", "[sweep] a"),
    ],
)
def test_a_float_where_an_integer_belongs_is_refused_by_the_schema(name, old, new, key):
    """JSON schema counts 400.0 as an integer; TOML does not, and neither do specs."""
    text = workflow(name)
    assert old in text
    parse = parse_scene if "[scene]" in text else parse_spec
    message = refusal(parse, text.replace(old, new))
    assert key in message
    assert "wrong type; expected integer" in message


def test_study_run_refuses_a_float_count_with_one_line(tmp_path, capsys):
    spec = tmp_path / "cal.toml"
    spec.write_text(workflow("steering-calibration").replace("max_periods = 400",
                                                             "max_periods = 60.0"))
    assert main(["run", str(spec), "-o", str(tmp_path / "out.nc"), "--no-progress"]) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith(f"study: {spec}: invalid scene spec:")
    assert "[calibration] max_periods: 60.0 has the wrong type; expected integer" in captured.err
    assert not (tmp_path / "out.nc").exists()


# --------------------------------------------------------------------------- messages


@pytest.mark.parametrize(
    ("old", "new", "where"),
    [
        ("Q = 17.5", "Q = " + "[" * 9 + "1" + "]" * 9, "at [structure] Q;"),
        ("a = { start = 0.0, stop = 12.0, num = 241 }",
         "a = { values = " + "[" * 12 + "1" + "]" * 12 + " }", "at [sweep] a.values;"),
        # Too deep for the TOML parser itself: found by a scan of the text.
        ("Q = 17.5", "Q = " + "[" * 3000 + "]" * 3000, "at line 9 (Q);"),
    ],
)
def test_too_deep_nesting_is_refused_naming_the_key(old, new, where):
    text = workflow("regime-map")
    assert old in text
    message = refusal(parse_spec, text.replace(old, new))
    assert "tables or arrays nested" in message
    assert where in message
    assert message.endswith("allowed at most 8 levels")


def test_a_missing_table_or_key_is_refused_naming_what_is_required():
    text = workflow("frontier")
    message = refusal(parse_spec, text.replace("[structure]", "[structures]"))
    assert "top level: 'structure' is a required property; required tables: study, " \
           "structure, sweep" in message
    # Not the schema's whole description: one line per problem.
    assert "declarative" not in message
    message = refusal(parse_scene, workflow("steering").replace("radius = 0.02", ""))
    assert "[disk]: 'radius' is a required property; required keys: radius, cs" in message


# --------------------------------------------------------------------------- study ranges


@pytest.mark.parametrize(
    ("old", "new", "fragment"),
    [
        # Was a RuntimeWarning (overflow in sin(alpha)/cs), an error under -W error.
        ("cs = 0.25", "cs = 5e-324", "[structure] cs = 5e-324 is out of range; allowed: >= 1e-06"),
        ("cs = 0.25", "cs = 0.25\nck = 1e-300", "[structure] ck = 1e-300 is out of range"),
        # Was a hang: the two-way integrator's steps follow Q / (pi f0).
        ("Q = 17.5", "Q = 1e-06", "[structure] Q = 1e-06 is out of range; allowed: >= 0.01"),
    ],
)
def test_absurd_structure_values_are_refused(old, new, fragment):
    assert fragment in refusal(parse_spec, workflow("coupling").replace(old, new, 1))


def test_swept_values_obey_the_same_minimum():
    text = workflow("threshold-collapse").replace("[3.0, 10.0, 17.5, 50.0, 150.0]",
                                                  "[0.001, 10.0]")
    assert ("invalid structure at [sweep] point Q = 0.001, M = 0.002: Structure parameter "
            "'Q' = 0.001 is out of range; allowed: 0.01 <= Q <= 1e6") in refusal(parse_spec, text)


# --------------------------------------------------------------------------- scenes


@pytest.mark.parametrize(
    ("name", "old", "new", "fragment"),
    [
        # Was a ZeroDivisionError in the integrator (the radius squared underflows).
        ("steering", "radius = 0.02 ", "radius = 1e-300 #",
         "[disk] radius = 1e-300 is out of range; allowed: >= 0.0001"),
        # Was a hang: a calibration point at Q = 1e-6 did not end in a minute.
        ("steering-calibration", "Q = 10.0", "Q = 1e-06",
         "[plate #2] Q = 1e-06 is out of range; allowed: >= 0.01"),
        ("steering", "cs = 0.25 ", "cs = 5e-324 #", "[disk] cs = 5e-324 is out of range"),
    ],
)
def test_absurd_disk_and_plate_values_are_refused(name, old, new, fragment):
    text = workflow(name)
    assert old in text
    assert fragment in refusal(parse_scene, text.replace(old, new, 1))


def test_a_calibration_far_below_the_plates_resonance_is_refused_before_work():
    # Was a hang: at 1e-12 Hz each period ran the integrator to its step budget (42 s).
    text = workflow("steering-calibration").replace(
        "f = { start = 6.0, stop = 16.0, num = 81 }", "f = { values = [1e-12, 7.0, 8.0] }")
    message = refusal(parse_scene, text)
    assert "[calibration] f: 3 x 4 points x max_periods = 400 from 1e-12 Hz, below the " \
           "plates' f0 up to 14.44 Hz" in message
    assert "drive periods of work; allowed at most 1e+07: higher f" in message
    # The workflow itself weighs little more than its periods.
    spec = parse_scene(workflow("steering-calibration"), "cal.toml")
    weight = period_weight(spec.options["f"], spec.disk)
    assert 1.0 < weight.min() and weight.max() < 1.07


def test_a_trajectory_of_absurd_drive_time_is_refused_though_its_samples_are_few():
    text = workflow("steering").replace("sample_interval = 0.05", "sample_interval = 1000.0")
    text = text.replace("duration = 8.0", "duration = 1000000.0")
    message = refusal(parse_scene, text)
    assert "[[segment]] duration x f: the schedule's" in message
    assert f"allowed at most {MAX_TRAJECTORY_PERIODS:.3g}: shorter segments" in message
    assert parse_scene(workflow("steering"), "steering.toml").kind == "trajectory"



# --------------------------------------------------------------------------- titles


@pytest.mark.parametrize("name", ["thresholds", "steering"])
def test_an_empty_title_is_refused_before_any_work(name, tmp_path, capsys):
    """Was computed in full, then refused by the result's own validation, naming the
    temporary file rather than the spec."""
    spec = tmp_path / f"{name}.toml"
    spec.write_text(workflow(name).replace('title = "', 'title = "" # "', 1))
    assert main(["run", str(spec), "-o", str(tmp_path / "out.nc"), "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"study: {spec}: invalid ")
    assert "title: '' should be non-empty" in err
    assert not any(tmp_path.glob("*.nc*"))

"""Scene specs refused cleanly: wrong types, huge or non-finite values, implausible disks,
absurd sizes, each named by file, key and what is allowed; and the scene module's
place in the pipeline (it computes, it does not store).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import study.scenes.scene_kind
import study.scenes.scene_run
import study.scenes.scene_spec
from study.engine.spec_files import SpecError
from study.scenes.scene_kind import scene_dataset
from study.scenes.scene_run import MAX_PLAN_DRIVE_SECONDS
from study.scenes.scene_spec import (
    MAX_CALIBRATION_PERIODS,
    MAX_SCENE_SAMPLES,
    SceneError,
    parse_scene,
)

REPO = Path(__file__).resolve().parents[2]
TRAJECTORY = (REPO / "workflows" / "steering.toml").read_text(encoding="utf-8")
CALIBRATION = (REPO / "workflows" / "steering-calibration.toml").read_text(encoding="utf-8")
PLAN = (REPO / "workflows" / "steering-plan.toml").read_text(encoding="utf-8")
PATH = "workflows/edited.toml"


def _replace(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


REFUSALS = [
    # wrong types
    pytest.param(TRAJECTORY, "start = [0.0, 0.0, 90.0] # x",
                 'seed = "abc"\nstart = [0.0, 0.0, 90.0] #',
                 ["[trajectory] seed: 'abc' has the wrong type; expected integer"],
                 id="seed-string"),
    pytest.param(CALIBRATION, "a = { values = [5.0, 6.0, 7.0, 8.0] }", "a = { values = ['x'] }",
                 ["[calibration] a.values[0]: 'x' has the wrong type; expected number",
                  "allowed forms"], id="axis-values-strings"),
    pytest.param(TRAJECTORY, "f0 = 14.44 ", 'f0 = "14.44" ',
                 ["[plate #1] f0: '14.44' has the wrong type; expected number"], id="f0-string"),
    pytest.param(TRAJECTORY, "attachment = [0.005, 0.0]", "attachment = [0.005]",
                 ["[plate #1] attachment: [0.005] is too short", "[forward (m), left (m)]"],
                 id="attachment-short"),
    pytest.param(PLAN, "waypoints = [[0.0, 0.08],", "waypoints = [0.0, [0.0, 0.08],",
                 ["[plan] waypoints[0]: 0.0 has the wrong type; expected array"],
                 id="waypoint-not-a-pair"),
    pytest.param(PLAN, "realisations = 4", "realisations = 4.5",
                 ["[plan] realisations: 4.5 has the wrong type; expected integer"],
                 id="realisations-float"),
    pytest.param(TRAJECTORY, "[disk]", "disk = 3\n[disk_]",
                 ["top level: unknown key 'disk_'", "allowed keys:"], id="table-renamed"),
    # huge, tiny and non-finite values
    pytest.param(TRAJECTORY, "f0 = 14.44 ", "f0 = 1e300 ",
                 ["[plate #1] f0 = 1e+300 is out of range; allowed: > 0 and <= 10000"],
                 id="f0-1e300"),
    pytest.param(TRAJECTORY, "Q = 17.5", "Q = 1e300",
                 ["[plate #1] Q = 1e+300 is out of range; allowed: >= 0.01 and <= 10000"],
                 id="Q-huge"),
    pytest.param(TRAJECTORY, "radius = 0.02 ", "radius = nan ",
                 ["[disk] radius = nan is not a finite number"], id="radius-nan"),
    pytest.param(TRAJECTORY, "duration = 8.0", "duration = inf",
                 ["[segment #1] duration = inf is not a finite number"], id="duration-inf"),
    pytest.param(TRAJECTORY, "duration = 8.0", "duration = 1e300",
                 ["[segment #1] duration = 1e+300 is out of range; allowed: > 0 and <= 1000000"],
                 id="duration-huge"),
    pytest.param(TRAJECTORY, "tolerance = 1e-9", "tolerance = 1e-300",
                 ["[integrator] tolerance = 1e-300 is out of range; allowed: >= 1e-14"],
                 id="tolerance-tiny"),
    pytest.param(CALIBRATION, "num = 81 }", "num = 100000000000 }",
                 ["[calibration] f", "10000000"], id="num-huge"),
    pytest.param(PLAN, "realisations = 4", "realisations = 1000000000",
                 ["[plan] realisations = 1000000000 is out of range; allowed: >= 0 and <= 100"],
                 id="realisations-huge"),
    pytest.param(PLAN, "seed = 7", "seed = -7",
                 ["[plan] seed = -7 is out of range; allowed: >= 0"], id="seed-negative"),
    pytest.param(PLAN, "waypoints = [[0.0, 0.08],", "waypoints = [[0.0, 1e300],",
                 ["[plan] waypoints[0][1] = 1e+300 is out of range; allowed: >= -1000 and <= 1000"],
                 id="waypoint-huge"),
    # the disk must be physically plausible
    pytest.param(TRAJECTORY, "cs = 0.25 ", "cs = 0.25\ngyration_radius = 1000\n#",
                 ["[disk] gyration_radius = 1000", "radius/4 to radius"], id="gyration-1000"),
    pytest.param(TRAJECTORY, "cs = 0.25 ", "cs = 0.25\ngyration_radius = 0.021\n#",
                 ["[disk] gyration_radius = 0.021 m is out of range; allowed: radius/4 to radius "
                  "(0.005 to 0.02 m"], id="gyration-above-radius"),
    pytest.param(TRAJECTORY, "cs = 0.25 ", "cs = 0.25\ngyration_radius = 0.002\n#",
                 ["[disk] gyration_radius = 0.002 m is out of range"], id="gyration-light"),
    pytest.param(TRAJECTORY, "cs = 0.25 ", "cs = 0.25\nfriction_length = 0.03\n#",
                 ["[disk]: Disk: friction_length = 0.03 m is out of range; allowed: radius/1000 "
                  "to radius (2e-05 to 0.02 m"],
                 id="friction-length-above-radius"),
    # a length a double divides by (ZeroDivisionError before), or one too short to run
    pytest.param(TRAJECTORY, "cs = 0.25 ", "cs = 0.25\nfriction_length = 1e-300\n#",
                 ["[disk]: Disk: friction_length = 1e-300 m is out of range; allowed: "
                  "radius/1000 to radius (2e-05 to 0.02 m"], id="friction-length-1e-300"),
    pytest.param(TRAJECTORY, "cs = 0.25 ", "cs = 0.25\nfriction_length = 1.9e-5\n#",
                 ["[disk]: Disk: friction_length = 1.9e-05 m is out of range"],
                 id="friction-length-below-radius-over-1000"),
    pytest.param(CALIBRATION, "[disk]", "[disk]\nfriction_length = 1e-300",
                 ["[disk]: Disk: friction_length = 1e-300 m is out of range"],
                 id="calibration-friction-length-1e-300"),
    pytest.param(TRAJECTORY, "M = 0.08", "M = 0.98",
                 ["[disk]", "mass ratios sum to 1.06 > 1"], id="plates-heavier-than-disk"),
    # the planar model stops at lift-off: flight is refused naming the law, the solver and
    # what is allowed
    pytest.param(TRAJECTORY, "cs = 0.25 ", "cs = 0.25\nflight = true\n#",
                 ["[disk]: Disk: flight = True: lift_off law 'flight' is not implemented by "
                  "the planar integrator ('planar'); allowed: 'stop'", "outcome 'lift_off'"],
                 id="planar-flight"),
    pytest.param(CALIBRATION, "[disk]", "[disk]\nflight = 1",
                 ["[disk] flight: 1 has the wrong type; expected boolean"], id="flight-number"),
    # sizes
    pytest.param(TRAJECTORY, "sample_interval = 0.05", "sample_interval = 1e-12",
                 ["[trajectory] sample_interval = 1e-12 s", "3.6e+13 samples",
                  f"allowed at most {MAX_SCENE_SAMPLES:.3g}", "sample_interval >= 3.6e-06 s"],
                 id="trajectory-samples"),
    pytest.param(CALIBRATION, "max_periods = 400", "max_periods = 100000",
                 ["[calibration] f x a x max_periods = 81 x 4 x 100000",
                  f"allowed at most {MAX_CALIBRATION_PERIODS:.3g}"], id="calibration-periods"),
    pytest.param(CALIBRATION, "num = 81 }", "num = 1000000 }",
                 ["[calibration] f x a = 1000000 x 4", "allowed at most 1e+05"],
                 id="calibration-points"),
    # the kind's tables
    pytest.param(CALIBRATION, "[calibration]", "[plan]",
                 ["[plan]", "'acceleration' is a required property"], id="wrong-kind-table"),
    pytest.param(PLAN, "[plan]", "[plan_]", ["unknown key 'plan_'"], id="plan-missing"),
    # a key whose unit changed was renamed: the old one is refused with the conversion
    pytest.param(PLAN, "heading_drift_deg = 5.73", "heading_drift = 0.1",
                 ["[plan] heading_drift: the key was in rad per diameter; it is now "
                  "heading_drift_deg, in degree per diameter",
                  "heading_drift = 0.1 rad per diameter is heading_drift_deg = 5.73 degree per "
                  "diameter"], id="heading-drift-old-key"),
    pytest.param(TRAJECTORY, "start = [0.0, 0.0, 90.0] # x",
                 "heading_drift = 0.2\nstart = [0.0, 0.0, 90.0] #",
                 ["[trajectory] heading_drift:", "it is now heading_drift_deg",
                  "heading_drift_deg = 11.46 degree per diameter"],
                 id="heading-drift-old-key-trajectory"),
    pytest.param(PLAN, "heading_drift_deg = 5.73", "heading_drift_deg = 1000",
                 ["[plan] heading_drift_deg = 1000 is out of range; allowed: >= 0 and <= 573"],
                 id="heading-drift-huge"),
]


@pytest.mark.parametrize(("text", "old", "new", "fragments"), REFUSALS)
def test_scene_refusals_name_file_key_and_what_is_allowed(text, old, new, fragments):
    with pytest.raises(SceneError) as excinfo:
        parse_scene(_replace(text, old, new), PATH)
    message = str(excinfo.value)
    assert message.startswith(f"{PATH}: ")
    for fragment in fragments:
        assert fragment in message


def test_a_plan_without_its_table_says_what_it_needs():
    text = _replace(PLAN, "[plan]", "[trajectory]\n[notplan]")
    with pytest.raises(SceneError, match="unknown key 'notplan'"):
        parse_scene(text, PATH)
    text = PLAN[: PLAN.index("[plan]")]
    with pytest.raises(SceneError, match=r"a plan scene needs a \[plan\] table \(acceleration, "):
        parse_scene(text, PATH)


def test_a_scene_error_is_a_spec_error():
    with pytest.raises(SpecError):
        parse_scene("[scene]\nname = 1\n", PATH)


@pytest.mark.parametrize(
    ("old", "new", "fragment"),
    [
        # far waypoints: 7 m at 1 cm s-1, flown 45 times
        ("waypoints = [[0.0, 0.08], [0.06, 0.12], [0.10, 0.05], [0.02, 0.02]]",
         "waypoints = [[5.0, 5.0]]",
         f"s of drive, simulated up to 45 times (strategies and corrections for realisations "
         f"= 4): 3.44e+04 s; allowed at most {MAX_PLAN_DRIVE_SECONDS:.3g} s"),
        ("seed = 7", "seed = 7\nsample_interval = 1e-12",
         f"[plan] sample_interval = 1e-12 s gives 5.76e+14 samples over 15 runs of 38.39 s; "
         f"allowed at most {MAX_SCENE_SAMPLES:.3g}"),
    ],
    ids=["far-waypoint", "sample-interval"],
)
def test_an_absurd_plan_is_refused_before_any_flight(monkeypatch, old, new, fragment):
    spec = parse_scene(_replace(PLAN, old, new), PATH)

    def no_flight(*args, **kwargs):
        raise AssertionError("a flight was simulated before the size was checked")

    monkeypatch.setattr(study.scenes.scene_run, "refined_route", no_flight)
    monkeypatch.setattr(study.scenes.scene_run, "run_plan", no_flight)
    with pytest.raises(SceneError) as excinfo:
        scene_dataset(spec)
    message = str(excinfo.value)
    assert message.startswith(f"{PATH}: [plan] ")
    assert fragment in message


def test_the_scene_module_computes_and_does_not_store():
    """The scene's modules (study.scenes.scene_spec, scene_run, scene_kind) must not import
    the store, the runner, provenance, the CLI or figures,
    not even inside a function: computing a scene does not depend on how it is kept."""
    imported = set()
    for module in (study.scenes.scene_spec, study.scenes.scene_run, study.scenes.scene_kind):
        tree = ast.parse(Path(module.__file__).read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                imported |= {alias.name for alias in node.names}
            elif isinstance(node, ast.ImportFrom):
                imported.add(node.module or "")
    forbidden = {"study.engine.store", "study.engine.runner", "study.engine.provenance",
                 "study.cli",
                 "study.figures"}
    assert "study.scenes.planar_model" in imported  # the walk sees the imports
    assert not imported & forbidden
    assert not any(name.startswith("study.figures.") for name in imported)

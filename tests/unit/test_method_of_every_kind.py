"""Every kind of result records its method (issue 33): a fit's, a design's and a scene's
contact laws (coupling, friction law, lift-off law) are global attributes written by one
function (``study.engine.contact_attributes.contact_law_attributes``, which a study's
``method_attributes`` uses too) and a ``method:`` line of ``study info``. The attributes
are optional: files written before them still validate and describe themselves."""

from __future__ import annotations

import shutil
from pathlib import Path

import netCDF4
import pytest

import study
from study.engine.contact_attributes import contact_law_attributes, method_summary
from study.engine.validation import ResultError, describe, read_attributes, validate_file
from study.studies.layout import method_attributes
from study.studies.spec import parse_spec

GOLDEN = Path(__file__).resolve().parents[1] / "golden"

FIT = """\
[fit]
name = "tiny-fit"
measurements = ["lab.csv"]
free = { cs = [0.05, 1.0] }
coupling = "one-way"
max_evaluations = 20
profile = "none"

[structure]
f0 = 20.0
Q = 30.0
alpha = 60.0
M = 0.12
cs = 0.25
"""

LAB = """\
quantity,f,a,value,sigma,direction,note
threshold,18.0,,5.8,0.1,,
threshold,19.0,,4.0,0.1,,
threshold,21.0,,4.5,0.1,,
"""

DESIGN = """\
[design]
name = "tiny-design"
coupling = "two-way"
scan_points = 3
max_iterations = 1

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[free]
f0 = [14.0, 15.0]

[[target]]
f = 14.2
a = 7.0
behaviour = "forward"
"""

SCENE = """\
[scene]
name = "tiny-scene"
kind = "trajectory"

[disk]
radius = 0.02
cs = 0.25
ck = 0.2
coupling = "two-way"

[[plate]]
name = "head"
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
attachment = [0.005, 0.0]

[trajectory]
sample_interval = 0.05
start = [0.0, 0.0, 90.0]

[[segment]]
label = "forward"
f = 14.2
a = 7.0
duration = 0.1
"""

@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A tiny fit, design and scene, each run by ``study.run`` as a user would."""
    folder = tmp_path_factory.mktemp("kinds")
    (folder / "lab.csv").write_text(LAB)
    paths = {}
    for name, text in (("fit", FIT), ("design", DESIGN), ("scene", SCENE)):
        spec = folder / f"{name}.toml"
        spec.write_text(text)
        paths[name] = folder / f"{name}.nc"
        study.run(spec, paths[name])
    return paths


@pytest.mark.parametrize(("kind", "coupling"), [
    ("fit", "one-way"), ("design", "two-way"), ("scene", "two-way")])
def test_every_kind_records_its_contact_laws(results: dict[str, Path], kind: str,
                                             coupling: str) -> None:
    attrs = read_attributes(results[kind])
    laws = {key: attrs[key] for key in attrs
            if key.startswith(("study_coupling", "study_friction", "study_lift_off"))}
    # Coulomb friction has no parameters of its own and stop reads none: exactly these.
    assert laws == {"study_coupling": coupling, "study_friction_law": "coulomb",
                    "study_lift_off": "stop"}
    assert laws == contact_law_attributes(coupling)
    # Only a study chooses a solver.
    assert "study_solver_method" not in attrs
    lines = describe(results[kind]).splitlines()
    assert f"  method: {coupling} coupling, friction coulomb, lift-off stop" in lines
    assert not any("not recorded" in line for line in lines)


def test_a_scene_whose_laws_differ_from_its_spec_is_refused(results: dict[str, Path],
                                                            tmp_path: Path) -> None:
    edited = tmp_path / "scene.nc"
    shutil.copy(results["scene"], edited)
    with netCDF4.Dataset(edited, "a") as nc:
        nc.setncattr("study_coupling", "one-way")
    with pytest.raises(ResultError, match="study_coupling differs from the embedded spec"):
        validate_file(edited)


@pytest.mark.parametrize("name", ["fit", "design", "steering", "steering-plan"])
def test_files_without_the_attributes_describe_their_method(name: str) -> None:
    """0.1.0 wrote none of them: the line says what the file has and the defaults as
    such, without a solver (these kinds have none) and without a traceback."""
    path = GOLDEN / "v0.1.0" / f"{name}.nc"
    attrs = read_attributes(path)
    assert "study_friction_law" not in attrs and "study_lift_off" not in attrs
    line = next(x for x in describe(path).splitlines() if x.startswith("  method:"))
    assert "solver" not in line
    assert line.endswith("friction coulomb (not recorded; the default), "
                         "lift-off stop (not recorded; the default)")
    coupling = attrs.get("study_coupling")
    assert line.startswith(f"  method: {coupling} coupling" if coupling
                           else "  method: coupling not recorded")


def test_a_study_takes_its_laws_from_the_same_function() -> None:
    spec = parse_spec("""\
[study]
name = "flight"
observables = ["velocity"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.6
cs = 0.25
restitution = 0.5

[sweep]
f = { values = [14.5] }
a = { values = [12.0] }

[solver]
coupling = "two-way"
flight = true
""")
    laws = contact_law_attributes("two-way", lift_off="flight",
                                  lift_off_values={"restitution": 0.5})
    assert laws == {"study_coupling": "two-way", "study_friction_law": "coulomb",
                    "study_lift_off": "flight", "study_lift_off_restitution": 0.5}
    attrs = method_attributes(spec)
    assert {key: attrs[key] for key in laws} == laws
    assert method_summary(laws, solver=False) == (
        "two-way coupling, friction coulomb, lift-off flight, restitution e=0.5")


def test_undeclared_laws_and_values_are_refused() -> None:
    with pytest.raises(ValueError, match="coupling 'both' is unknown"):
        contact_law_attributes("both")
    with pytest.raises(ValueError, match="lift-off law 'bounce' is unknown"):
        contact_law_attributes("one-way", lift_off="bounce")
    with pytest.raises(ValueError, match="reads no parameter"):
        contact_law_attributes("one-way", lift_off_values={"restitution": 0.5})
    with pytest.raises(ValueError, match="friction law 'stribeck' needs"):
        contact_law_attributes("one-way", "stribeck")

"""Likely mistakes in a spec, caught all at once (issue 34, item 3): a tilt that looks
like radians warns as the API does, a parameter that the chosen laws do not read is
refused with the law that reads it and the fix, every independent problem is reported in
one error, and ``study.run`` without an output writes beside the spec, not in results/."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import study
from study.cli import main
from study.engine.spec_files import SpecError
from study.model.contact import LAWS
from study.studies.spec import load_spec

BASE = """\
[study]
name = "mistake"
observables = [{observables}]

[structure]
f0 = 14.44
Q = 17.5
alpha = {alpha}
M = 0.08
cs = 0.25
{structure}
[sweep]
f = {{ start = 12.0, stop = 17.0, num = 3 }}
a = {{ start = 0.0, stop = 10.0, num = 3 }}
{sweep}
[solver]
{solver}
"""


def write(tmp_path: Path, *, observables: str = '"velocity"', alpha: str = "64.0",
          structure: str = "", sweep: str = "", solver: str = "") -> Path:
    path = tmp_path / "mistake.toml"
    path.write_text(BASE.format(observables=observables, alpha=alpha, structure=structure,
                                sweep=sweep, solver=solver))
    return path


def test_a_tilt_that_looks_like_radians_warns_and_study_run_says_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, alpha="1.117")
    with pytest.warns(study.SuspectInputWarning) as caught:
        spec = load_spec(path)
    message = str(caught[0].message)
    assert message.startswith(f"{path}: [structure] alpha = 1.117 degree")
    # The Structure's own words (one text) and the fix: the value in degree.
    assert "looks like an angle in radians" in message
    assert "give alpha = 63.9994" in message
    assert spec.structure_at(()).alpha == 1.117  # allowed, as given
    # study run says it on stderr, once, before the work, and runs.
    output = tmp_path / "out.nc"
    assert main(["run", str(path), "-o", str(output), "--workers", "1",
                 "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert err.startswith(f"study: warning: {path}: [structure] alpha = 1.117 degree")
    assert err.count("study: warning:") == 1
    # A sweep whose every tilt looks like radians warns too; one reaching 64 does not.
    swept = write(tmp_path, alpha="64.0", sweep="alpha = { values = [0.0, 0.5, 1.2] }")
    swept.write_text(swept.read_text().replace("alpha = 64.0\n", ""))
    with pytest.warns(study.SuspectInputWarning, match=r"\[sweep\] alpha.*give alpha ="):
        load_spec(swept)
    fine = write(tmp_path, alpha="64.0", sweep="alpha = { values = [1.0, 64.0] }")
    fine.write_text(fine.read_text().replace("alpha = 64.0\n", ""))
    assert load_spec(fine).warnings == ()


def test_a_parameter_the_chosen_laws_do_not_read_is_refused(tmp_path: Path) -> None:
    """Restitution without flight: derived from the laws' declarations."""
    assert "restitution" in LAWS["lift_off"]["flight"].structure_parameters
    for where, text in (("[sweep]", {"sweep": "restitution = { values = [0.0, 0.5] }"}),
                        ("[structure]", {"structure": "restitution = 0.5"})):
        path = write(tmp_path, **text)
        with pytest.raises(SpecError) as refused:
            load_spec(path)
        message = str(refused.value)
        assert message.startswith(f"{path}: {where} restitution is read only by the "
                                  "lift-off law 'flight'")
        assert "no effect" in message
        assert 'add [solver] flight = true (with coupling = "two-way")' in message
    # With flight chosen the same spec is a study.
    assert load_spec(write(tmp_path, sweep="restitution = { values = [0.0, 0.5] }",
                           solver='coupling = "two-way"\nflight = true')).flight
    # A friction law's parameter with another law: named with the law that reads it.
    path = write(tmp_path, solver='method = "integrator"\n'
                 'friction = { law = "coulomb", stribeck_speed = 0.01 }')
    with pytest.raises(SpecError, match=re.escape(
            f"{path}: [solver] friction stribeck_speed is read only by the friction law "
            "'stribeck'") + r".*give \[solver\] friction = \{ law = \"stribeck\""):
        load_spec(path)


def test_independent_problems_are_reported_together(tmp_path: Path) -> None:
    path = write(tmp_path, observables='"velocity", "floquet"', solver="flight = true",
                 sweep="restitution = { values = [0.0, 0.5] }")
    with pytest.raises(SpecError) as refused:
        load_spec(path)
    lines = str(refused.value).splitlines()
    assert lines[0] == f"{path}: 2 problems, each to fix:"
    assert len(lines) == 3
    # Each line the message the problem has alone (its key, the file and the fix).
    assert lines[1].startswith(f'  - {path}: [study] observable "floquet"')
    assert 'allowed: coupling = "two-way"' in lines[1]
    assert lines[2].startswith(f'  - {path}: [solver] flight = true needs coupling = '
                               '"two-way"')
    assert "or flight = false" in lines[2]
    # The restitution is not unread: flight was asked for (and refused for the coupling).
    assert "restitution" not in str(refused.value)
    # One problem alone keeps its message as it was, on one line.
    single = write(tmp_path, solver="flight = true")
    with pytest.raises(SpecError) as alone:
        load_spec(single)
    assert str(alone.value).startswith(f"{single}: [solver] flight = true needs coupling")
    assert "\n" not in str(alone.value)


def test_run_without_an_output_writes_beside_the_spec(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch
                                                      ) -> None:
    own = tmp_path / "own"
    own.mkdir()
    path = write(own)
    monkeypatch.chdir(tmp_path)
    ds = study.run(path, workers=1)
    assert Path(ds.encoding["source"]) == own / "mistake.nc"
    assert not (tmp_path / "results").exists()


USER = """\
[study]
name = "user"
observables = [{observables}]

[structure]
f0 = 18.0
Q = 25.0
alpha = 55.0
M = {M}
cs = 0.35
{structure}
[sweep]
f = {f}
a = {{ start = 0.0, stop = 14.0, num = 29 }}
{sweep}
[solver]
coupling = "two-way"
{solver}
"""
GOOD_F = "{ start = 8.0, stop = 20.0, num = 121 }"


def _user(tmp_path: Path, name: str = "user.toml", *, observables: str = '"velocity"',
          M: str = "0.9", f: str = GOOD_F, structure: str = "", sweep: str = "",
          solver: str = "flight = true") -> Path:
    path = tmp_path / name
    path.write_text(USER.format(observables=observables, M=M, f=f, structure=structure,
                                sweep=sweep, solver=solver))
    return path


def _refusal(path: Path) -> str:
    with pytest.raises(SpecError) as refused:
        load_spec(path)
    return str(refused.value)


def _alone(tmp_path: Path, **mistake: str) -> str:
    """The message of one problem alone: the line it must keep in a joint refusal."""
    message = _refusal(_user(tmp_path, "alone.toml", **mistake))
    assert "\n" not in message, message
    return message.replace("alone.toml", "user.toml")


def test_schema_violations_and_the_other_checks_are_reported_in_one_error(tmp_path):
    """Issue 47: an unknown observable and num = 0 (the schema's) and M = 1 with flight
    (the structure's, found only once the schema passed) came in two runs; now in one
    error, one line each, each the message it has alone, naming its key."""
    path = _user(tmp_path, observables='"velocity", "velocty"', M="1.0",
                 f="{ start = 8.0, stop = 20.0, num = 0 }")
    lines = _refusal(path).splitlines()
    assert lines[0] == f"{path}: 3 problems, each to fix:"
    assert len(lines) == 4
    assert lines[1].startswith(f"  - {path}: [study] observables[1]: 'velocty' is not allowed")
    assert lines[2].startswith(f"  - {path}: [sweep] f: ")
    assert "f.num = 0 is out of range" in lines[2]
    flight_alone = _alone(tmp_path, M="1.0")
    assert flight_alone.startswith(f"{tmp_path / 'user.toml'}: M = 1.0 at [structure] with "
                                   "[solver] flight = true: flight needs M < 1")
    assert lines[3] == f"  - {flight_alone}"


def test_the_schema_alone_keeps_its_message(tmp_path):
    """Schema violations without another problem read as they always did."""
    path = _user(tmp_path, observables='"velocity", "velocty"',
                 f="{ start = 8.0, stop = 20.0, num = 0 }")
    message = _refusal(path)
    assert message.startswith(f"{path}: invalid study spec:\n  [study] observables[1]: ")
    assert len(message.splitlines()) == 3


def test_m_one_with_flight_is_reported_beside_the_other_checks(tmp_path):
    """M = 1 with flight was checked only after every other check had passed: beside an
    observable's unmet need and [basins] without basins it came a run later."""
    path = _user(tmp_path, M="1.0", observables='"velocity", "frontier"',
                 sweep='protocol = { along = "f", direction = "up" }',
                 structure="", solver="flight = true\n\n[basins]\nstarts = 4")
    lines = _refusal(path).splitlines()
    assert lines[0] == f"{path}: 3 problems, each to fix:"
    assert '[sweep] protocol with the observable "frontier"' in lines[1]
    assert "[basins] is read only by the observable \"basins\"" in lines[2]
    assert lines[3] == f"  - {_alone(tmp_path, M='1.0')}"
    # A swept structure point names its values, as alone.
    swept = _user(tmp_path, M="1.0", f="{ start = 8.0, stop = 20.0, num = 0 }",
                  structure="", sweep="Q = { values = [20.0, 25.0] }")
    swept.write_text(swept.read_text().replace("Q = 25.0\n", ""))
    message = _refusal(swept)
    assert "2 problems" in message
    assert "M = 1.0 at [sweep] point Q = 20.0 with [solver] flight = true" in message


def test_a_problem_that_follows_from_a_refused_key_is_not_reported(tmp_path):
    """A check that reads what the schema refused is left for the run after the fix: a
    misspelt observable does not also make [basins] unread, a misspelt parameter does
    not also make the structure miss one, a refused M is not also checked for flight."""
    path = _user(tmp_path, observables='"velocity", "basin"',
                 solver="flight = true\n\n[basins]\nstarts = 4")
    message = _refusal(path)
    assert "'basin' is not allowed" in message and "[basins]" not in message
    assert "\n  - " not in message  # the schema's alone
    misspelt = _user(tmp_path, M="0.9\nq = 25.0")
    misspelt.write_text(misspelt.read_text().replace("Q = 25.0\n", ""))
    message = _refusal(misspelt)
    assert "unknown key 'q'" in message and "missing" not in message
    refused_m = _user(tmp_path, M='"1.0"', f="{ start = 8.0, stop = 20.0, num = 0 }")
    message = _refusal(refused_m)
    assert "[structure] M" in message and "flight needs M < 1" not in message


def test_a_drop_in_millimetres_warns_naming_the_key_the_file_and_the_value(tmp_path, capsys):
    """Issue 47: a drop of 2.0 m (2 mm meant) passed silently. Above 0.1 m, or above 100
    natural hop scales g / (2 pi f)^2 of the lowest frequency, a drop warns: the key,
    the file, the value, what looks wrong and the units; study run prints it and runs."""
    from study.model.inputs import natural_hop

    path = _user(tmp_path, solver="flight = true\nstart = { drop = 2.0, phase = 0.25 }")
    with pytest.warns(study.SuspectInputWarning) as caught:
        spec = load_spec(path)
    assert len(caught) == 1
    message = str(caught[0].message)
    hop = 9.8 / (2 * np.pi * 8.0) ** 2
    np.testing.assert_allclose(natural_hop(8.0, 9.8), hop, rtol=1e-15)
    assert message.startswith(f"{path}: [solver] start drop = 2.0 m: a drop of "
                              f"{2.0 / hop:.3g} times the natural hop scale")
    assert f"= {hop * 1e3:.3g} mm of the lowest drive frequency (8 Hz)" in message
    assert "above 0.1 m" in message and "looks like a height in millimetres" in message
    assert "the height is in metres (for 2 mm give drop = 0.002)" in message
    assert spec.solver.start.height == 2.0  # allowed, as given
    # The drops a study means do not warn: 2 mm, and 9 cm at 8 Hz (23 hop scales).
    for height in ("0.002", "0.09"):
        fine = _user(tmp_path, solver=f"flight = true\nstart = {{ drop = {height} }}")
        assert load_spec(fine).warnings == ()
    # Far above the hop scale of a high drive frequency, below 0.1 m: 5 cm at 100 Hz.
    high = _user(tmp_path, solver="flight = true\nstart = { drop = 0.05 }",
                 f="{ start = 100.0, stop = 120.0, num = 3 }", structure="f0 = 90.0")
    high.write_text(high.read_text().replace("f0 = 18.0\n", ""))
    with pytest.warns(study.SuspectInputWarning) as caught:
        load_spec(high)
    (warning,) = [str(w.message) for w in caught]
    assert "2.01e+03 times the natural hop scale" in warning and "above 0.1 m" not in warning
    output = tmp_path / "out.nc"
    small = _user(tmp_path, solver="flight = true\nstart = { drop = 2.0 }",
                  f="{ values = [14.0] }")
    small.write_text(small.read_text().replace("num = 29", "num = 2"))
    assert main(["run", str(small), "-o", str(output), "--workers", "1",
                 "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert err.startswith(f"study: warning: {small}: [solver] start drop = 2.0 m: ")


@pytest.mark.parametrize(("f", "low", "high", "says"), [
    ("{ start = 50.0, stop = 190.0, num = 15 }", 50.0, 190.0,
     "look like angular frequencies in rad s-1; f is in Hz"),
    ("{ start = 63.0, stop = 107.0, num = 5 }", 63.0, 107.0,  # 10-17 Hz, below f0
     "look like angular frequencies in rad s-1; f is in Hz"),
    ("{ values = [200.0, 300.0] }", 200.0, 300.0, "above 5 times the resonance f0 = 18 Hz"),
])
def test_drive_frequencies_far_above_the_resonance_warn(tmp_path, f, low, high, says):
    """Issue 47: f = 50-190 (rad s-1) for f0 = 18 Hz passed silently. Every f above 2 f0
    with f / (2 pi) coming within 20 % of f0, or every f above 5 f0, warns."""
    path = _user(tmp_path, f=f)
    with pytest.warns(study.SuspectInputWarning) as caught:
        load_spec(path)
    (message,) = [str(w.message) for w in caught]
    assert message.startswith(f"{path}: [sweep] f = {low:g} .. {high:g} Hz: every drive "
                              "frequency is above")
    assert says in message
    if "rad" in says:
        hz = f"{low / (2 * np.pi):.4g} .. {high / (2 * np.pi):.4g} Hz"
        assert f"f / (2 pi) = {hz} would come within 20 % of it" in message


@pytest.mark.parametrize("f", [
    "{ start = 8.0, stop = 20.0, num = 121 }",   # the user's own, across f0 = 18 Hz
    "{ start = 5.0, stop = 90.0, num = 18 }",    # wide, reaching 5 f0
    "{ start = 37.0, stop = 80.0, num = 3 }",    # above 2 f0, f / (2 pi) short of 0.8 f0
    "{ values = [1.0, 2.0] }",                   # far below resonance: quasi-static
])
def test_frequencies_a_study_may_mean_do_not_warn(tmp_path, f):
    assert load_spec(_user(tmp_path, f=f)).warnings == ()


def test_no_workflow_looks_mistaken() -> None:
    """The workflows' drops and frequency axes are all within the plausible bounds."""
    import warnings

    root = Path(__file__).resolve().parents[2] / "workflows"
    for spec in sorted(root.glob("*.toml")):
        if "[study]" not in spec.read_text(encoding="utf-8"):
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("error", study.SuspectInputWarning)
            load_spec(spec)

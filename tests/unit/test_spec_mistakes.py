"""Likely mistakes in a spec, caught all at once (issue 34, item 3): a tilt that looks
like radians warns as the API does, a parameter that the chosen laws do not read is
refused with the law that reads it and the fix, every independent problem is reported in
one error, and ``study.run`` without an output writes beside the spec, not in results/."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import study
from study.cli import main
from study.engine.spec_files import SpecError
from study.engine.study_spec import load_spec
from study.model.contact import LAWS

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

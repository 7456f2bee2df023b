"""The promise that results outlive versions: every file a release wrote still opens,
validates, describes itself, draws and exports, and upgrades to today's format.

``tests/golden/<release>/`` holds small result files of every kind written by that
release's own ``study`` command (``make_corpus.py``); they are never rewritten. A change
that makes any of them unreadable fails here: a format change is a deliberate act (a
new :class:`study.engine.kinds.ResultFormat`, its frozen schema, its reader and, where
it can be done without recomputing, its upgrade step).
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

from study.cli import main
from study.engine.kinds import RESULT_KINDS, kind_of_schema
from study.engine.validation import (
    ResultError,
    describe,
    file_format_note,
    open_result,
    read_attributes,
    seal,
    validate_file,
)
from study.engine.validation.formats import written_by
from study.figures import FigureError, draw_figure
from study.model.status import Status
from study.version import VERSION
from tests.support.tiers import headline

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
RELEASES = sorted(p.name for p in HERE.glob("v*") if p.is_dir())
CORPUS = sorted(HERE.glob("v*/*.nc"))


def _is_older_format(path: Path) -> bool:
    """Whether the file's format is older than the one this code writes."""
    attrs = read_attributes(path)
    kind = kind_of_schema(str(attrs["study_result_schema"]))
    return attrs.get(kind.format_attribute, kind.formats[0].number) != kind.current_format.number


#: The files of the releases before this version: the promise is that a later version
#: reads what an earlier one wrote. (The files this version writes are read by this
#: same code throughout the other tiers; they join these once a later version exists.
#: Every file still opens, validates and describes above.) Also this version's files of
#: a format changed since its release (its studies, format 4, while the unreleased code
#: writes format 5): they are read and upgraded as any earlier release's.
EARLIER = [path for path in CORPUS
           if path.parent.name != f"v{VERSION}" or _is_older_format(path)]
#: Every study of the corpus, of every release (formats 2, 3 and 4).
STUDIES = [path for path in CORPUS
           if read_attributes(path)["study_result_schema"] == "study-result-v1"]
#: The figure each golden file is drawn as (every file is drawn by at least one).
FIGURE_OF = {
    "own": "regime-map",
    "frontier-two-way": "threshold-collapse",
    "mass-ratio-two-way": "coupling",
    "thresholds": "thresholds",
    "integrator": "velocity-curves",
    "paradox": "velocity-curves",
    "flight": "bouncing",
    "irregular": "lyapunov",
    "stribeck": "velocity-curves",
    "steering": "steering",
    "steering-calibration": "steering-calibration",
    "steering-plan": "steering-plan",
    "fit": "fit",
    "design": None,  # no figure draws a design: it is exported and described
}
#: Figure options a file needs (a structure to draw where it sweeps one).
FIGURE_SELECTION = {"mass-ratio-two-way": ["M=0.6"], "thresholds": ["M=0.08"],
                    "paradox": ["M=0.99"], "flight": ["restitution=0"],
                    "irregular": ["M=0.99", "restitution=0"]}


def _id(path: Path) -> str:
    return f"{path.parent.name}/{path.stem}"


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _kind(path: Path):
    return kind_of_schema(str(read_attributes(path)["study_result_schema"]))


def test_every_release_holds_every_kind():
    """Each release's corpus has a study, a scene, a fit and a design, and was written
    by that release (its files say so)."""
    import tomllib

    declared = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    assert "v0.1.0" in RELEASES
    assert f"v{declared}" in RELEASES, f"release {declared} has not written its golden files"
    for release in RELEASES:
        files = sorted((HERE / release).glob("*.nc"))
        kinds = {_kind(path).name for path in files}
        assert kinds == set(RESULT_KINDS), (release, kinds)
        for path in files:
            assert written_by(read_attributes(path)) == release.removeprefix("v"), path


def test_the_corpus_holds_every_status():
    """Every status code appears in some golden file (the newest release's statuses)."""
    seen: set[int] = set()
    for path in CORPUS:
        if _kind(path).name != "study":
            continue
        with xr.open_dataset(path) as dataset:
            for name in ("status", "status_one_way", "status_without_flight"):
                if name in dataset:
                    seen.update(np.unique(dataset[name].values).tolist())
    assert seen == {int(s) for s in Status}, sorted(seen)


@pytest.mark.parametrize("path", CORPUS, ids=_id)
def test_opens_validates_and_describes(path: Path):
    kind = _kind(path)
    assert validate_file(path) == kind.label
    dataset = open_result(path)
    assert dataset.sizes, path
    text = describe(path)
    release = path.parent.name.removeprefix("v")
    assert f"made by study {release}" in text
    written = read_attributes(path).get(kind.format_attribute, kind.formats[0].number)
    note = file_format_note(path)
    if written == kind.current_format.number:
        assert note == "" and "note:" not in text
    else:
        # One line, naming where it came from and what to do.
        assert "\n" not in note
        assert f"format {written} from study {release}" in note
        assert "study upgrade" in note and note in text


@pytest.mark.parametrize("path", headline(EARLIER, per=lambda path: path.stem), ids=_id)
def test_the_command_line_reads_it(path: Path, tmp_path: Path, capsys):
    """``study validate``, ``info``, ``export`` and ``figure``, as a user types them."""
    assert main(["validate", str(path)]) == 0
    assert main(["info", str(path)]) == 0
    assert main(["export", str(path), "--csv", str(tmp_path / "table.csv")]) == 0
    assert (tmp_path / "table.csv").stat().st_size > 0
    figure = FIGURE_OF[path.stem]
    if figure is not None:
        options = [arg for sel in FIGURE_SELECTION.get(path.stem, []) for arg in ("--sel", sel)]
        assert main(["figure", figure, str(path), "-o", str(tmp_path / "figure"),
                     *options]) == 0
        assert (tmp_path / "figure.png").stat().st_size > 0
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    kind = _kind(path)
    older = read_attributes(path).get(kind.format_attribute, 1) != kind.current_format.number
    assert ("study upgrade" in captured.err) == older


@pytest.mark.parametrize("path", EARLIER, ids=_id)
def test_upgrade_keeps_every_value(path: Path, tmp_path: Path):
    """``study upgrade`` writes today's format, bit for bit the same values, the same
    provenance and fingerprint, a valid checksum; the input is not touched."""
    before = _digest(path)
    output = tmp_path / "upgraded.nc"
    assert main(["upgrade", str(path), "-o", str(output)]) == 0
    assert _digest(path) == before
    kind = _kind(path)
    assert validate_file(output) == kind.label
    new = read_attributes(output)
    assert new.get(kind.format_attribute, 1) == kind.current_format.number
    assert file_format_note(output) == ""
    old = read_attributes(path)
    assert written_by(new) == written_by(old)
    for key in ("provenance", "study_fingerprint", "study_spec", "study_version"):
        assert new.get(key) == old.get(key), key
    with xr.open_dataset(path) as a, xr.open_dataset(output) as b:
        assert set(a.variables) == set(b.variables)
        for name in a.variables:
            assert np.array_equal(a[name].values, b[name].values,
                                  equal_nan=a[name].dtype.kind == "f"), name


def test_an_upgraded_study_records_its_method(tmp_path: Path):
    """The upgrade of a 0.1.0 study adds the method attributes today's files carry,
    from its embedded spec, and today's flags (a superset whose codes kept meaning)."""
    path = HERE / "v0.1.0" / "mass-ratio-two-way.nc"
    with netCDF4.Dataset(path) as nc:
        assert "study_friction_law" not in nc.ncattrs()
        old_flags = nc["status"].getncattr("flag_meanings").split()
    output = tmp_path / "up.nc"
    assert main(["upgrade", str(path), "-o", str(output)]) == 0
    attrs = read_attributes(output)
    assert attrs["study_friction_law"] == "coulomb"
    assert attrs["study_lift_off"] == "stop"
    assert attrs["study_coupling"] == "two-way"
    # The prose that names the method follows it (it is generated from the spec).
    assert "friction law 'coulomb'" in attrs["source"]
    assert "friction law 'coulomb'" in attrs["summary"]
    assert "upgrade" in attrs["history"].splitlines()[-1]
    with netCDF4.Dataset(output) as nc:
        new_flags = nc["status"].getncattr("flag_meanings").split()
    assert new_flags == [s.name.lower() for s in Status]
    assert new_flags[:len(old_flags)] == old_flags


def _tampered(path: Path, tmp_path: Path, **attrs) -> Path:
    copy = tmp_path / path.name
    shutil.copyfile(path, copy)
    with netCDF4.Dataset(copy, "a") as nc:
        for name, value in attrs.items():
            nc.setncattr(name, value)
    return copy


def test_a_file_of_a_newer_version_is_refused_in_one_line(tmp_path: Path, capsys):
    path = HERE / RELEASES[-1] / "own.nc"
    kind = _kind(path)
    newer = _tampered(path, tmp_path, study_version="9.0.0",
                      study_result_format=np.int32(kind.current_format.number + 1))
    with pytest.raises(ResultError) as raised:
        open_result(newer)
    message = str(raised.value)
    assert "\n" not in message
    assert "9.0.0" in message and VERSION in message and "upgrade study" in message
    assert main(["info", str(newer)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and "pip install" in err


def test_a_kind_of_a_newer_version_is_refused_with_what_to_do(tmp_path: Path):
    path = HERE / RELEASES[-1] / "own.nc"
    newer = _tampered(path, tmp_path, study_version="9.0.0",
                      study_result_schema="study-basins-v1")
    with pytest.raises(ResultError, match=r"9\.0\.0.*upgrade study"):
        validate_file(newer)


def test_an_older_file_may_not_give_a_code_another_meaning(tmp_path: Path):
    """The flags of an older format are a subset of today's, code for code: a file
    that calls code 3 'bouncing' (today: lift_off) is refused, even resealed."""
    copy = tmp_path / "own.nc"
    shutil.copyfile(HERE / "v0.1.0" / "own.nc", copy)
    with netCDF4.Dataset(copy, "a") as nc:
        meanings = nc["status"].getncattr("flag_meanings").split()
        meanings[3] = "bouncing"
        nc["status"].setncattr("flag_meanings", " ".join(meanings))
    with pytest.raises(ResultError, match=r"status: flags 3 bouncing differ"):
        seal(copy)


def test_a_figure_says_in_one_line_what_an_older_file_lacks(tmp_path: Path):
    dataset = open_result(HERE / "v0.1.0" / "own.nc")
    with pytest.raises(FigureError) as raised:
        draw_figure("bouncing", dataset, tmp_path / "bouncing")
    assert "\n" not in str(raised.value) and "flight" in str(raised.value)


def test_running_a_spec_onto_an_older_file_says_why_it_recomputes(tmp_path: Path, capsys):
    """The older file stays whole until the new one is sealed, and the run says why."""
    from study.engine.runner import StudyInterrupted, run

    old = HERE / "v0.1.0" / "own.nc"
    output = tmp_path / "own.nc"
    shutil.copyfile(old, output)
    spec = tmp_path / "own.toml"
    shutil.copyfile(HERE / "specs" / "own.toml", spec)
    with pytest.raises(StudyInterrupted):
        run(str(spec), output, cache=tmp_path / "cache", stop_after=0, progress=False)
    assert _digest(output) == _digest(old)
    assert main(["run", str(spec), "-o", str(output), "--cache",
                 str(tmp_path / "cache")]) == 0
    out = capsys.readouterr().out
    assert "rewritten because it was written by study 0.1.0 in study result format 2" in out
    assert file_format_note(output) == ""


def _frozen_schemas() -> dict[str, str]:
    return json.loads((HERE / "frozen-schemas.json").read_text())


def test_every_format_has_its_schema_and_old_ones_are_frozen():
    """Each declared format's header schema is in the package and in results_schema/;
    the schema of a format no longer written never changes (its sha256 is recorded)."""
    frozen = _frozen_schemas()
    for kind in RESULT_KINDS.values():
        for result_format in kind.formats:
            name = f"{result_format.schema}.schema.json"
            packaged = REPO / "study" / "schemas" / name
            assert packaged.is_file(), name
            assert (REPO / "results_schema" / name).read_bytes() == packaged.read_bytes()
            if result_format.schema != kind.result_schema:
                assert frozen.get(name) == _digest(packaged), (
                    f"{name} is the frozen schema of an older format: never edit it")


def test_an_older_study_does_not_replace_a_newer_versions_file(tmp_path: Path, capsys):
    """Running a spec onto a file a later version wrote is refused in one line (the
    file is kept), unless forced."""
    spec = tmp_path / "own.toml"
    shutil.copyfile(HERE / "specs" / "own.toml", spec)
    path = HERE / RELEASES[-1] / "own.nc"
    newer = _tampered(path, tmp_path, study_version="9.0.0",
                      study_result_format=np.int32(_kind(path).current_format.number + 1))
    before = _digest(newer)
    assert main(["run", str(spec), "-o", str(newer), "--cache", str(tmp_path / "c")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "9.0.0" in err and "--force" in err
    assert _digest(newer) == before
    assert main(["run", str(spec), "-o", str(newer), "--cache", str(tmp_path / "c"),
                 "--force"]) == 0
    assert validate_file(newer) == "study result"


# ---------------------------------------------------------------------------
# Format 5: the start and slow sweeps recorded (format 4 is study 0.3.0's)

FORMAT_5_SPEC = """\
[study]
name = "format-5"
observables = ["velocity", "section", "unswept"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.99
cs = 0.25

[sweep]
f = { values = [15.2, 16.0] }
a = { values = [10.0] }
protocol = { along = "f", direction = "both" }

[solver]
coupling = "two-way"
flight = true
start = "switch-on"
"""


def test_the_current_study_format_is_5_and_4_is_frozen_as_0_3_0_wrote_it():
    from study.studies.variables import RESULT_FORMAT, STUDY_FORMATS

    assert RESULT_FORMAT == 5
    assert [f.number for f in STUDY_FORMATS] == [1, 2, 3, 4, 5]
    four = STUDY_FORMATS[3]
    assert (four.release, four.schema) == ("0.3.0", "study-result-v1.format-4")
    frozen = json.loads((REPO / "study" / "schemas" / f"{four.schema}.schema.json").read_text())
    assert frozen["properties"]["attrs"]["properties"]["study_result_format"]["const"] == 4
    # 0.3.0 knew no start: its schema names none of the attributes format 5 added.
    assert not [name for name in frozen["properties"]["attrs"]["properties"]
                if name.startswith(("study_start", "study_protocol"))]
    current = json.loads((REPO / "study" / "schemas" / "study-result-v1.schema.json").read_text())
    attrs = current["properties"]["attrs"]
    assert attrs["properties"]["study_result_format"]["const"] == 5
    assert {"study_start", "study_start_kind"} <= set(attrs["required"])


@pytest.mark.parametrize("path", [p for p in STUDIES if p.parent.name == "v0.3.0"], ids=_id)
def test_a_0_3_0_study_upgrades_to_format_5_started_by_the_release(path: Path,
                                                                  tmp_path: Path):
    """Step 4 -> 5 reads and writes no value: a format-4 file started by the release and
    holds no slow sweep; the start is recorded from its embedded spec, the format and
    the history change, nothing else."""
    old = read_attributes(path)
    assert old["study_result_format"] == 4
    assert not [name for name in old if name.startswith(("study_start", "study_protocol"))]
    output = tmp_path / "upgraded.nc"
    assert main(["upgrade", str(path), "-o", str(output)]) == 0
    assert validate_file(output) == "study result"
    new = read_attributes(output)
    assert new["study_result_format"] == 5
    assert (new["study_start"], new["study_start_kind"]) == ("release", "release")
    changed = {name for name in set(old) | set(new) if old.get(name) != new.get(name)}
    assert changed <= {"study_result_format", "history", "date_modified", "study_start",
                       "study_start_kind", "study_content_sha256"}, changed
    assert new["study_content_sha256"] == old["study_content_sha256"]
    assert "format 4 -> 5" in new["history"].splitlines()[-1]
    assert new["history"].startswith(old["history"])
    with netCDF4.Dataset(path) as a, netCDF4.Dataset(output) as b:
        assert dict(a.dimensions.items()).keys() == dict(b.dimensions.items()).keys()
        for name, variable in a.variables.items():
            assert {k: str(variable.getncattr(k)) for k in variable.ncattrs()} == {
                k: str(b[name].getncattr(k)) for k in b[name].ncattrs()}, name


@pytest.mark.parametrize("path", [p for p in STUDIES if p.parent.name in ("v0.1.0", "v0.2.0")],
                         ids=_id)
def test_older_studies_upgrade_all_the_way_to_format_5(path: Path, tmp_path: Path):
    before = read_attributes(path).get("study_result_format", 1)
    output = tmp_path / "upgraded.nc"
    assert main(["upgrade", str(path), "-o", str(output)]) == 0
    assert validate_file(output) == "study result"
    new = read_attributes(output)
    assert new["study_result_format"] == 5
    assert (new["study_start"], new["study_start_kind"]) == ("release", "release")
    assert f"format {before} -> 5" in new["history"].splitlines()[-1]


def test_a_format_5_file_written_today_validates_and_0_3_0_s_rules_are_not_its(tmp_path):
    """A slow sweep both ways from the switch-on, with the section and unswept
    observables: every attribute, dimension and variable format 5 added, by the current
    schema; one without its start is refused (format 5 requires it)."""
    from study.engine.runner import run_study
    from study.engine.validation.formats import schema_path
    from study.engine.validation.header import file_header, schema_problems
    from study.engine.validation.reading import file_metadata, open_netcdf
    from study.studies.variables import STUDY_FORMATS

    spec = tmp_path / "format-5.toml"
    spec.write_text(FORMAT_5_SPEC)
    output = run_study(spec, tmp_path / "format-5.nc", cache=tmp_path / "cache",
                       progress=False, workers=1).output
    assert validate_file(output) == "study result"
    assert file_format_note(output) == ""
    attrs = read_attributes(output)
    assert attrs["study_result_format"] == 5
    assert (attrs["study_start"], attrs["study_start_kind"]) == ("switch-on", "switch-on")
    assert (attrs["study_protocol"], attrs["study_protocol_along"],
            attrs["study_protocol_direction"]) == ("slow sweep", "f", "both")
    with open_netcdf(output) as nc:
        header = file_header(file_metadata(nc, output))
        assert nc["direction"][:].tolist() == ["up", "down"]
    assert header["dims"]["direction"] == 2 and "section_period" in header["dims"]
    for name in ("jumped", "velocity_unswept", "status_unswept", "section_delta"):
        assert name in header["variables"], name
    assert schema_problems(schema_path(STUDY_FORMATS[-1]), header) == []
    # Its start is required; a direction dimension is a sweep both ways.
    without_start = json.loads(json.dumps(header))
    del without_start["attrs"]["study_start"]
    assert schema_problems(schema_path(STUDY_FORMATS[-1]), without_start)
    one_way = json.loads(json.dumps(header))
    one_way["attrs"]["study_protocol_direction"] = "up"
    assert schema_problems(schema_path(STUDY_FORMATS[-1]), one_way)
    copy = tmp_path / "no-start.nc"
    shutil.copyfile(output, copy)
    with netCDF4.Dataset(copy, "a") as nc:
        nc.delncattr("study_start")
    with pytest.raises(ResultError, match="study_start"):
        validate_file(copy)


def test_a_format_newer_than_5_is_refused_naming_the_file_and_formats(tmp_path, capsys):
    """Never read by rules it was not written for: one line that names the file, the
    format it claims and the newest this version reads."""
    path = HERE / "v0.3.0" / "own.nc"
    newer = _tampered(path, tmp_path, study_result_format=np.int32(6))
    with pytest.raises(ResultError) as raised:
        validate_file(newer)
    message = str(raised.value)
    assert "\n" not in message
    assert message.startswith(f"{newer}: study result format 6,")
    assert "this version reads formats 1-5" in message and "upgrade study" in message
    assert main(["validate", str(newer)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(newer) in err and "format 6" in err
    assert "formats 1-5" in err and "Traceback" not in err

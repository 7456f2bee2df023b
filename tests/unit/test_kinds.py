"""The kind registry (study.engine.kinds): every kind registered once from its own module,
found by its table, its spec class and its result schema; fit and design files written
by the one runner (lock, output check, atomic write); the engine imports no scene or
analysis module."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

import study
from study.analyses.design import DESIGN_KIND
from study.analyses.design_spec import DesignSpec
from study.analyses.fit import FIT_KIND, fit_dataset
from study.analyses.fit_search import fit
from study.analyses.fit_spec import FitSpec
from study.engine.kinds import (
    RESULT_KINDS,
    ResultKind,
    UnknownKind,
    kind_named,
    kind_of_schema,
    kind_of_spec,
    kind_of_table,
    register,
)
from study.engine.outputs import OutputError
from study.engine.runner import StudyBusy, load_any, run
from study.engine.spec_files import SpecError, detect_kind
from study.engine.store import exclusive
from study.engine.validation import validate_file
from study.scenes.scene_kind import SCENE_KIND
from study.scenes.scene_spec import SceneSpec
from study.studies.kind import STUDY_KIND
from study.studies.spec import StudySpec

PACKAGE = Path(study.__file__).parent
ROOT = PACKAGE.parent

FIT_SPEC = """[fit]
name = "t"
measurements = ["m.csv"]
free = { cs = [0.1, 0.6] }
coupling = "one-way"

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.1
cs = 0.3
"""

FIT_CSV = ("quantity,f,a,value,sigma\n"
           + "".join(f"threshold,{f!r},,{v!r},0.2\n"
                     for f, v in ((12.0, 6.0), (13.0, 4.0), (14.0, 2.5), (15.0, 3.0))))


def test_the_four_kinds_register_from_their_own_modules():
    assert list(RESULT_KINDS) == ["study", "scene", "fit", "design"]
    where = {name: kind.spec_type.__module__ for name, kind in RESULT_KINDS.items()}
    assert where == {"study": "study.studies.spec_types", "scene": "study.scenes.scene_spec",
                     "fit": "study.analyses.fit_spec", "design": "study.analyses.design_spec"}
    assert [STUDY_KIND, SCENE_KIND, FIT_KIND, DESIGN_KIND] == list(RESULT_KINDS.values())
    assert (STUDY_KIND.spec_type, SCENE_KIND.spec_type) == (StudySpec, SceneSpec)
    assert (FIT_KIND.spec_type, DESIGN_KIND.spec_type) == (FitSpec, DesignSpec)


@pytest.mark.parametrize("name", ["study", "scene", "fit", "design"])
def test_a_kind_is_found_by_its_name_table_and_schema(name):
    kind = kind_named(name)
    assert kind_of_table({kind.spec_table: {}}, "x.toml") is kind
    assert kind_of_schema(kind.result_schema) is kind
    # Its spec and result schemas are package data of those names.
    assert (PACKAGE / "schemas" / f"{kind.spec_schema}.schema.json").is_file()
    assert (PACKAGE / "schemas" / f"{kind.result_schema}.schema.json").is_file()
    # Its validator can be imported (it is imported on first use).
    module, function = kind.validator.split(":")
    assert callable(getattr(__import__(module, fromlist=[function]), function))


def test_the_schema_names_validation_exports_are_the_kinds():
    from study.engine import validation

    assert [validation.RESULT_SCHEMA, validation.SCENE_SCHEMA, validation.FIT_SCHEMA,
            validation.DESIGN_SCHEMA] == [k.result_schema for k in RESULT_KINDS.values()]


def test_a_second_kind_with_a_taken_table_is_refused_naming_both():
    twin = ResultKind(**{**{f: getattr(FIT_KIND, f) for f in FIT_KIND.__dataclass_fields__},
                         "name": "twin", "result_schema": "study-twin-v1", "spec_type": dict,
                         "formats": ()})
    with pytest.raises(ValueError, match="its spec_table 'fit' is already kind 'fit'"):
        register(twin)
    assert "twin" not in RESULT_KINDS


def test_unknown_kinds_name_the_file_and_the_kinds(tmp_path):
    with pytest.raises(UnknownKind, match="unknown result kind 'nope'; the kinds are 'study', "
                                          "'scene', 'fit', 'design'"):
        kind_named("nope")
    path = tmp_path / "odd.toml"
    path.write_text("[structure]\nQ = 1\n")
    with pytest.raises(SpecError) as info:
        detect_kind(path)
    assert str(info.value) == (
        f"{path}: not a spec of a result kind ('study', 'scene', 'fit', 'design'): it needs a "
        "[study] or [scene] or [fit] or [design] table (top-level tables found: 'structure')")
    with pytest.raises(UnknownKind, match="both \\[fit\\] and \\[design\\] tables"):
        kind_of_table({"fit": {}, "design": {}}, "x.toml")
    with pytest.raises(UnknownKind, match="dict is not the spec of a result kind"):
        kind_of_spec({})


@pytest.mark.parametrize("spec", sorted((ROOT / "workflows").glob("*.toml"))[:3]
                         + sorted((ROOT / "designs").glob("*.toml")), ids=lambda p: p.name)
def test_every_spec_file_is_read_by_the_kind_of_its_table(spec):
    loaded = load_any(spec)
    assert kind_of_spec(loaded).name == detect_kind(spec)


def test_a_fit_runs_through_the_runner_like_any_kind(tmp_path):
    """Same numbers as calling the fit directly; the lock and the output check hold; the
    file validates as a fit result."""
    (tmp_path / "m.csv").write_text(FIT_CSV)
    (tmp_path / "fit.toml").write_text(FIT_SPEC)
    output = tmp_path / "fit.nc"
    with exclusive(output), pytest.raises(StudyBusy, match="another run"):
        run(tmp_path / "fit.toml", output)
    assert not output.exists()
    report = run(tmp_path / "fit.toml", output, progress=False)
    assert report.kind == "fit" and not report.up_to_date
    assert validate_file(output) == "fit result"
    spec = FIT_KIND.load(tmp_path / "fit.toml")
    direct = fit_dataset(spec, fit(spec), "direct")
    with xr.open_dataset(output) as written:
        for name in ("estimate", "standard_error", "chi2", "model"):
            assert_allclose(written[name].values, direct[name].values, rtol=0, atol=0)
        assert np.isfinite(written["estimate"].values).all()
    # A fit never writes over what it reads.
    with pytest.raises(OutputError, match=r"m\.csv"):
        run(tmp_path / "fit.toml", tmp_path / "m.csv")


def _imports(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
        elif (isinstance(node, ast.Constant) and isinstance(node.value, str)
              and node.value.startswith("study.") and ":" in node.value):
            found.add(node.value.split(":")[0])  # a kind's validator, imported on first use
    return found


def test_the_engine_imports_no_scene_or_analysis_module():
    climbing = {str(path.relative_to(ROOT)): sorted(
        name for name in _imports(path)
        if name.startswith(("study.scenes", "study.analyses", "study.figures")))
        for path in (PACKAGE / "engine").rglob("*.py")}
    assert {k: v for k, v in climbing.items() if v} == {}

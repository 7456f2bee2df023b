"""The JSON schemas: package data in ``study/schemas/``, an exact copy in ``results_schema/``.

The code reads the package folder only (an installed ``study`` has no repository around
it); the top-level folder is part of the repository's documented shape and must not
drift from what the code enforces.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import study
from study.studies.spec import SPEC_SCHEMA_PATH

REPO = Path(__file__).resolve().parents[2]
PACKAGE_SCHEMAS = Path(study.__file__).resolve().parent / "schemas"
COPY = REPO / "results_schema"


def _names(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir() if p.is_file()}


def test_the_two_folders_hold_the_same_files() -> None:
    assert _names(PACKAGE_SCHEMAS), "no schemas shipped in study/schemas"
    assert _names(PACKAGE_SCHEMAS) == _names(COPY)


@pytest.mark.parametrize("name", sorted(_names(PACKAGE_SCHEMAS)))
def test_every_copy_is_identical(name: str) -> None:
    assert (COPY / name).read_bytes() == (PACKAGE_SCHEMAS / name).read_bytes(), (
        f"results_schema/{name} differs from study/schemas/{name}: copy the package's file"
    )


@pytest.mark.parametrize("name", sorted(_names(PACKAGE_SCHEMAS)))
def test_every_schema_is_a_json_schema(name: str) -> None:
    import jsonschema

    schema = json.loads((PACKAGE_SCHEMAS / name).read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)


def test_the_code_reads_the_package_folder() -> None:
    assert SPEC_SCHEMA_PATH.parent == PACKAGE_SCHEMAS


def test_the_spec_schema_file_is_the_export_of_the_observable_declarations() -> None:
    """Adding an observable touches study/studies/observables.py only; `make schemas` writes
    the file, and this test says so when it has not been run."""
    from study.studies.observables import OBSERVABLES
    from study.studies.schema import export_spec_schema, spec_schema

    on_disk = (Path(study.__file__).parent / "schemas" / "study-spec-v1.schema.json")
    assert on_disk.read_text(encoding="utf-8") == export_spec_schema(), "run `make schemas`"
    enum = spec_schema()["properties"]["study"]["properties"]["observables"]["items"]["enum"]
    assert enum == list(OBSERVABLES)

"""The tables of docs/user-guide/specs.md (observables, contact laws, parameters) are
written into the page (docs/generate_tables.py, ``make schemas``), so that its source
shows them: each committed table is the one its declaration gives, and a stale one is
found and rewritten (they were include directives of files that exist only after
``make docs``, issue 47)."""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _load():
    spec = importlib.util.spec_from_file_location("generate_tables",
                                                  ROOT / "docs" / "generate_tables.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


tables = _load()


@pytest.mark.parametrize("table", tables.TABLES, ids=lambda t: t.name)
def test_the_committed_table_is_the_generated_one(table) -> None:
    assert tables.committed(table) == table.generate(), (
        f"docs/{table.page}: the table {table.name!r} is stale; run `make schemas`")


def test_the_tables_are_the_declarations_own() -> None:
    """What the script writes is the package's table function's text, whole."""
    from study.model.parameters import PARAMETERS
    from study.studies.observable_table import markdown_table as observables
    from study.studies.observables import OBSERVABLES

    by_name = {table.name: table for table in tables.TABLES}
    assert by_name["observables"].generate() == observables().rstrip("\n") + "\n"
    page = (ROOT / "docs" / "user-guide" / "specs.md").read_text(encoding="utf-8")
    for name in OBSERVABLES:
        assert f"| `{name}` |" in page, name
    for name in PARAMETERS:
        assert f"| `{name}` |" in page, name


def test_no_page_includes_a_table_that_exists_only_after_a_build() -> None:
    for page in (ROOT / "docs").rglob("*.md"):
        assert "_generated/" not in page.read_text(encoding="utf-8"), page


def test_a_stale_table_is_found_and_rewritten(tmp_path) -> None:
    docs = tmp_path / "docs"
    for table in tables.TABLES:
        (docs / table.page).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / "docs" / table.page, docs / table.page)
    page = docs / "user-guide" / "specs.md"
    text = page.read_text(encoding="utf-8")
    assert tables.stale(docs) == []
    page.write_text(text.replace("| `resonance` |", "| `resonanse` |"), encoding="utf-8")
    assert [t.name for t in tables.stale(docs)] == ["observables"]
    assert [t.name for t in tables.write(docs)] == ["observables"]
    assert page.read_text(encoding="utf-8") == text
    assert tables.stale(docs) == []


def test_a_page_without_its_markers_is_refused(tmp_path) -> None:
    docs = tmp_path / "docs"
    (docs / "user-guide").mkdir(parents=True)
    (docs / "user-guide" / "specs.md").write_text("# Specs\n", encoding="utf-8")
    with pytest.raises(tables.TableError, match="0 blocks of the table 'observables'"):
        tables.stale(docs)

"""``--quick`` benchmarks (``make bench-quick``) never write the documentation's tables:
``benchmarks/docs_tables.py`` sends them and the reports to ``results/bench-quick/``."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "docs_tables.py"


@pytest.fixture
def tables(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    spec = importlib.util.spec_from_file_location("docs_tables_under_test", _PATH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "DOCS_SPEED", tmp_path / "docs" / "speed")
    monkeypatch.setattr(module, "QUICK_OUTPUT", tmp_path / "results" / "bench-quick")
    return module


def test_a_full_run_writes_the_docs_table(tables, tmp_path: Path) -> None:
    tables.use_quick(False)
    path = tables.write_docs_table("x", "bench_x.py", "a machine", "| a |\n|---|\n| 1 |")
    assert path == tmp_path / "docs" / "speed" / "x.md"
    assert path.read_text().startswith("*Written by `make bench` (`benchmarks/bench_x.py`)")
    assert tables.output(tmp_path / "results" / "bench-x.md") == tmp_path / "results" / "bench-x.md"


def test_a_quick_run_writes_beside_the_quick_reports_only(tables, tmp_path: Path) -> None:
    assert tables.use_quick(True)
    path = tables.write_docs_table("x", "bench_x.py", "a machine", "| a |\n|---|\n| 1 |")
    assert path == tmp_path / "results" / "bench-quick" / "docs-x.md"
    assert path.read_text().startswith("*Written by `make bench-quick` (fewer rounds")
    assert not (tmp_path / "docs").exists()
    assert tables.output(Path("results/bench-x.md")) == (
        tmp_path / "results" / "bench-quick" / "bench-x.md")

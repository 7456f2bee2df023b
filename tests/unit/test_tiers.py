"""The test suite's own shape: every test module sits in a tier, and the unit tier starts
no process and no cluster (those tests belong to tests/integration).

Read from the sources (imports, function-level ones too), so a test that moves or
gains a ``subprocess`` call is caught here, naming the file.
"""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
TIERS = {"unit", "integration", "paper", "hard_cases", "property", "fuzz", "golden"}
#: Packages that hold no tests: the independent oracles and the shared helpers.
HELPERS = {"reference", "support"}
#: What a unit test may not import: processes, clusters, or another tier's tests.
NOT_IN_UNIT = ("subprocess", "multiprocessing", "distributed", "dask.distributed",
               "tests.integration")


def imported(path: Path) -> set[str]:
    """Every module ``path`` imports (``from X import y`` also counts ``X.y``)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            found.add(node.module)
            found |= {f"{node.module}.{alias.name}" for alias in node.names}
    return found


def forbidden(modules: set[str]) -> list[str]:
    return sorted(m for m in modules for banned in NOT_IN_UNIT
                  if m == banned or m.startswith(banned + "."))


def test_every_test_module_is_in_a_tier() -> None:
    folders = {path.parent.name for path in TESTS.rglob("test_*.py")}
    assert folders <= TIERS, sorted(folders - TIERS)
    assert not list(TESTS.glob("test_*.py")), "a test module outside every tier"
    for helper in HELPERS:
        assert not list((TESTS / helper).rglob("test_*.py")), helper


def test_the_check_sees_a_process_or_a_cluster(tmp_path: Path) -> None:
    source = tmp_path / "test_x.py"
    source.write_text("import os\n\ndef test_a():\n    from subprocess import run\n"
                      "    from dask.distributed import LocalCluster\n")
    assert forbidden(imported(source)) == ["dask.distributed", "dask.distributed.LocalCluster",
                                           "subprocess", "subprocess.run"]


def test_the_unit_tier_starts_no_process_and_no_cluster() -> None:
    found = {path.name: forbidden(imported(path))
             for path in sorted((TESTS / "unit").glob("*.py"))}
    assert {name: modules for name, modules in found.items() if modules} == {}


def _is_slow(case) -> bool:
    return any(getattr(mark, "name", None) == "slow" for mark in case.marks)


def test_headline_keeps_the_first_case_of_each_group_in_the_default_tier() -> None:
    import pytest

    from tests.support.tiers import headline

    cases = headline([("regime-map", "f"), ("regime-map", "a"), ("thresholds", "f"),
                      pytest.param("thresholds", "a", id="named")],
                     per=lambda figure, dim: figure)
    assert [_is_slow(c) for c in cases] == [False, True, False, True]
    assert [c.values for c in cases] == [("regime-map", "f"), ("regime-map", "a"),
                                         ("thresholds", "f"), ("thresholds", "a")]
    assert cases[3].id == "named"  # a case's own id survives
    # A case already slow keeps no place: the next one is the group's headline.
    cases = headline([pytest.param(1, marks=pytest.mark.slow), 2, 3], keep=1)
    assert [_is_slow(c) for c in cases] == [True, False, True]


def test_the_fuzz_mark_is_exactly_the_fuzz_folder() -> None:
    """``make fuzz`` runs tests/fuzz by path (beside the API-input properties): every
    module there is marked fuzz, and no module elsewhere is, so that the path and
    ``-m fuzz`` select the same tests (``make test`` and ``make test-slow`` leave the
    mark out)."""
    def uses_the_mark(path: Path) -> bool:  # pytest.mark.fuzz anywhere in the module
        return any(isinstance(node, ast.Attribute) and node.attr == "fuzz"
                   and isinstance(node.value, ast.Attribute) and node.value.attr == "mark"
                   for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))))

    marked = {path.relative_to(TESTS).as_posix() for path in TESTS.rglob("test_*.py")
              if uses_the_mark(path)}
    folder = {path.relative_to(TESTS).as_posix() for path in (TESTS / "fuzz").glob("test_*.py")}
    assert marked == folder

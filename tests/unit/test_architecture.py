"""The package's shape: no import cycle, no private name used across modules, and the
computing code independent of how results are kept, shown and run."""

from __future__ import annotations

import ast
from pathlib import Path

import study

PACKAGE = Path(study.__file__).parent


def modules() -> dict[str, Path]:
    found = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        found[name] = path
    return found


def imports(name: str, path: Path, known: dict[str, Path]) -> list[tuple[str, str]]:
    """(module imported, name imported or '') for every import, function-level ones too."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(alias.name, "") for alias in node.names
                      if alias.name.split(".")[0] == "study"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            if module.split(".")[0] != "study":
                continue
            for alias in node.names:
                full = f"{module}.{alias.name}"
                found.append((full, "") if full in known else (module, alias.name))
    return found


def graph() -> dict[str, set[str]]:
    known = modules()
    return {name: {m for m, _ in imports(name, path, known) if m in known and m != name}
            for name, path in known.items()}


def test_the_walk_sees_imports():
    edges = graph()
    assert "study.engine.observables" in edges["study.engine.sweep"]
    assert "study.engine.cache" in edges["study.engine.study_kind"]


def test_no_private_name_crosses_modules():
    known = modules()
    crossing = [
        f"{name} imports {imported}.{what}"
        for name, path in known.items()
        for imported, what in imports(name, path, known)
        if what.startswith("_") and imported != name
    ]
    assert not crossing, crossing


def test_no_import_cycle():
    edges = graph()
    state: dict[str, int] = {}
    cycles = []

    def visit(node: str, trail: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 1:
                cycles.append([*trail[trail.index(nxt):], nxt])
            elif nxt not in state:
                visit(nxt, [*trail, nxt])
        state[node] = 2

    for node in sorted(edges):
        if node not in state:
            visit(node, [node])
    assert not cycles, cycles


def test_computing_modules_do_not_depend_on_storage_display_or_running():
    """Stages: spec -> physics -> kernels -> sweep; only the runner crosses into the
    cache, the store and the executors; figures and the CLI come after."""
    edges = graph()
    later = {"study.engine.runner", "study.engine.store", "study.engine.cache",
             "study.engine.executors", "study.cli", "study.engine.validation",
             "study.engine.progress"}
    for name in ("study.engine.sweep", "study.engine.observables", "study.scenes.scene_kind",
                 "study.engine.study_spec", "study.engine.spec_files", "study.solvers.exact",
                 "study.solvers.integrator", "study.scenes.planar_model"):
        reached, todo = set(), [name]
        while todo:
            for nxt in edges[todo.pop()]:
                if nxt not in reached:
                    reached.add(nxt)
                    todo.append(nxt)
        assert not reached & later, (name, reached & later)
        assert not any(m.startswith("study.figures") for m in reached), name

"""The package's shape: no import cycle, no private name used across modules (imported
or reached as an attribute), imports only going down the stages, and the computing code
independent of how results are kept, shown and run."""

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


#: The stages, lowest first: a module imports only modules of its own stage or of
#: stages before it. ``top`` is the public face: ``study/__init__.py``, ``api``, ``cli``.
STAGES = ("model", "kernels", "solvers", "engine", "studies", "scenes",
          "analyses", "figures", "top")

#: Modules outside the stage folders and the stage they belong to. ``study.version``
#: is a leaf every stage may read (the package's version, for provenance).
LOOSE_MODULES = {"study": "top", "study.api": "top", "study.cli": "top",
                 "study.figure_batch": "top",  # runs study.cli's figure commands
                 "study.version": "model"}

#: What the kernels may import outside ``study.kernels``: declarations without
#: numerics, the status codes as plain ints (numba reads module-level ints as constants)
#: and the contact laws' codes and parameters (the structure vector's entries).
KERNEL_IMPORTS = ("study.model.codes", "study.model.contact", "study.model.statistics")

def stage(name: str) -> str:
    """The stage of the module ``name``: its folder under ``study``, or
    :data:`LOOSE_MODULES`."""
    if name in LOOSE_MODULES:
        return LOOSE_MODULES[name]
    folder = name.split(".")[1]
    assert folder in STAGES, f"{name} is in no stage folder: add it to STAGES or LOOSE_MODULES"
    return folder


def climbs(edges: dict[str, set[str]] | None = None) -> dict[tuple[str, str], None]:
    """Every import (module, imported module) that goes up the stages."""
    found = {}
    for name, targets in (graph() if edges is None else edges).items():
        for target in targets:
            if STAGES.index(stage(target)) > STAGES.index(stage(name)):
                found[(name, target)] = None
    return found


def module_aliases(name: str, path: Path, known: dict[str, Path]) -> dict[str, str]:
    """Local names bound to modules of the package: ``import study.x as m``,
    ``from study.x import m`` and the bare ``import study.x`` (bound as ``study``)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    aliases = {}
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] != "study":
                    continue
                if alias.asname:
                    aliases[alias.asname] = alias.name
                else:
                    aliases["study"] = "study"
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            for alias in node.names:
                full = f"{module}.{alias.name}"
                if full in known:
                    aliases[alias.asname or alias.name] = full
    return aliases


def attribute_reaches(name: str, path: Path, known: dict[str, Path]) -> list[tuple[str, str]]:
    """(module, attribute) for every ``m.attribute`` (or ``study.x.m.attribute``) with
    ``m`` a module of the package bound in ``name``."""
    aliases = module_aliases(name, path, known)
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.Attribute):
            continue
        chain = []
        base = node.value
        while isinstance(base, ast.Attribute):
            chain.append(base.attr)
            base = base.value
        if not isinstance(base, ast.Name) or base.id not in aliases:
            continue
        module = ".".join([aliases[base.id], *reversed(chain)])
        if module in known:
            found.append((module, node.attr))
    return found


def private(what: str) -> bool:
    return what.startswith("_") and not what.startswith("__")


def test_the_walk_sees_imports():
    edges = graph()
    assert "study.studies.observables" in edges["study.studies.sweep"]
    assert "study.engine.cache" in edges["study.studies.kind"]


def test_no_private_name_crosses_modules():
    known = modules()
    crossing = [
        f"{name} imports {imported}.{what}"
        for name, path in known.items()
        for imported, what in imports(name, path, known)
        if what.startswith("_") and imported != name
    ]
    assert not crossing, crossing


def test_no_private_name_is_reached_as_an_attribute():
    """``kernel._solve(...)`` on an imported module is a private name crossing modules
    too: a wrapper calls the kernel's public entry point."""
    known = modules()
    crossing = [
        f"{name} reaches {module}.{what}"
        for name, path in known.items()
        for module, what in attribute_reaches(name, path, known)
        if private(what) and module != name
    ]
    assert not crossing, crossing


def test_the_attribute_walk_sees_attribute_access(tmp_path: Path):
    """The check above can fail: it sees ``m._x``, ``study.m._x`` and aliased imports."""
    known = {"study.kernels.k": tmp_path / "k.py", "study.solvers.s": tmp_path / "s.py"}
    known["study.solvers.s"].write_text(
        "import study.kernels.k\n"
        "from study.kernels import k as kernel\n"
        "import study.kernels.k as other\n"
        "kernel._a()\nstudy.kernels.k._b\nother.public\nother.__doc__\n",
        encoding="utf-8")
    found = attribute_reaches("study.solvers.s", known["study.solvers.s"], known)
    assert sorted(what for _, what in found if private(what)) == ["_a", "_b"]
    assert ("study.kernels.k", "public") in found


def test_imports_only_go_down_the_stages():
    """model < kernels < solvers < engine < scenes < analyses < figures < top."""
    assert not climbs(), sorted(climbs())


def test_the_stage_check_sees_a_climb():
    planted = {"study.engine.runner": {"study.scenes.scene_kind", "study.solvers.exact"},
               "study.model.drive": {"study.engine.spec_files"}}
    assert sorted(climbs(planted)) == [("study.engine.runner", "study.scenes.scene_kind"),
                                       ("study.model.drive", "study.engine.spec_files")]


def test_every_module_has_a_stage():
    for name in modules():
        assert stage(name) in STAGES


def test_kernels_import_only_kernels_and_the_codes():
    """The numba kernels depend on nothing but each other and the plain-int codes."""
    edges = graph()
    for name, targets in edges.items():
        if stage(name) != "kernels":
            continue
        outside = {t for t in targets
                   if stage(t) != "kernels" and t not in KERNEL_IMPORTS}
        assert not outside, (name, outside)


def test_only_the_solvers_call_the_kernels():
    """Kernels are reached through their wrappers in study/solvers/ (which validate and
    allocate); a constant the other stages need is declared in study/model/. No
    exception: the planar model's kernel is wrapped by study.solvers.planar too."""
    edges = graph()
    callers = {name for name, targets in edges.items()
               if stage(name) not in ("kernels", "solvers")
               and any(stage(t) == "kernels" for t in targets)}
    assert not callers, sorted(callers)


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
             "study.engine.cache_format", "study.engine.cache_sharing",
             "study.engine.cache_health", "study.engine.executors", "study.cli",
             "study.engine.validation", "study.engine.progress"}
    for name in ("study.studies.sweep", "study.studies.observables", "study.scenes.scene_kind",
                 "study.studies.spec", "study.engine.spec_files", "study.solvers.exact",
                 "study.solvers.integrator", "study.solvers.planar",
                 "study.solvers.planar_periodic", "study.scenes.planar_model"):
        reached, todo = set(), [name]
        while todo:
            for nxt in edges[todo.pop()]:
                if nxt not in reached:
                    reached.add(nxt)
                    todo.append(nxt)
        assert not reached & later, (name, reached & later)
        assert not any(m.startswith("study.figures") for m in reached), name


#: The most lines a module may have: past it a module holds more than one job, and the
#: next capability has to read all of them (issue 44 split the last ones).
MAX_MODULE_LINES = 900


def test_no_module_is_longer_than_one_job_needs():
    lengths = {name: len(path.read_text(encoding="utf-8").splitlines())
               for name, path in modules().items()}
    too_long = {name: n for name, n in lengths.items() if n > MAX_MODULE_LINES}
    assert not too_long, (f"modules over {MAX_MODULE_LINES} lines (split them by job): "
                          f"{too_long}")
    # The measure sees every module: the longest is within reach of the limit.
    assert max(lengths.values()) > MAX_MODULE_LINES // 2

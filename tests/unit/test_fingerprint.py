"""Code fingerprints from the import graph (study.engine.fingerprint): closures, staleness, CLI."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from study.engine.fingerprint import (
    RESULT_KIND_ENTRIES,
    code_fingerprint,
    import_closure,
    main,
    result_code_sha256,
)
from study.engine.provenance import code_sha256, scene_code_sha256

PACKAGE = Path(__file__).resolve().parents[2] / "study"
SCHEMAS = PACKAGE.parent / "results_schema"

NOT_COMPUTING = ("study.cli", "study.figures")


def copy_package(destination: Path) -> Path:
    """A scratch copy of the package (and the schemas next to it); its package folder."""
    shutil.copytree(PACKAGE, destination / "study",
                    ignore=shutil.ignore_patterns("__pycache__"))
    if SCHEMAS.is_dir():
        shutil.copytree(SCHEMAS, destination / "results_schema")
    return destination / "study"


@pytest.fixture(scope="module")
def copy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A scratch copy of ``study``; tests that edit it restore what they edit."""
    return copy_package(tmp_path_factory.mktemp("copy"))


def _source(root: Path, module: str) -> Path:
    base = root.joinpath(*module.split(".")[1:])
    return base / "__init__.py" if base.is_dir() else base.with_suffix(".py")


def test_study_closure_holds_every_computing_module():
    modules = code_fingerprint(RESULT_KIND_ENTRIES["study"]).modules
    for name in ("study.studies.sweep", "study.solvers.frontier", "study.solvers.exact",
                 "study.kernels.one_way",
                 "study.model.forces", "study.model.structure", "study.solvers.integrator",
                 "study.kernels.integrator", "study.model.status", "study", "study.kernels",
                 "study.model"):
        assert name in modules, name
    assert not [m for m in modules if m.startswith(NOT_COMPUTING)], modules


def test_scene_closure_holds_the_planar_model():
    modules = code_fingerprint(RESULT_KIND_ENTRIES["scene"]).modules
    for name in ("study.scenes.scene_kind", "study.scenes.scene_spec", "study.scenes.scene_run",
                 "study.scenes.planar_model", "study.kernels.planar_integrator",
                 "study.scenes.planner", "study.model.forces", "study.solvers.integrator",
                 "study.model.status"):
        assert name in modules, name
    assert not [m for m in modules if m.startswith(NOT_COMPUTING)], modules


def test_walker_follows_every_import_form(tmp_path: Path):
    root = tmp_path / "study"
    files = {
        "__init__.py": "",
        "entry.py": (
            "import os\n"
            "import study.plain\n"
            "from study.pkg import sub\n"            # sub is a submodule
            "from study.named import VALUE\n"        # VALUE is a name
            "from . import sibling\n"
            "from .rel import thing\n"
            "def late():\n"
            "    from study import lazy\n"          # function-level
            "    import importlib\n"
            "    importlib.import_module('study.dynamic')\n"
        ),
        "plain.py": "", "named.py": "VALUE = 1\n", "sibling.py": "", "rel.py": "thing = 2\n",
        "lazy.py": "", "dynamic.py": "", "unused.py": "",
        "pkg/__init__.py": "from .inner import x\n",
        "pkg/inner.py": "from .. import deep\nx = 1\n",
        "pkg/sub.py": "",
        "deep.py": "",
    }
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    assert import_closure(("study.entry",), root) == tuple(sorted(
        ["study", "study.entry", "study.plain", "study.pkg", "study.pkg.sub",
         "study.pkg.inner", "study.named", "study.sibling", "study.rel", "study.lazy",
         "study.dynamic", "study.deep"]
    ))


# Slow tier: an edit per closure module; the default tier keeps the headline
# (tests/integration/test_fingerprint_cli.py and test_kernel_cache.py, issue 46).
@pytest.mark.slow
def test_every_closure_module_edit_changes_its_kind_hash(copy: Path):
    for kind, entries in RESULT_KIND_ENTRIES.items():
        before = result_code_sha256(kind, copy)
        modules = code_fingerprint(entries, copy).modules
        assert modules == code_fingerprint(entries).modules
        for module in modules:
            path = _source(copy, module)
            original = path.read_bytes()
            path.write_bytes(original + b"\n# edited\n")
            try:
                assert result_code_sha256(kind, copy) != before, (kind, module)
            finally:
                path.write_bytes(original)
        assert result_code_sha256(kind, copy) == before


def test_cli_figures_and_schemas(copy: Path):
    before = {kind: result_code_sha256(kind, copy) for kind in RESULT_KIND_ENTRIES}
    edited = [copy / "cli.py", *sorted((copy / "figures").glob("*.py"))]
    originals = {path: path.read_bytes() for path in edited}
    try:
        for path in edited:
            path.write_bytes(originals[path] + b"\n# edited\n")
        for kind, sha in before.items():
            assert result_code_sha256(kind, copy) == sha, kind
    finally:
        for path, original in originals.items():
            path.write_bytes(original)
    # The schemas the spec layer reads do count.
    schema = sorted((copy / "schemas").glob("*.json"))[0]
    original = schema.read_bytes()
    schema.write_bytes(original + b"\n")
    try:
        for kind, sha in before.items():
            assert result_code_sha256(kind, copy) != sha, kind
    finally:
        schema.write_bytes(original)


def test_deterministic_and_order_free():
    entries = RESULT_KIND_ENTRIES["study"]
    first = code_fingerprint(entries, PACKAGE)
    assert code_fingerprint(entries, PACKAGE) == first
    assert first.sha256 == code_sha256() == result_code_sha256("study")
    assert result_code_sha256("scene") == scene_code_sha256()
    # Other entry tuples reaching the same modules hash the same modules.
    for other in (entries[::-1], (*entries, "study.solvers.exact", "study.studies.sweep")):
        again = code_fingerprint(other, PACKAGE)
        assert again.modules == first.modules
        assert again.sha256 == first.sha256
    assert set(first.libraries) == {"numpy", "numba", "llvmlite", "python", "machine"}


def test_unknown_kind_names_the_allowed_ones():
    with pytest.raises(ValueError, match="unknown result kind 'nope'; the kinds are 'study', "
                                         "'scene', 'fit', 'design'"):
        result_code_sha256("nope")
    with pytest.raises(ValueError, match=r"no source for module 'study\.missing'"):
        code_fingerprint(("study.missing",), PACKAGE)


def test_module_listing_for_humans(capsys: pytest.CaptureFixture[str]):
    assert main(["scene"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"scene: {result_code_sha256('scene')}\n")
    assert "    study.kernels.planar_integrator\n" in out
    assert "study.cli" not in out


def test_the_package_version_is_not_in_the_fingerprint(copy: Path,
                                                       monkeypatch: pytest.MonkeyPatch):
    """A version bump changes the installed version, never a result's code hash: the
    version is declared in pyproject.toml alone, not read from (or written into) a file
    of the package, whose sources the fingerprint hashes; and the fingerprint reads no
    metadata of study's own distribution."""
    import importlib.metadata
    import tomllib

    from study.version import DISTRIBUTION

    config = tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())
    declared = config["project"]["version"]
    assert "version" not in config["project"].get("dynamic", [])
    assert "version" not in config["tool"].get("setuptools", {}).get("dynamic", {})
    assert "setuptools_scm" not in config["tool"]  # it would write no file, but would compute
    # A result format names the release that first wrote it (``ResultFormat(3, "0.2.0",
    # ...)``): a fact about files, set when the format changes, not at a version bump.
    written = [path.relative_to(PACKAGE.parent) for path in sorted(PACKAGE.rglob("*"))
               if path.is_file() and path.suffix in (".py", ".json", ".txt", ".toml")
               and any(re.search(rf"""["']{re.escape(declared)}["']""", line)
                       and "ResultFormat(" not in line
                       for line in path.read_text().splitlines())]
    assert written == [], f"the version {declared} is written in {written}"
    before = {kind: code_fingerprint(entries, copy).sha256
              for kind, entries in RESULT_KIND_ENTRIES.items()}
    real = importlib.metadata.version
    asked: list[str] = []

    def tagged(name: str) -> str:
        asked.append(name)
        return "99.0.0" if name == DISTRIBUTION else real(name)

    monkeypatch.setattr(importlib.metadata, "version", tagged)
    after = {kind: code_fingerprint(entries, copy).sha256
             for kind, entries in RESULT_KIND_ENTRIES.items()}
    assert asked, "the fingerprint no longer reads library versions: the check is void"
    assert DISTRIBUTION not in asked
    assert after == before

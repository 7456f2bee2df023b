"""An installed (non-editable) ``study``: a wheel of this repo, in a fresh venv, run elsewhere.

The development venv holds ``study`` as an editable install (a path finder that
serves the repo's ``study/``), and the test process may have ``PYTHONPATH`` set to
a worktree. Either would hide a wheel that lacks files the package reads at run
time (the JSON schemas). So the checks run in a separate venv:

* The wheel is built from a copy of the repo's package and metadata in
  ``tmp_path`` (pip builds in the source tree; a copy keeps ``build/`` and
  ``*.egg-info`` out of the repo and stale ``build/lib`` files out of the wheel).
  With setuptools >= 77 in this interpreter (the ``test`` extra brings it) the
  build is offline (``--no-build-isolation --no-index``); otherwise pip builds in
  an isolated environment, which downloads setuptools.
* The venv is made with ``--without-pip`` (nothing downloaded). The dependencies
  come from this interpreter's site-packages through a ``.pth`` file: a path line
  in a ``.pth`` file only appends that folder to ``sys.path``; the ``.pth`` files
  inside it (the editable finder of ``study``, the distutils shim) are *not*
  executed, so the repo's ``study`` is not importable there. The first test checks
  exactly that.
* The wheel is installed with this interpreter's pip, ``pip --python NEW``
  (pip >= 22.3), with ``--no-deps --no-index``: pip writes the console script
  ``study`` and the RECORD itself, instead of a hand-rolled unpacking.
* Every subprocess runs with ``PYTHONPATH`` and ``PYTHONHOME`` removed from its
  environment, from a folder outside the repo.

A fresh install has no numba cache: the first solver or planar run compiles its
kernels (15-25 s each). So ``make test`` runs a closed-form study and validates a
scene file made by the development copy (every schema is read from the installed
copy either way); the runs that compile are ``slow``.
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

from study.version import DISTRIBUTION, UNKNOWN_VERSION

REPO = Path(__file__).resolve().parents[2]
SCHEMAS = sorted(p.name for p in (REPO / "study" / "schemas").glob("*.json"))

STRUCTURE = """
[structure]
f0 = 14.44   # Hz
Q = 17.5
alpha = 64.0 # degree
M = 0.08
cs = 0.25
"""

# Closed form only (no solver, nothing to compile): 3 frequencies.
CLOSED_FORM_SPEC = """\
[study]
name = "installed-closed-form"
title = "Thresholds run by an installed study"
observables = ["resonance", "thresholds", "lift_off"]
""" + STRUCTURE + """
[sweep]
f = { values = [12.0, 14.0, 16.0] }          # Hz
"""

# 3 frequencies x 3 accelerations through the steady solver.
VELOCITY_SPEC = """\
[study]
name = "installed-velocity"
title = "A 3 x 3 velocity study run by an installed study"
observables = ["thresholds", "lift_off", "velocity"]
""" + STRUCTURE + """
[sweep]
f = { values = [12.0, 14.0, 16.0] }          # Hz
a = { start = 4.0, stop = 8.0, num = 3 }     # m s-2
"""

# One short segment of the two-plate disk (workflows/steering.toml, cut down).
SCENE_SPEC = """\
[scene]
name = "installed-scene"
kind = "trajectory"
title = "A short trajectory run by an installed study"

[disk]
radius = 0.02
cs = 0.25

[[plate]]
name = "head"
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
direction = 0.0
attachment = [0.005, 0.0]

[[plate]]
name = "tail"
f0 = 7.7
Q = 10.0
alpha = 64.0
M = 0.08
direction = -90.0
attachment = [-0.02, 0.0]

[trajectory]
sample_interval = 0.1
start = [0.0, 0.0, 90.0]

[[segment]]
label = "forward"
f = 14.2
a = 7.0
duration = 0.5
"""

# Run inside the new venv: where study comes from, and what else is on the path.
PROBE = """\
import importlib.util, json, sys
import numpy, study, study.studies.spec
print(json.dumps({
    "study": study.__file__,
    "spec_schema": str(study.studies.spec.SPEC_SCHEMA_PATH),
    "spec_schema_exists": study.studies.spec.SPEC_SCHEMA_PATH.is_file(),
    "numpy": numpy.__file__,
    "editable_modules": sorted(m for m in sys.modules if "editable" in m),
    "editable_finders": [repr(f) for f in sys.meta_path if "editable" in repr(f).lower()],
    "path": sys.path,
    "prefix": sys.prefix,
}))
"""


def _clean_env() -> dict[str, str]:
    """This process's environment without what would put another ``study`` first."""
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}


def _run(args: list[str | Path], cwd: Path, timeout: float = 300.0):
    """Run a command; fail the test with its output if it exits non-zero."""
    done = subprocess.run([str(a) for a in args], cwd=cwd, env=_clean_env(), timeout=timeout,
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        pytest.fail(f"{' '.join(map(str, args))} exited {done.returncode}\n"
                    f"stdout:\n{done.stdout}\nstderr:\n{done.stderr}")
    return done


def _setuptools_major() -> int:
    try:
        return int(importlib.metadata.version("setuptools").split(".")[0])
    except importlib.metadata.PackageNotFoundError:
        return 0


def _inside(path: str | Path, folder: Path) -> bool:
    return Path(path).resolve().is_relative_to(folder.resolve())


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A wheel built from (a copy of) this repo."""
    root = tmp_path_factory.mktemp("wheel")
    source = root / "source"
    source.mkdir()
    # What the wheel is built from: the top-level files (pyproject.toml, README.md,
    # licence files) and the package; not results, caches or the venv, nor git's data
    # (in a worktree ``.git`` is a file): a tree without git information, which builds
    # as the version pyproject.toml declares.
    for item in REPO.iterdir():
        if item.is_file() and item.name != ".git":
            shutil.copy2(item, source / item.name)
    shutil.copytree(REPO / "study", source / "study",
                    ignore=shutil.ignore_patterns("__pycache__", "*.py[co]", "*.nbi", "*.nbc"))
    assert not (source / ".git").exists()
    dist = root / "dist"
    command = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--disable-pip-version-check",
               "--quiet", "--wheel-dir", dist]
    if _setuptools_major() >= 77:
        command += ["--no-build-isolation", "--no-index"]
    _run([*command, source], cwd=root)
    (built,) = dist.glob(f"{DISTRIBUTION.replace('-', '_')}-*.whl")
    return built


def _declared_version() -> str:
    """``[project] version`` of pyproject.toml, where the version is declared."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert project["name"] == DISTRIBUTION
    assert "version" not in project.get("dynamic", [])
    assert project["version"] != UNKNOWN_VERSION
    return project["version"]


@pytest.fixture(scope="module")
def venv(wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A fresh venv outside the repo with the wheel installed; dependencies borrowed."""
    root = tmp_path_factory.mktemp("venv")
    assert not _inside(root, REPO)
    new = root / "new"
    _run([sys.executable, "-m", "venv", "--without-pip", new], cwd=root)
    python = new / ("Scripts" if os.name == "nt" else "bin") / "python"
    paths = json.loads(_run([python, "-c", "import json, sysconfig; "
                                           "print(json.dumps(sysconfig.get_paths()))"],
                            cwd=root).stdout)
    # This interpreter's site-packages, as plain path lines (see the module docstring).
    borrowed = dict.fromkeys(sysconfig.get_paths()[k] for k in ("purelib", "platlib"))
    (Path(paths["purelib"]) / "study-test-dependencies.pth").write_text(
        "".join(f"{p}\n" for p in borrowed))
    _run([sys.executable, "-m", "pip", "--python", python, "install", "--no-deps", "--no-index",
          "--disable-pip-version-check", "--quiet", wheel], cwd=root)
    elsewhere = root / "elsewhere"
    elsewhere.mkdir()
    return {"prefix": new, "python": python, "scripts": Path(paths["scripts"]),
            "purelib": Path(paths["purelib"]), "elsewhere": elsewhere, "borrowed": list(borrowed)}


def test_the_wheel_ships_every_schema(wheel):
    assert SCHEMAS, "no schemas in study/schemas/"
    names = zipfile.ZipFile(wheel).namelist()
    missing = [s for s in SCHEMAS if f"study/schemas/{s}" not in names]
    assert not missing, f"{wheel.name} lacks {missing}"
    # Shipped byte for byte.
    with zipfile.ZipFile(wheel) as archive:
        for name in SCHEMAS:
            assert archive.read(f"study/schemas/{name}") == (
                REPO / "study" / "schemas" / name).read_bytes()


def test_the_venv_imports_the_installed_copy_not_the_repo(venv):
    probe = json.loads(_run([venv["python"], "-c", PROBE], cwd=venv["elsewhere"]).stdout)
    assert _inside(probe["study"], venv["purelib"]), probe["study"]
    assert probe["spec_schema_exists"]
    assert _inside(probe["spec_schema"], venv["purelib"])
    assert _inside(probe["prefix"], venv["prefix"])
    # The dev venv's editable finder was not activated by the borrowed path line...
    assert probe["editable_modules"] == []
    assert probe["editable_finders"] == []
    # ... its dependencies come from there, and no path entry serves the repo's package
    # (the dev venv may live in the repo: its site-packages holds no study/).
    assert not _inside(probe["numpy"], venv["prefix"])
    assert set(venv["borrowed"]) <= set(probe["path"])
    serving = [p for p in probe["path"]
               if (Path(p or venv["elsewhere"]) / "study").resolve() == (REPO / "study").resolve()]
    assert serving == [], probe["path"]


VERSION_PROBE = f"""\
import importlib.metadata, json, study, study.engine.provenance
print(json.dumps({{
    "metadata": importlib.metadata.version({DISTRIBUTION!r}),
    "study": study.__version__,
    "provenance": study.engine.provenance.package_version(),
}}))
"""


def test_a_tree_without_git_information_installs_as_the_declared_version(wheel, venv):
    """The wheel was built from a copy without ``.git``: it is the version pyproject.toml
    declares, which study reports as its own version, from the metadata of the
    distribution named in pyproject.toml."""
    declared = _declared_version()
    assert wheel.name.startswith(f"{DISTRIBUTION.replace('-', '_')}-{declared}-")
    found = json.loads(_run([venv["python"], "-c", VERSION_PROBE], cwd=venv["elsewhere"]).stdout)
    assert found == {"metadata": declared, "study": declared, "provenance": declared}


def test_the_installed_command_reports_the_declared_version(venv):
    done = _run([venv["scripts"] / "study", "--version"], cwd=venv["elsewhere"])
    assert done.stdout.split() == ["study", _declared_version()]


def _run_spec(venv: dict[str, Path], name: str, text: str) -> Path:
    """``study run``, ``validate`` and ``info`` of the installed command on one spec."""
    here = venv["elsewhere"] / name
    here.mkdir()
    (here / "spec.toml").write_text(text)
    study = venv["scripts"] / "study"
    _run([study, "run", "spec.toml", "-o", "out.nc"], cwd=here)
    assert (here / "out.nc").is_file()
    _run([study, "validate", "out.nc"], cwd=here)
    _run([study, "info", "out.nc"], cwd=here)
    return here / "out.nc"


def test_the_installed_command_runs_a_spec_from_another_folder(venv):
    _run_spec(venv, "closed-form", CLOSED_FORM_SPEC)


def test_the_installed_command_validates_a_scene_file(venv, tmp_path):
    from study.cli import main

    # Made by the development copy, whose numba cache is warm; read by the installed one.
    spec = tmp_path / "scene.toml"
    spec.write_text(SCENE_SPEC)
    made = tmp_path / "scene.nc"
    assert main(["run", str(spec), "-o", str(made)]) == 0
    here = venv["elsewhere"] / "scene-file"
    here.mkdir()
    shutil.copy2(made, here / "scene.nc")
    study = venv["scripts"] / "study"
    _run([study, "validate", "scene.nc"], cwd=here)
    _run([study, "info", "scene.nc"], cwd=here)


@pytest.mark.slow
def test_the_installed_command_runs_a_velocity_study(venv):
    _run_spec(venv, "velocity", VELOCITY_SPEC)


@pytest.mark.slow
def test_the_installed_command_runs_a_scene(venv):
    _run_spec(venv, "scene", SCENE_SPEC)

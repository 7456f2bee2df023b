"""Where a result came from: code, environment and the fingerprint that decides reruns."""

from __future__ import annotations

import hashlib
import platform
import socket
import subprocess
import sys
from datetime import UTC, datetime
from functools import cache
from importlib import metadata
from pathlib import Path
from typing import Any

from study.version import VERSION

__all__ = [
    "code_sha256",
    "environment",
    "fingerprint",
    "git_state",
    "kind_code_sha256",
    "package_version",
    "scene_code_sha256",
    "scene_fingerprint",
    "utc_now",
]

PACKAGE_DIR = Path(__file__).resolve().parents[1]


def utc_now() -> str:
    """The current time, ISO 8601 in UTC with a ``Z``, to the second."""
    return datetime.now(UTC).replace(microsecond=0).isoformat().replace("+00:00", "Z")


def kind_code_sha256(kind: str) -> str:
    """Hash of the code behind result kind ``kind`` (see :mod:`study.engine.fingerprint`)."""
    # Imported on first use: ``import study`` (which registers the kinds) must not import
    # the fingerprint module, or ``python -m study.engine.fingerprint`` would run it twice.
    from study.engine.fingerprint import result_code_sha256

    return result_code_sha256(kind)


def code_sha256() -> str:
    """Hash of the code behind parameter-study results (see :mod:`study.engine.fingerprint`).

    It covers every module that ``study.studies.sweep`` and ``study.solvers.frontier`` import, found
    from the import graph, so the solver and integrator versions are in it too.
    """
    return kind_code_sha256("study")


def scene_code_sha256() -> str:
    """Hash of the code behind steering scenes (see :mod:`study.engine.fingerprint`)."""
    return kind_code_sha256("scene")


def scene_fingerprint(spec_sha256: str) -> str:
    """What a scene result depends on: the canonical scene spec and its code."""
    return hashlib.sha256(f"{spec_sha256}:{scene_code_sha256()}".encode()).hexdigest()


def fingerprint(spec_sha256: str, code: str | None = None) -> str:
    """What a result depends on: the canonical spec and the computing code.

    Parameters
    ----------
    spec_sha256 : str
        Hash of the spec's canonical form.
    code : str, optional
        Code hash (default: this code's, :func:`code_sha256`).
    """
    code = code_sha256() if code is None else code
    return hashlib.sha256(f"{spec_sha256}:{code}".encode()).hexdigest()


def package_version() -> str:
    """Installed version of ``study`` (see :mod:`study.version`)."""
    return VERSION


@cache
def git_state() -> dict[str, Any]:
    """Commit and dirty flag of the checkout the package runs from, if it is one."""
    def git(*args: str) -> str:
        return subprocess.run(
            ["git", "-C", str(PACKAGE_DIR), *args],
            capture_output=True, text=True, check=True, timeout=10,
        ).stdout.strip()

    try:
        commit = git("rev-parse", "HEAD")
        dirty = bool(git("status", "--porcelain", "--untracked-files=no", "--", "."))
    except (OSError, subprocess.SubprocessError):
        return {"git_commit": "unknown", "git_dirty": "unknown"}
    return {"git_commit": commit, "git_dirty": dirty}


def _version(module: str) -> str:
    try:
        return metadata.version(module)
    except metadata.PackageNotFoundError:
        return "not installed"


@cache
def environment() -> dict[str, str]:
    """Versions of the interpreter, the libraries and the netCDF/HDF5 C libraries."""
    import netCDF4

    return {
        "python": platform.python_version(),
        "numpy": _version("numpy"),
        "numba": _version("numba"),
        "xarray": _version("xarray"),
        "dask": _version("dask"),
        "distributed": _version("distributed"),
        "netCDF4": _version("netCDF4"),
        "netcdf_c": str(netCDF4.__netcdf4libversion__),
        "hdf5": str(netCDF4.__hdf5libversion__),
        "platform": platform.platform(),
        "host": socket.gethostname(),
        "executable": sys.executable,
    }

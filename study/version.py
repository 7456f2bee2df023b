"""The package version, read from the installed distribution's metadata.

The version is made from git tags by setuptools-scm when the package is built or
installed (see ``[tool.setuptools_scm]`` in ``pyproject.toml``): ``0.1.0`` at tag
``v0.1.0``, ``0.1.1.devN+g<hash>`` N commits later. It is not written into any file of
the package, so making a tag changes no source file: the code fingerprint of results
(:mod:`study.engine.fingerprint`, which hashes the package's sources) does not move with it.
An editable install keeps the version it was installed with until it is reinstalled
(``pip install -e .``); the provenance of every result also records the git commit.
"""

from __future__ import annotations

from importlib import metadata

__all__ = ["DISTRIBUTION", "UNKNOWN_VERSION", "VERSION", "installed_version"]

#: The name of the distribution on the package index (``pyproject.toml``'s
#: ``[project] name``); the import name and the command are ``study``. Another
#: distribution called ``study`` (an unrelated project) must never be asked.
DISTRIBUTION = "stickslip-study"

#: The version of a ``study`` that runs without installed metadata (a source tree on
#: ``PYTHONPATH``); the same as ``fallback_version`` in ``pyproject.toml``, the version
#: of a build without git information. No release is 0.0: it means "unknown".
UNKNOWN_VERSION = "0.0"


def installed_version() -> str:
    """The version of the installed :data:`DISTRIBUTION`, else :data:`UNKNOWN_VERSION`."""
    try:
        return metadata.version(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        return UNKNOWN_VERSION


VERSION = installed_version()

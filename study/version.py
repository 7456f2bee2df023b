"""The package version, read from the installed distribution's metadata.

The version is declared once, as ``version`` in ``pyproject.toml``'s ``[project]`` table,
and bumped together with the newest ``## X.Y.Z - date`` heading of ``CHANGELOG.md`` and
the version of ``CITATION.cff``. Every tree of the repository builds as that version
(a clone, an archive, a copy without ``.git``); no git tag is needed. The version is not
written into any file of the package: the installer records it in the distribution's
metadata, which :data:`VERSION` reads, so a bump changes no source file and the code
fingerprint of results (:mod:`study.engine.fingerprint`, which hashes the package's
sources) does not move with it. An editable install keeps the version it was installed
with until it is reinstalled (``pip install -e .``; ``make`` reinstalls whenever
``pyproject.toml`` changes); the provenance of every result also records the git commit.
"""

from __future__ import annotations

from importlib import metadata

__all__ = ["DISTRIBUTION", "UNKNOWN_VERSION", "VERSION", "installed_version"]

#: The name of the distribution on the package index (``pyproject.toml``'s
#: ``[project] name``); the import name and the command are ``study``. Another
#: distribution called ``study`` (an unrelated project) must never be asked.
DISTRIBUTION = "stickslip-study"

#: The version of a ``study`` that runs without installed metadata (a source tree on
#: ``PYTHONPATH``, never installed). No release is 0.0: it means "unknown".
UNKNOWN_VERSION = "0.0"


def installed_version() -> str:
    """The version of the installed :data:`DISTRIBUTION`, else :data:`UNKNOWN_VERSION`."""
    try:
        return metadata.version(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        return UNKNOWN_VERSION


VERSION = installed_version()

"""The version is declared once and released in step: pyproject.toml's ``[project]``
``version``, the newest ``## X.Y.Z - date`` heading of CHANGELOG.md and CITATION.cff's
``version`` and ``date-released`` agree, and the installed package reports that version.
"""

from __future__ import annotations

import datetime
import json
import re
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
import yaml

import study
from study.version import DISTRIBUTION, UNKNOWN_VERSION, VERSION, installed_version

REPO = Path(__file__).resolve().parents[2]

#: A released section of CHANGELOG.md: ``## 0.2.0 - 2026-11-28`` (0.1.0 has no date).
RELEASE_HEADING = re.compile(r"^## (\d+\.\d+\.\d+)(?: - (\d{4}-\d{2}-\d{2}))?$")


def declared_version() -> str:
    return tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))[
        "project"]["version"]


def released(changelog: str) -> list[tuple[str, str | None]]:
    """The released sections of a changelog, as (version, date), in the file's order."""
    found = []
    for line in changelog.splitlines():
        if line.startswith("## "):
            match = RELEASE_HEADING.match(line.rstrip())
            assert match or line.rstrip() == "## Unreleased", f"not a release heading: {line!r}"
            if match:
                found.append((match[1], match[2]))
    return found


def newest_release() -> tuple[str, str | None]:
    releases = released((REPO / "CHANGELOG.md").read_text(encoding="utf-8"))
    assert releases, "CHANGELOG.md has no release heading"
    return releases[0]


def citation() -> dict:
    return yaml.safe_load((REPO / "CITATION.cff").read_text(encoding="utf-8"))


def _key(version: str) -> tuple[int, ...]:
    return tuple(int(part) for part in version.split("."))


def test_the_changelog_headings_are_read_newest_first():
    text = "# Changelog\n\n## Unreleased\n\n## 1.10.0 - 2027-01-02\n\n- x\n\n## 1.9.3\n"
    assert released(text) == [("1.10.0", "2027-01-02"), ("1.9.3", None)]
    with pytest.raises(AssertionError, match="not a release heading"):
        released("## v1.0.0\n")
    releases = released((REPO / "CHANGELOG.md").read_text(encoding="utf-8"))
    versions = [version for version, _ in releases]
    assert versions == sorted(versions, key=_key, reverse=True), versions
    assert len(set(versions)) == len(versions), versions


def test_pyproject_changelog_and_citation_declare_the_same_release():
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    # Declared, not computed at build time from git (or from a file in the package).
    assert "version" not in project.get("dynamic", [])
    version, date = newest_release()
    cited = citation()
    assert project["version"] == version == str(cited["version"])
    # The release is dated, and CITATION.cff gives the same date.
    assert date is not None, f"## {version} has no date"
    assert datetime.date.fromisoformat(date)
    assert str(cited["date-released"]) == date
    assert version != UNKNOWN_VERSION


def _installed_from_this_tree() -> metadata.Distribution:
    """The distribution :data:`study.version.VERSION` reads, if it was installed from this
    tree since the last change of pyproject.toml; otherwise the test is skipped, saying why.

    ``importlib.metadata`` finds the first one on ``sys.path``: the ``.dist-info`` of an
    install (its ``direct_url.json`` names the tree pip installed from), or, with the
    tree's folder on the path, the ``.egg-info`` the build wrote into the tree.
    """
    try:
        found = metadata.distribution(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        pytest.skip(f"{DISTRIBUTION} is not installed (the package runs from its sources)")
    folder = getattr(found, "_path", None)  # the .dist-info or .egg-info folder
    if folder is None:
        pytest.skip(f"{DISTRIBUTION} {found.version}: no metadata folder to read")
    folder = Path(folder)
    direct_url = found.read_text("direct_url.json")
    if direct_url:
        source = json.loads(direct_url).get("url")
        here = source == REPO.as_uri()
    else:
        source = str(folder.parent)
        here = folder.parent.resolve() == REPO.resolve()
    if not here:
        pytest.skip(f"{DISTRIBUTION} {found.version} is installed from {source}, "
                    f"not from this tree ({REPO})")
    written = folder / ("METADATA" if folder.suffix == ".dist-info" else "PKG-INFO")
    if (REPO / "pyproject.toml").stat().st_mtime > written.stat().st_mtime:
        pytest.skip(f"the installed metadata ({found.version}, {written}) is older than "
                    "pyproject.toml: reinstall (`make .venv/.installed` or `pip install -e .`)")
    return found


def test_the_installed_package_reports_the_declared_version():
    found = _installed_from_this_tree()
    declared = declared_version()
    assert found.version == declared
    assert VERSION == installed_version() == study.__version__ == declared

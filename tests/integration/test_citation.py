"""CITATION.cff: valid Citation File Format 1.2.0 naming this software, its release and
the paper whose model it computes.

The structure is checked against the fields CFF 1.2.0 requires (the file itself was
validated with ``cffconvert --validate``, which pins an old jsonschema and so is not a
test dependency); the release against the version pyproject.toml declares and the newest
release heading of CHANGELOG.md (tests/unit/test_version.py checks the same agreement,
with the dates).
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
import yaml
from packaging.version import Version

from study.version import DISTRIBUTION

REPO = Path(__file__).resolve().parents[2]
CITATION = REPO / "CITATION.cff"

PAPER_TITLE = "Controlled locomotion of a minimal soft structure by stick-slip nonlinearity"
PAPER_AUTHORS = ["Barois", "Boucherie", "Tadrist", "Kellay"]


@pytest.fixture(scope="module")
def citation() -> dict:
    return yaml.safe_load(CITATION.read_text(encoding="utf-8"))


def test_required_fields_of_cff_1_2_0(citation):
    assert citation["cff-version"] == "1.2.0"
    for key in ("message", "title", "authors"):
        assert citation[key], key
    assert citation["type"] == "software"
    for author in citation["authors"]:
        # A person has a family name, an entity a name (CFF 1.2.0).
        assert author.get("family-names") or author.get("name"), author
    for reference in citation.get("references", []):
        assert {"type", "title", "authors"} <= set(reference), reference


def test_names_this_software_and_its_licence(citation):
    assert DISTRIBUTION in citation["title"]
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert citation["license"] == project["license"]


def test_names_the_paper_it_implements(citation):
    papers = [r for r in citation["references"] if r["title"] == PAPER_TITLE]
    assert len(papers) == 1, citation["references"]
    (paper,) = papers
    assert paper["type"] == "article"
    assert [a["family-names"] for a in paper["authors"]] == PAPER_AUTHORS
    assert PAPER_TITLE in " ".join(citation["message"].split())


def _newest_changelog_release() -> str:
    """The version of the first ``## X.Y.Z`` heading of CHANGELOG.md (the newest release;
    ``## Unreleased`` above it is not one)."""
    for line in (REPO / "CHANGELOG.md").read_text(encoding="utf-8").splitlines():
        match = re.match(r"## (\d+\.\d+\.\d+)\b", line)
        if match:
            return match[1]
    pytest.fail("CHANGELOG.md has no `## X.Y.Z` release heading")


def test_the_version_is_the_declared_release(citation):
    """The cited version is a release, the one pyproject.toml declares and the newest
    CHANGELOG.md lists: the three are bumped together."""
    version = Version(str(citation["version"]))
    assert not (version.is_devrelease or version.is_prerelease or version.local), version
    assert re.fullmatch(r"\d+\.\d+\.\d+", str(citation["version"]))
    declared = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    assert str(citation["version"]) == declared == _newest_changelog_release()

"""Where a user's own files go, the README and the docs agree, and git ignores it; what
the README and the install page say ``make`` installs is what the Makefile installs;
the Makefile names each figure once."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_readme_and_the_own_structure_page_keep_specs_in_own() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split("## Your own structure", 1)[1].split("\n## ", 1)[0]
    assert "Save this spec as `own/own.toml`" in section
    assert ".venv/bin/study run own/own.toml -o own/own.nc" in section
    page = (ROOT / "docs" / "getting-started" / "own-structure.md").read_text(encoding="utf-8")
    assert "`own/own.toml`:" in page
    assert ".venv/bin/study run own/own.toml -o own/own.nc" in page


def test_git_ignores_the_own_folder() -> None:
    lines = [line.strip() for line in (ROOT / ".gitignore").read_text().splitlines()]
    assert "/own/" in lines


def test_the_install_page_names_the_extras_make_installs() -> None:
    makefile = (ROOT / "Makefile").read_text()
    extras = re.search(r"pip install --quiet -e '\.\[([a-z,]+)\]'", makefile)
    assert extras is not None
    page = (ROOT / "docs" / "getting-started" / "install.md").read_text(encoding="utf-8")
    assert f"pip install -e '.[{extras[1]}]'" in page
    named = set(re.findall(r"pip install -e '\.\[([a-z,]+)\]'", page))
    assert named == {extras[1]}


def _make_extras() -> list[str]:
    extras = re.search(r"pip install --quiet -e '\.\[([a-z,]+)\]'",
                       (ROOT / "Makefile").read_text())
    assert extras is not None
    return extras[1].split(",")


def test_the_readme_and_the_install_page_say_what_make_test_installs() -> None:
    """Both pages' ``make test`` line names the extras the Makefile installs (the README
    said "its test extra" while the Makefile installs test and docs, issue 47)."""
    extras = _make_extras()
    spoken = " and ".join(extras) + (" extras" if len(extras) > 1 else " extra")
    line = f"make test     # create .venv, install study with its {spoken}, lint, run the tests"
    for page in (ROOT / "README.md", ROOT / "docs" / "getting-started" / "install.md"):
        text = page.read_text(encoding="utf-8")
        assert line in text, page.name
        assert len(re.findall(r"^make test +#.*$", text, re.MULTILINE)) == 1, page.name


def test_the_makefile_names_each_figure_once() -> None:
    """``FIGURES += ...`` lines add figures no other line adds (``basins-flight
    basins-paper`` was added twice, with its comment)."""
    makefile = (ROOT / "Makefile").read_text().replace("\\\n", " ")  # continued lines
    names = [word for line in re.findall(r"^FIGURES \+?:?= (.*)$", makefile, re.MULTILINE)
             for word in line.split() if not word.startswith("$(")]
    assert {"thresholds", "steering-plan", "basins-flight"} <= set(names)
    assert len(names) == len(set(names)), sorted(n for n in names if names.count(n) > 1)

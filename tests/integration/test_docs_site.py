"""The documentation site's own machinery: API reference coverage, offline intersphinx, CLI page.

The full build (``make docs``: Sphinx with ``-W``, the example gallery executed) is run by
CI, not here; these tests check, quickly, what the build itself cannot tell:

* the API reference (docs/api/index.md) lists every name of ``study.__all__``, and no
  name that is not there (needs nothing but the page);
* the intersphinx inventories written offline (docs/_ext/offline_inventories.py) read
  back with Sphinx's own inventory reader and send the names the docs use to the URLs
  of each project's documentation, and docs/conf.py maps every project to such a local
  file (so the build never downloads);
* the CLI reference (docs/_ext/cli_reference.py) names every command, option and choice
  of the parser the ``study`` command runs.

The last two need Sphinx (the ``docs`` extra) and are skipped without it.
"""

from __future__ import annotations

import argparse
import importlib
import re
import runpy
import sys
from pathlib import Path

import pytest

import study

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
API_PAGE = DOCS / "api" / "index.md"

_CURRENT = re.compile(r"^\.\. (?:py:)?currentmodule:: (\S+)\s*$")
_AUTOSUMMARY = re.compile(r"^\.\. autosummary::\s*$")
_DATA = re.compile(r"^\.\. (?:py:)?data:: ([\w.]+)\.(\w+)\s*$")


def documented_names(text: str) -> dict[str, list[str]]:
    """module -> names listed in the page's autosummary tables under that current module,
    and described by a ``.. py:data:: MODULE.NAME`` directive.

    ``None`` (no current module) collects full names, such as the modules.
    """
    found: dict[str, list[str]] = {}
    module = "None"
    in_table = False
    for row in text.splitlines():
        current = _CURRENT.match(row)
        data = _DATA.match(row)
        if data:
            found.setdefault(data.group(1), []).append(data.group(2))
            in_table = False
        elif current:
            module, in_table = current.group(1), False
        elif _AUTOSUMMARY.match(row):
            in_table = True
        elif in_table:
            entry = row.strip()
            if row and not row.startswith(" "):
                in_table = False
            elif entry and not entry.startswith(":"):
                found.setdefault(module, []).append(entry)
    return found


def test_documented_names_are_read_from_autosummary_tables() -> None:
    text = ("```{eval-rst}\n.. currentmodule:: study\n\n.. autosummary::\n   :toctree: g\n\n"
            "   Structure\n   thresholds\n```\n\nprose Structure\n\n```{eval-rst}\n"
            ".. py:currentmodule:: None\n\n.. autosummary::\n   :toctree: g\n\n"
            "   study.analyses.fit\n"
            "```\n\n```{eval-rst}\n.. py:data:: study.__version__\n   :type: str\n\n"
            "   The version.\n```\n")
    assert documented_names(text) == {"study": ["Structure", "thresholds", "__version__"],
                                      "None": ["study.analyses.fit"]}


def test_the_api_reference_lists_every_public_name() -> None:
    names = documented_names(API_PAGE.read_text(encoding="utf-8"))
    listed = names.get("study", [])
    missing = sorted(set(study.__all__) - set(listed))
    unknown = sorted(set(listed) - set(study.__all__))
    assert not missing, f"{API_PAGE.relative_to(ROOT)} does not list study.{missing}"
    assert not unknown, f"{API_PAGE.relative_to(ROOT)} lists {unknown}, not in study.__all__"
    assert len(listed) == len(set(listed)), "a name is listed twice"


def test_the_api_reference_modules_exist_and_are_not_private() -> None:
    modules = documented_names(API_PAGE.read_text(encoding="utf-8")).get("None", [])
    assert "study.analyses.fit" in modules
    for module in modules:
        assert not any(part.startswith("_") for part in module.split("."))
        assert importlib.import_module(module).__all__, f"{module} has no __all__"


# --- Sphinx machinery (the docs extra) -------------------------------------------------

def _sphinx():
    return pytest.importorskip("sphinx", reason="Sphinx is not installed: the docs extra "
                               "(pip install -e '.[docs]') builds the site")


@pytest.fixture
def ext_path(monkeypatch):
    monkeypatch.syspath_prepend(str(DOCS / "_ext"))


def _read_inventory(path: Path, url: str) -> dict[str, dict[str, str]]:
    """role -> name -> URL, read by Sphinx's own inventory reader."""
    from sphinx.util.inventory import InventoryFile

    data = path.read_bytes()
    if hasattr(InventoryFile, "loads"):  # Sphinx >= 8.2
        inventory = InventoryFile.loads(data, uri=url).data
        return {role: {k: item.uri for k, item in items.items()}
                for role, items in inventory.items()}
    import io
    import posixpath

    inventory = InventoryFile.load(io.BytesIO(data), url, posixpath.join)
    return {role: {k: item[2] for k, item in items.items()} for role, items in inventory.items()}


#: (project, role, name, URL of that object in the project's own documentation).
KNOWN_URLS = [
    ("python", "py:class", "float", "https://docs.python.org/3/library/functions.html#float"),
    ("python", "py:class", "str", "https://docs.python.org/3/library/stdtypes.html#str"),
    ("python", "py:class", "pathlib.Path",
     "https://docs.python.org/3/library/pathlib.html#pathlib.Path"),
    ("python", "py:exception", "ValueError",
     "https://docs.python.org/3/library/exceptions.html#ValueError"),
    ("python", "std:label", "bltin-boolean-values",
     "https://docs.python.org/3/library/stdtypes.html#bltin-boolean-values"),
    ("numpy", "py:class", "numpy.ndarray",
     "https://numpy.org/doc/stable/reference/generated/numpy.ndarray.html#numpy.ndarray"),
    ("numpy", "py:function", "numpy.linspace",
     "https://numpy.org/doc/stable/reference/generated/numpy.linspace.html#numpy.linspace"),
    ("numpy", "py:class", "numpy.float64",
     "https://numpy.org/doc/stable/reference/arrays.scalars.html#numpy.float64"),
    ("numpy", "std:term", "array_like",
     "https://numpy.org/doc/stable/glossary.html#term-array_like"),
    ("xarray", "py:class", "xarray.Dataset",
     "https://docs.xarray.dev/en/stable/generated/xarray.Dataset.html#xarray.Dataset"),
    ("xarray", "py:function", "xarray.open_dataset",
     "https://docs.xarray.dev/en/stable/generated/xarray.open_dataset.html"
     "#xarray.open_dataset"),
    ("xarray", "py:method", "xarray.Dataset.sel",
     "https://docs.xarray.dev/en/stable/generated/xarray.Dataset.sel.html#xarray.Dataset.sel"),
    ("dask", "py:class", "dask.array.Array",
     "https://docs.dask.org/en/stable/generated/dask.array.Array.html#dask.array.Array"),
    ("distributed", "py:class", "distributed.Client",
     "https://distributed.dask.org/en/stable/api.html#distributed.Client"),
    ("distributed", "py:class", "dask.distributed.LocalCluster",
     "https://distributed.dask.org/en/stable/api.html#distributed.LocalCluster"),
]


def test_offline_inventories_send_names_to_their_projects_pages(tmp_path, ext_path) -> None:
    _sphinx()
    from offline_inventories import write_inventories

    mapping = write_inventories(tmp_path)
    assert set(mapping) == {"python", "numpy", "xarray", "dask", "distributed"}
    read = {project: _read_inventory(Path(path), url) for project, (url, path) in mapping.items()}
    for project, role, name, url in KNOWN_URLS:
        assert read[project].get(role, {}).get(name) == url, (project, role, name)
    # Only what the installed packages have: a name xarray does not define is absent.
    assert "xarray.NoSuchThing" not in read["xarray"]["py:class"]


def test_conf_maps_every_project_to_a_local_inventory(tmp_path, monkeypatch) -> None:
    _sphinx()
    monkeypatch.setenv("STUDY_DOCS_INVENTORIES", str(tmp_path))
    monkeypatch.setattr(sys, "path", list(sys.path))
    conf = runpy.run_path(str(DOCS / "conf.py"))
    mapping = conf["intersphinx_mapping"]
    assert {"python", "numpy", "xarray", "dask"} <= set(mapping)
    for project, (url, inventory) in mapping.items():
        assert url.startswith("https://"), project
        # A local file: intersphinx reads it and never downloads.
        assert Path(inventory).is_file() and Path(inventory).parent == tmp_path, project


def _options_and_commands(parser: argparse.ArgumentParser, prefix: str):
    """(command, every option string, choices, positional metavars) of a parser tree."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _options_and_commands(sub, f"{prefix} {name}")
        elif not isinstance(action, argparse._HelpAction):
            choices = [] if action.choices is None else [str(c) for c in action.choices]
            positional = [] if action.option_strings else [action.metavar or action.dest]
            yield prefix, list(action.option_strings), choices, positional


def test_the_cli_reference_names_every_command_and_option(tmp_path, ext_path) -> None:
    _sphinx()
    from sphinx.application import Sphinx

    from study.cli import build_parser

    source = tmp_path / "src"
    source.mkdir()
    (source / "conf.py").write_text('extensions = ["cli_reference"]\n')
    (source / "index.rst").write_text("CLI\n===\n\n.. cli-reference:: study.cli:build_parser\n")
    app = Sphinx(str(source), str(source), str(tmp_path / "out"), str(tmp_path / "doctrees"),
                 "text", status=None, warning=None, freshenv=True, warningiserror=True)
    app.build()
    page = (tmp_path / "out" / "index.txt").read_text(encoding="utf-8")
    # The text builder writes each section as a title underlined with "=", and each
    # argument as a quoted term line ("-o OUTPUT, --output OUTPUT") above its help.
    parts = re.split(r"^(study [\w-]+)\n=+\n", page, flags=re.MULTILINE)
    sections = {"study": parts[0], **dict(zip(parts[1::2], parts[2::2], strict=True))}
    parser = build_parser()
    commands = set()
    for command, options, choices, positional in _options_and_commands(parser, "study"):
        commands.add(command)
        assert command in sections, f"no section for {command}"
        terms = [t.split(", ")
                 for t in re.findall(r'^"(.+)"$', sections[command], re.MULTILINE)]
        spellings = [{word.split(" ")[0] for word in term} for term in terms]
        wanted = set(options) or set(positional)
        assert wanted in spellings, f"{command}: {sorted(wanted)} is not on the page"
        if choices:  # wrapped over lines, and at hyphens, by the text builder
            unwrapped = " ".join(re.sub(r"-\n\s+", "-", sections[command]).split())
            assert "choices: " + ", ".join(choices) in unwrapped, command
    assert {"study run", "study figure", "study fit", "study design"} <= commands
    assert set(sections) == commands | {"study"}
    assert parser.description in page

"""Every code block of the README and the documentation pages runs, every spec shown is valid.

The pages are README.md and every docs/**/*.md page (MyST markdown). In each page:

* Each ```python block runs verbatim, in a fresh namespace and a temporary working
  folder of its page, unless its first line is the comment ``# continues``: then it runs
  in the namespace of the block before it (so a reader can also paste it after that
  one). The first failing block of a page is reported with the page, its line and the
  error, as a reader would see them.
* Each ```toml block that is a spec (it has a ``[study]``, ``[scene]``, ``[fit]`` or
  ``[design]`` table) is read by the project's parser of that kind
  (:func:`study.studies.spec.parse_spec`, :func:`study.scenes.scene_spec.parse_scene`,
  :func:`study.analyses.fit_spec.parse_fit_spec`,
  :func:`study.analyses.design_spec.parse_design_spec`) and must be
  valid. A fit spec names measurement files, which a page does not ship: each is
  stood in for by a one-row valid file, so that the spec itself is checked in full.
  TOML blocks without such a table (fragments, ``pyproject.toml``) are not specs.

Shell blocks (```sh) are checked by ``tests/integration/test_doc_shell_blocks.py``: every
``study`` command parsed by the real parser, every ``make`` target known to make, the
README's own-structure example run as printed.
"""

from __future__ import annotations

import os
import re
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
CONTINUES = "# continues"
#: Folders of docs/ written by the docs build, not pages of ours.
GENERATED = ("gallery", "api/generated", "_build")
#: The top-level tables that make a TOML block a spec, and the kind each marks.
SPEC_TABLES = ("study", "scene", "fit", "design")

_FENCE = re.compile(
    r"^(?P<indent>[ ]*)(?P<fence>```+)[ ]*(?:\{code(?:-block)?\}[ ]*)?(?P<lang>[\w-]*)[^\n]*\n"
    r"(?P<body>.*?)^(?P=indent)(?P=fence)[ \t]*$",
    re.DOTALL | re.MULTILINE,
)


def pages() -> list[Path]:
    """README.md and every markdown page of docs/, generated folders left out."""
    found = [ROOT / "README.md"]
    for path in sorted(DOCS.rglob("*.md")):
        relative = path.relative_to(DOCS).as_posix()
        if not any(relative.startswith(folder + "/") for folder in GENERATED):
            found.append(path)
    return found


def blocks(text: str, language: str) -> list[tuple[int, str]]:
    """``(line number, code)`` of every fenced block of ``language``, in order.

    Fences may be indented (a block inside a list item) and written ```python or
    ```{code-block} python; the code is dedented by the fence's indentation.
    """
    found = []
    for match in _FENCE.finditer(text):
        if match.group("lang") == language:
            line = text.count("\n", 0, match.start()) + 1
            body = match.group("body")
            indent = match.group("indent")
            if indent:
                body = "".join(row[len(indent):] if row.startswith(indent) else row
                               for row in body.splitlines(keepends=True))
            found.append((line, body))
    return found


def name(path: Path) -> str:
    """A page's name in messages: its path in the repository (else its file name)."""
    return path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else path.name


def python_failure(path: Path, folder: Path) -> str | None:
    """The first python block of a page that fails, with its error; None if all run."""
    text = path.read_text(encoding="utf-8")
    namespace: dict = {}
    previous = Path.cwd()
    os.chdir(folder)
    try:
        for line, code in blocks(text, "python"):
            if not code.startswith(CONTINUES):
                namespace = {"__name__": "__doc_block__"}
            try:
                exec(compile(code, f"{name(path)}:{line}", "exec"), namespace)
            except Exception as err:  # the block and its error, as a reader would see them
                return (f"{name(path)} line {line}: the python block fails: "
                        f"{type(err).__name__}: {err}\n{code}")
    finally:
        os.chdir(previous)
    return None


def spec_kind(code: str) -> str | None:
    """The spec kind a TOML block is (its top table), or None for a block that is no spec."""
    import tomllib

    try:
        tables = tomllib.loads(code)
    except tomllib.TOMLDecodeError:
        # Not TOML a reader could use; a spec's parser says why below.
        tables = {kind: {} for kind in SPEC_TABLES
                  if re.search(rf"^\[{kind}\]", code, re.MULTILINE)}
    kinds = [kind for kind in SPEC_TABLES if isinstance(tables.get(kind), dict)]
    return kinds[0] if len(kinds) == 1 else ("several" if kinds else None)


def check_spec(code: str, where: str, folder: Path) -> None:
    """Parse a spec block with the project's parser of its kind (raises if invalid)."""
    import tomllib

    from study.analyses.design_spec import parse_design_spec
    from study.analyses.fit_spec import parse_fit_spec
    from study.scenes.scene_spec import parse_scene
    from study.studies.spec import parse_spec

    kind = spec_kind(code)
    if kind == "study":
        parse_spec(code, where)
    elif kind == "scene":
        parse_scene(code, where)
    elif kind == "design":
        parse_design_spec(code, where)
    elif kind == "fit":
        measurements = tomllib.loads(code)["fit"].get("measurements", [])
        for file_name in measurements if isinstance(measurements, list) else []:
            stand_in = folder / str(file_name)
            stand_in.parent.mkdir(parents=True, exist_ok=True)
            stand_in.write_text("quantity,value,sigma\nringdown_f0,14.4,0.1\n")
        parse_fit_spec(code, where, base=folder)
    elif kind == "several":
        raise ValueError(f"{where}: a spec has one of the tables "
                         f"{', '.join(f'[{t}]' for t in SPEC_TABLES)}, this block several")


def spec_failures(path: Path, folder: Path) -> list[str]:
    """Every spec block of a page that its parser refuses, with the parser's message."""
    failures = []
    for line, code in blocks(path.read_text(encoding="utf-8"), "toml"):
        if spec_kind(code) is None:
            continue
        where = f"{name(path)}:{line}"
        try:
            check_spec(code, where, folder / f"line-{line}")
        except Exception as err:
            failures.append(f"{where}: the {spec_kind(code)} spec is invalid: "
                            f"{type(err).__name__}: {err}")
    return failures


PAGES = pages()
PYTHON_PAGES = [p for p in PAGES if blocks(p.read_text(encoding="utf-8"), "python")]
SPEC_PAGES = [p for p in PAGES
              if any(spec_kind(c) for _, c in blocks(p.read_text(encoding="utf-8"), "toml"))]


def test_the_pages_are_found_and_have_blocks() -> None:
    assert PAGES[0].name == "README.md"
    assert any(p.parent == DOCS for p in PAGES), "no page of docs/ was found"
    readme = blocks(PAGES[0].read_text(encoding="utf-8"), "python")
    assert readme, "the README shows no python block"
    assert not readme[0][1].startswith(CONTINUES), "the first block has nothing to continue"
    assert PYTHON_PAGES and SPEC_PAGES


def test_block_extraction() -> None:
    text = ("x\n```python\na = 1\n```\n```sh\nls\n```\n```python\n# continues\nb = a\n```\n"
            "* item\n\n  ```{code-block} python\n  c = 3\n    d = 4\n  ```\n"
            "````markdown\n```python\nnot = 'a block of its own'\n```\n````\n")
    assert blocks(text, "python") == [
        (2, "a = 1\n"), (8, "# continues\nb = a\n"), (14, "c = 3\n  d = 4\n")]
    assert blocks(text, "sh") == [(5, "ls\n")]


def test_spec_kinds() -> None:
    assert spec_kind('[study]\nname = "x"\n') == "study"
    assert spec_kind("[fit]\n[structure]\nQ = 1\n") == "fit"
    assert spec_kind("[structure.mass]\nm0 = 1\n") is None  # a fragment, not a spec
    assert spec_kind("[build-system]\nrequires = []\n") is None
    assert spec_kind("[study]\nx = \n") == "study"  # broken TOML is still checked
    assert spec_kind("[study]\n[scene]\n") == "several"


def test_a_broken_block_is_reported(tmp_path: Path) -> None:
    """The checks can fail: a failing block, a broken chain and an invalid spec are named."""
    page = tmp_path / "broken.md"
    page_text = textwrap.dedent("""\
        # A page

        ```python
        a = 1
        ```

        ```python
        # continues
        assert a == 1
        b = undefined_name
        ```

        ```toml
        [study]
        name = "x"
        observables = ["velocity"]
        [structure]
        f0 = 14.44
        Q = 17.5
        alpha = 64.0
        M = 0.08
        cs = 0.25
        [sweep]
        f = { start = 10.0, stop = 20.0, num = 3 }
        a = { start = 0.0, stop = 12.0, num = 3 }
        frequency = 3
        ```

        ```toml
        [structure.mass]
        m0 = "fragment"
        ```
        """)
    page.write_text(page_text, encoding="utf-8")
    work = tmp_path / "work"
    work.mkdir()
    failure = python_failure(page, work)
    problems = spec_failures(page, work)
    assert failure is not None
    assert failure.startswith("broken.md line 7: the python block fails: NameError")
    assert len(problems) == 1  # the fragment is no spec
    assert problems[0].startswith("broken.md:13: the study spec is invalid")
    assert "frequency" in problems[0]


def test_a_valid_spec_of_each_kind_passes(tmp_path: Path) -> None:
    structure = "[structure]\nf0 = 14.44\nQ = 17.5\nalpha = 64.0\nM = 0.08\ncs = 0.25\n"
    study_spec = ('[study]\nname = "s"\nobservables = ["thresholds"]\n' + structure
                  + "[sweep]\nf = { start = 10.0, stop = 20.0, num = 3 }\n")
    fit_spec = ('[fit]\nname = "f"\nmeasurements = ["lab/m.csv"]\n'
                "free = { cs = [0.05, 1.0] }\n" + structure)
    design_spec = ('[design]\nname = "d"\n' + structure + "[free]\nf0 = [12.0, 17.0]\n"
                   '[[target]]\nf = 14.2\na = 7.0\nbehaviour = "forward"\n')
    scene_spec = (ROOT / "workflows" / "steering.toml").read_text(encoding="utf-8")
    for code in (study_spec, fit_spec, design_spec, scene_spec):
        check_spec(code, "<test>", tmp_path)
    with pytest.raises(Exception, match="free"):
        check_spec(fit_spec.replace("cs = [0.05, 1.0]", "cs = [1.0, 0.05]"), "<test>", tmp_path)


@pytest.mark.parametrize("page", PYTHON_PAGES, ids=name)
def test_every_python_block_runs_verbatim(page: Path, tmp_path: Path) -> None:
    failure = python_failure(page, tmp_path)
    if failure:
        pytest.fail(failure)


@pytest.mark.parametrize("page", SPEC_PAGES, ids=name)
def test_every_spec_shown_is_valid(page: Path, tmp_path: Path) -> None:
    failures = spec_failures(page, tmp_path)
    if failures:
        pytest.fail("\n".join(failures))

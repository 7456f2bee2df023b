"""Every ```python block of README.md runs verbatim.

The rule (also stated in the README, "Tests"): each block runs on its own, in a fresh
namespace and a temporary working folder, unless its first line is the comment
``# continues``, in which case it runs in the namespace of the block before it (so a
reader can also paste it after that one). Shell blocks (```sh) are not run here: the
commands they show are tested by ``tests/unit/test_cli.py`` and the study-run tests on
small specs, and ``make`` runs the workflows themselves.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[2] / "README.md"
CONTINUES = "# continues"

_BLOCK = re.compile(r"^```python\n(.*?)^```\s*$", re.DOTALL | re.MULTILINE)


def python_blocks(text: str) -> list[tuple[int, str]]:
    """``(line number, code)`` of every ```python block, in order."""
    return [(text.count("\n", 0, m.start()) + 1, m.group(1)) for m in _BLOCK.finditer(text)]


BLOCKS = python_blocks(README.read_text(encoding="utf-8"))


def test_the_readme_has_python_blocks() -> None:
    assert len(BLOCKS) >= 3
    assert not BLOCKS[0][1].startswith(CONTINUES), "the first block has nothing to continue"


def test_block_extraction() -> None:
    text = "x\n```python\na = 1\n```\n```sh\nls\n```\n```python\n# continues\nb = a\n```\n"
    assert python_blocks(text) == [(2, "a = 1\n"), (8, "# continues\nb = a\n")]


def test_every_python_block_runs_verbatim(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for line, code in BLOCKS:
        if not code.startswith(CONTINUES):
            namespace = {"__name__": "__readme__"}
        try:
            exec(compile(code, f"README.md:{line}", "exec"), namespace)
        except Exception as err:  # the block and its error, as a reader would see them
            pytest.fail(f"README.md line {line}: the python block fails: "
                        f"{type(err).__name__}: {err}\n{code}")

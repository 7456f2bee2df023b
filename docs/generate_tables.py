"""Write the tables the package declares into the documentation's pages.

``docs/user-guide/specs.md`` lists the observables, the contact laws and the parameters
as tables, each generated from its one declaration in the package. They are written
into the page itself, between two markers::

    <!-- table: observables (written by docs/generate_tables.py from
         study.studies.observable_table.markdown_table; do not edit) -->
    | observable | ... |
    <!-- end of table: observables -->

so that the page's source (the repository's view of it) shows them, not only the built
site. ``make schemas`` runs this script with the other generated files;
``tests/unit/test_docs_tables.py`` fails while a committed table differs from the one
its declaration gives.

Usage (from the Makefile)::

    python docs/generate_tables.py          # rewrite the tables that changed
    python docs/generate_tables.py --check  # exit 1, naming them, if any is stale
"""

from __future__ import annotations

import importlib
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

DOCS = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Table:
    """A generated table: its name (in the markers), the page that shows it and the
    package function that writes it."""

    name: str
    page: str
    source: str

    def generate(self) -> str:
        """The table as its declaration gives it (markdown, ending in a newline)."""
        module, function = self.source.rsplit(".", 1)
        write: Callable[[], str] = getattr(importlib.import_module(module), function)
        return write().rstrip("\n") + "\n"

    @property
    def opening(self) -> str:
        return (f"<!-- table: {self.name} (written by docs/generate_tables.py from "
                f"{self.source}; do not edit) -->")

    @property
    def closing(self) -> str:
        return f"<!-- end of table: {self.name} -->"


TABLES = (
    Table("observables", "user-guide/specs.md", "study.studies.observable_table.markdown_table"),
    Table("contact laws", "user-guide/specs.md", "study.model.contact.markdown_table"),
    Table("parameters", "user-guide/specs.md", "study.model.parameters.markdown_table"),
    Table("starts", "user-guide/specs.md", "study.model.starts.markdown_table"),
    Table("bifurcations", "theory/branches.md", "study.model.bifurcations.markdown_table"),
)


class TableError(ValueError):
    """A page whose markers of a table are missing or repeated."""


def _block(text: str, table: Table, page: Path) -> re.Match[str]:
    pattern = re.compile(re.escape(table.opening) + r"\n(.*?)" + re.escape(table.closing),
                         re.DOTALL)
    found = list(pattern.finditer(text))
    if len(found) != 1:
        raise TableError(
            f"{page}: {len(found)} blocks of the table {table.name!r}; allowed: exactly one, "
            f"from the line {table.opening!r} to the line {table.closing!r}")
    return found[0]


def committed(table: Table, docs: Path = DOCS) -> str:
    """The table as its page holds it now."""
    page = docs / table.page
    return _block(page.read_text(encoding="utf-8"), table, page)[1]


def rewritten(text: str, table: Table, page: Path) -> str:
    """``text`` (page ``page``) with the block of ``table`` replaced by the generated one."""
    block = _block(text, table, page)
    return text[:block.start(1)] + table.generate() + text[block.end(1):]


def stale(docs: Path = DOCS) -> list[Table]:
    """The tables whose committed text differs from the generated one."""
    return [table for table in TABLES if committed(table, docs) != table.generate()]


def write(docs: Path = DOCS) -> list[Table]:
    """Rewrite every stale table in its page; returns those rewritten."""
    changed = stale(docs)
    for page in sorted({table.page for table in changed}):
        path = docs / page
        text = path.read_text(encoding="utf-8")
        for table in (t for t in changed if t.page == page):
            text = rewritten(text, table, path)
        path.write_text(text, encoding="utf-8")
    return changed


def main(argv: list[str]) -> int:
    if argv not in ([], ["--check"]):
        print("usage: python docs/generate_tables.py [--check]", file=sys.stderr)
        return 2
    if argv == ["--check"]:
        old = stale()
        for table in old:
            print(f"docs/{table.page}: the table {table.name!r} differs from its declaration "
                  f"({table.source}); run `make schemas`", file=sys.stderr)
        return 1 if old else 0
    for table in write():
        print(f"docs/{table.page}: table {table.name!r} rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""The ``result-formats`` directive: the table of every result format, generated from the
kinds' declarations (``ResultKind.formats``, :class:`study.engine.kinds.ResultFormat`).

Usage in a MyST page::

    ```{result-formats}
    ```

One row per format of every kind: the attribute that records it, the release that first
wrote it, what it changed, the schema of its header and whether this version writes,
reads or refuses it. A new format declared in the code appears here by itself.
"""

from __future__ import annotations

from docutils import nodes
from sphinx.application import Sphinx
from sphinx.util.docutils import SphinxDirective

__all__ = ["ResultFormats", "setup"]


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def table_text() -> str:
    """The formats as a Markdown table."""
    import study  # noqa: F401  (the kinds register on import)
    from study.engine.kinds import RESULT_KINDS

    rows = ["| kind | attribute | format | first written by | what it changed | header "
            "schema | this version |", "|---|---|---|---|---|---|---|"]
    for kind in RESULT_KINDS.values():
        for result_format in kind.formats:
            current = result_format is kind.current_format
            released = not result_format.release.startswith("before")
            state = ("writes and reads" if current else
                     "reads by its own rules; `study upgrade` rewrites it" if released
                     else "refuses as stale where its units differ; rerun the spec")
            rows.append("| " + " | ".join(_cell(text) for text in (
                kind.name, f"`{kind.format_attribute}`", str(result_format.number),
                result_format.release, result_format.changes,
                f"`{result_format.schema}.schema.json`", state)) + " |")
    return "\n".join(rows)


class ResultFormats(SphinxDirective):
    """Generate the table of the result formats."""

    required_arguments = 0
    has_content = False

    def run(self) -> list[nodes.Node]:
        return self.parse_text_to_nodes(table_text())


def setup(app: Sphinx) -> dict[str, object]:
    app.add_directive("result-formats", ResultFormats)
    return {"parallel_read_safe": True, "parallel_write_safe": True}

"""The ``statuses`` directive: the table of every point status, generated from its one
declaration, :class:`study.model.status.Status` (code, meaning, what the velocity is).

Usage in a MyST page::

    ```{statuses}
    ```

A status added to the enum appears here by itself, as it does in the files'
``flag_meanings`` and in the figures' legends.
"""

from __future__ import annotations

from docutils import nodes
from sphinx.application import Sphinx
from sphinx.util.docutils import SphinxDirective

__all__ = ["Statuses", "setup"]


class Statuses(SphinxDirective):
    """Generate the table of the statuses."""

    required_arguments = 0
    has_content = False

    def run(self) -> list[nodes.Node]:
        from study.model.status import markdown_table

        return self.parse_text_to_nodes(markdown_table())


def setup(app: Sphinx) -> dict[str, object]:
    app.add_directive("statuses", Statuses)
    return {"parallel_read_safe": True, "parallel_write_safe": True}

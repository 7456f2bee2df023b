"""The ``cli-reference`` directive: a command-line reference generated from an argparse parser.

Usage in a MyST page::

    ```{cli-reference} study.cli:build_parser
    ```

writes the parser's description and usage, then one section per sub-command (its help,
description and usage) with every argument: its spellings and metavar, its help, the
allowed choices and the default. The text is taken as it is (never parsed as markup),
so what ``study COMMAND --help`` prints and what the page says cannot differ.
"""

from __future__ import annotations

import argparse
import importlib
import os
from collections.abc import Iterator

from docutils import nodes
from sphinx.application import Sphinx
from sphinx.util.docutils import SphinxDirective

__all__ = ["CliReference", "setup"]

#: Usage lines are wrapped at this width, whatever terminal builds the docs.
USAGE_WIDTH = 88


def _load(target: str) -> argparse.ArgumentParser:
    module_name, _, function = target.partition(":")
    if not function:
        raise ValueError(f"cli-reference: {target!r} is not MODULE:FUNCTION")
    return getattr(importlib.import_module(module_name), function)()


def _usage(parser: argparse.ArgumentParser) -> str:
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(USAGE_WIDTH)
    try:
        return parser.format_usage().strip()
    finally:
        if previous is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = previous


def _subcommands(parser: argparse.ArgumentParser
                 ) -> Iterator[tuple[str, str, argparse.ArgumentParser]]:
    """(name, one-line help, parser) of each sub-command, in the parser's order."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, helps.get(name, ""), sub


def _spelling(action: argparse.Action) -> str:
    if not action.option_strings:
        return action.metavar or action.dest
    if action.nargs == 0:
        return ", ".join(action.option_strings)
    metavar = action.metavar or action.dest.upper()
    return ", ".join(f"{option} {metavar}" for option in action.option_strings)


def _help(action: argparse.Action, prog: str) -> str:
    text = action.help or ""
    if "%" in text:
        text = text % dict(vars(action), prog=prog)
    return text


def _default_worth_saying(action: argparse.Action) -> bool:
    default = action.default
    return not (default is None or default is False or default == []
                or default == argparse.SUPPRESS or action.nargs == 0
                or "default" in (action.help or ""))


class CliReference(SphinxDirective):
    """Generate the reference of an argparse parser named ``MODULE:FUNCTION``."""

    required_arguments = 1
    has_content = False

    def run(self) -> list[nodes.Node]:
        parser = _load(self.arguments[0])
        out: list[nodes.Node] = []
        if parser.description:
            out.append(nodes.paragraph(text=parser.description))
        out.append(nodes.literal_block(text=_usage(parser), language="none"))
        out.extend(self._arguments(parser))
        for name, summary, sub in _subcommands(parser):
            out.append(self._section(f"{parser.prog} {name}", summary, sub))
        return out

    def _section(self, title: str, summary: str, parser: argparse.ArgumentParser
                 ) -> nodes.section:
        section = nodes.section(ids=[nodes.make_id(title)],
                                names=[nodes.fully_normalize_name(title)])
        section += nodes.title(text=title)
        if summary:
            section += nodes.paragraph(text=summary[:1].upper() + summary[1:] + ".")
        if parser.description:
            section += nodes.paragraph(text=parser.description)
        section += nodes.literal_block(text=_usage(parser), language="none")
        section.extend(self._arguments(parser))
        self.state.document.note_implicit_target(section, section)
        return section

    def _arguments(self, parser: argparse.ArgumentParser) -> list[nodes.Node]:
        items = nodes.definition_list()
        for action in parser._actions:
            if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
                continue
            if action.help == argparse.SUPPRESS:
                continue
            body = nodes.definition()
            help_text = _help(action, parser.prog)
            if help_text:
                body += nodes.paragraph(text=help_text)
            notes = []
            if action.choices is not None and not isinstance(action.choices, dict):
                notes.append("choices: " + ", ".join(map(str, action.choices)))
            if _default_worth_saying(action):
                notes.append(f"default: {action.default}")
            if action.required and action.option_strings:
                notes.append("required")
            if notes:
                body += nodes.paragraph(text="(" + "; ".join(notes) + ")")
            term = nodes.term()
            term += nodes.literal(text=_spelling(action))
            items += nodes.definition_list_item("", term, body)
        return [items] if len(items) else []


def setup(app: Sphinx) -> dict[str, object]:
    app.add_directive("cli-reference", CliReference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}

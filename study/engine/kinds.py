"""The kinds of result ``study`` writes: a registry that each kind fills from its own module.

A result kind (a parameter study, a steering scene, a fit, a design) registers once,
next to its own code, with :func:`register`: what a spec of that kind looks like
(its top table and spec schema), how to read one (its spec parser), how to compute
it and build its dataset, how to check a file of it (its validator), how to name
it for people (its description), the result schema its files carry and the modules
whose import closure computes it (the code fingerprint). The modules that register
are imported by ``import study`` (``study/__init__.py``):

==========  ====================================
study       :mod:`study.studies.kind`
scene       :mod:`study.scenes.scene_kind`
fit         :mod:`study.analyses.fit`
design      :mod:`study.analyses.design`
==========  ====================================

The spec layer (which kind a TOML file is), the runner, validation, ``study info``,
the fingerprint and the CLI look kinds up here and call their hooks; none of them
branches on a kind, and the engine imports no scene or analysis module.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "RESULT_KINDS",
    "ResultFormat",
    "ResultKind",
    "UnknownKind",
    "kind_named",
    "kind_of_schema",
    "kind_of_spec",
    "kind_of_table",
    "register",
    "registered",
]


class UnknownKind(ValueError):
    """A kind, a spec object or a result schema that no registered kind has."""


@dataclass(frozen=True)
class ResultFormat:
    """One version of the layout of a kind's files (global attribute
    ``study_result_format``; a file without it is its kind's first format).

    A format changes only by a deliberate act: a new :class:`ResultFormat` appended to
    its kind's ``formats``, its header schema frozen in ``results_schema/`` and, for an
    older format that can be rewritten without recomputation, an ``upgrade`` step. A
    file of an older format is checked by the rules of the format it was written in;
    one of a newer format than this version knows is refused with what to do.

    Attributes
    ----------
    number : int
        The value of ``study_result_format``: 1, 2, ...
    release : str
        The first release of ``stickslip-study`` that wrote it (``"0.1.0"``).
    changes : str
        What it changed from the format before (one line, for people).
    schema : str
        Stem of the JSON schema of its header in ``study/schemas/`` (and
        ``results_schema/``): ``<result schema>.format-<number>`` for an older format,
        the kind's own ``result_schema`` for the current one.
    upgrade : str
        ``"module:function"`` of ``upgrade(nc) -> None`` that rewrites, in place, an open
        file (netCDF4, append mode) of the format before into this one without
        recomputing a value; empty where the step needs nothing but the new
        ``study_result_format``.
    """

    number: int
    release: str
    changes: str
    schema: str
    upgrade: str = ""

    def upgrade_file(self, nc: Any) -> None:
        """Rewrite an open file of the format before into this one (:attr:`upgrade`)."""
        if self.upgrade:
            module, function = self.upgrade.split(":")
            getattr(importlib.import_module(module), function)(nc)


def _no_inputs(spec: Any) -> list[str]:
    return [str(spec.path)]


def _one_unit(spec: Any) -> int:
    return 1


@dataclass(frozen=True)
class ResultKind:
    """One kind of result and the hooks the engine calls for it.

    Attributes
    ----------
    name : str
        ``"study"``, ``"scene"``, ``"fit"`` or ``"design"``.
    spec_table : str
        The top-level TOML table that marks a spec of this kind.
    spec_schema : str
        Name of the JSON schema of its specs (``study/schemas/<name>.schema.json``).
    result_schema : str
        Value of the ``study_result_schema`` attribute of its files (and the name of
        the JSON schema of their header).
    entry_modules : tuple of str
        Modules whose import closure decides the numbers (see :mod:`study.engine.fingerprint`).
    summary : str
        One line for docs and ``study info``.
    label : str
        What ``study validate`` calls a valid file: ``"study result"``, ...
    spec_type : type
        The class of its parsed specs (the runner finds a spec's kind by it).
    load : callable
        ``load(path) -> spec``: read and validate a spec file.
    parse : callable
        ``parse(text, source) -> spec``: read a spec from its text (a file's embedded spec).
    validator : str
        ``"module:function"`` of ``problems(nc, meta, source, written) -> list[str]``
        (``written``: the file's :class:`ResultFormat`, whose rules apply), imported on
        first use: the checks read netCDF through :mod:`study.engine.validation`, which the
        computing modules that register kinds must not import.
    name_attribute : str
        Global attribute that names the result (``study info``).
    compute : callable, optional
        ``compute(spec, progress) -> result``; ``progress`` is a
        :class:`study.engine.progress.Progress` (``update(work)``, ``say(line)``).
    build : callable, optional
        ``build(spec, result, command) -> xarray.Dataset``: the dataset written.
    stream : callable, optional
        ``stream(spec, job) -> RunReport``: for a kind that writes its file as it computes
        (a study, chunk by chunk) instead of ``compute`` and ``build``.
    work : callable, optional
        ``work(spec) -> (total, unit)`` for a progress bar; None: progress in lines.
    variant : callable, optional
        ``variant(spec) -> str``: which sort of this kind a spec is (a scene's
        ``"trajectory"``), shown as ``RunReport.kind == "scene:trajectory"``.
    variant_attribute : str, optional
        Global attribute of its files that holds the variant (``study info``).
    metadata : callable, optional
        ``metadata(spec) -> dict``: attributes that follow the spec's text but not its
        numbers (rewritten without recomputing); None: the kind is always recomputed.
    own_provenance : bool
        The builder writes the kind's provenance itself (its layout fixed by its result
        schema); otherwise the runner adds the common provenance attributes.
    inputs : callable
        ``inputs(spec) -> list of str``: files a run reads (never replaced by its output).
    size : callable
        ``size(spec) -> int``: chunks a run of it counts (1 but for studies).
    formats : tuple of ResultFormat
        Every format its files were ever written in, oldest first; the last is the one
        this version writes.
    format_attribute : str
        The global attribute that holds a file's format number (a file without it is
        the first format).
    """

    name: str
    spec_table: str
    spec_schema: str
    result_schema: str
    entry_modules: tuple[str, ...]
    summary: str
    label: str
    spec_type: type
    load: Callable[[Any], Any]
    parse: Callable[[str, str], Any]
    validator: str
    name_attribute: str = "study_name"
    compute: Callable[[Any, Any], Any] | None = None
    build: Callable[[Any, Any, str], Any] | None = None
    stream: Callable[[Any, Any], Any] | None = None
    work: Callable[[Any], tuple[float, str]] | None = None
    variant: Callable[[Any], str] | None = None
    variant_attribute: str | None = None
    metadata: Callable[[Any], dict[str, Any]] | None = None
    own_provenance: bool = False
    inputs: Callable[[Any], list[str]] = field(default=_no_inputs)
    size: Callable[[Any], int] = field(default=_one_unit)
    formats: tuple[ResultFormat, ...] = ()
    format_attribute: str = "study_result_format"

    def __post_init__(self) -> None:
        if not self.formats:
            object.__setattr__(self, "formats", (ResultFormat(
                1, "0.1.0", "the first format", self.result_schema),))
        numbers = [f.number for f in self.formats]
        if numbers != list(range(numbers[0], numbers[0] + len(numbers))):
            raise ValueError(f"result kind {self.name!r}: formats {numbers} must count up "
                             "by one, oldest first")
        if self.formats[-1].schema != self.result_schema:
            raise ValueError(f"result kind {self.name!r}: its current format's schema is "
                             f"{self.formats[-1].schema!r}, not {self.result_schema!r}")

    @property
    def current_format(self) -> ResultFormat:
        """The format this version writes."""
        return self.formats[-1]

    def format_numbered(self, number: int) -> ResultFormat | None:
        """The declared format ``number``, if any."""
        return next((f for f in self.formats if f.number == number), None)

    def problems(self, nc: Any, meta: Any, source: str, written: ResultFormat) -> list[str]:
        """What is wrong with a file of this kind written in format ``written`` (its
        registered validator, which checks it by that format's rules)."""
        module, function = self.validator.split(":")
        return getattr(importlib.import_module(module), function)(nc, meta, source, written)


#: name -> ResultKind, in the order the kinds registered.
RESULT_KINDS: dict[str, ResultKind] = {}


def register(kind: ResultKind) -> ResultKind:
    """Add a kind (once: a second kind of the same name, table, schema or spec class is
    refused, naming both)."""
    for other in RESULT_KINDS.values():
        for key in ("name", "spec_table", "result_schema", "spec_type"):
            if getattr(other, key) == getattr(kind, key) and other is not kind:
                raise ValueError(f"result kind {kind.name!r}: its {key} "
                                 f"{getattr(kind, key)!r} is already kind {other.name!r}'s")
    RESULT_KINDS[kind.name] = kind
    return kind


def registered() -> str:
    """The registered kinds, for messages: ``'study', 'scene', 'fit', 'design'``."""
    return ", ".join(repr(name) for name in RESULT_KINDS) or "none (import study first)"


def kind_named(name: str) -> ResultKind:
    """The kind called ``name``; :class:`UnknownKind` names the registered ones."""
    try:
        return RESULT_KINDS[name]
    except KeyError:
        raise UnknownKind(f"unknown result kind {name!r}; the kinds are {registered()}") from None


def kind_of_schema(result_schema: str) -> ResultKind | None:
    """The kind whose files carry ``study_result_schema == result_schema``, if any."""
    return next((k for k in RESULT_KINDS.values() if k.result_schema == result_schema), None)


def kind_of_spec(spec: Any) -> ResultKind:
    """The kind of a parsed spec, found by its class."""
    kind = next((k for k in RESULT_KINDS.values() if type(spec) is k.spec_type), None)
    if kind is None:
        raise UnknownKind(f"{type(spec).__name__} is not the spec of a result kind; the kinds "
                          f"are {registered()}")
    return kind


def kind_of_table(raw: Mapping[str, Any], path: str) -> ResultKind:
    """The kind of a parsed TOML document: the one kind whose top table it has.

    Raises
    ------
    UnknownKind
        Naming the file, the tables found and the tables of every kind.
    """
    found = [k for k in RESULT_KINDS.values() if k.spec_table in raw]
    tables = " or ".join(f"[{k.spec_table}]" for k in RESULT_KINDS.values())
    if len(found) > 1:
        both = " and ".join(f"[{k.spec_table}]" for k in found)
        raise UnknownKind(f"{path}: both {both} tables; a spec is one of them ({tables})")
    if found and isinstance(raw[found[0].spec_table], dict):
        return found[0]
    if found:
        raise UnknownKind(f"{path}: [{found[0].spec_table}] must be a table, not a value")
    present = ", ".join(sorted(map(repr, raw))) or "none"
    raise UnknownKind(f"{path}: not a spec of a result kind ({registered()}): it needs a "
                      f"{tables} table (top-level tables found: {present})")

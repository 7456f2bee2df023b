"""The kinds of result ``study`` writes, declared once.

A result kind ties together what a spec of that kind looks like (its top table and
spec schema), the result schema its files carry, and the modules whose import
closure computes it (the code fingerprint). The spec layer, the runner, the
fingerprint and validation each look kinds up here by name; each stage keeps its
own implementation for a kind next to its other code, keyed by the same name.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["RESULT_KINDS", "ResultKind", "kind_of_schema"]


@dataclass(frozen=True)
class ResultKind:
    """One kind of result.

    Attributes
    ----------
    name : str
        ``"study"`` or ``"scene"``.
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
    """

    name: str
    spec_table: str
    spec_schema: str
    result_schema: str
    entry_modules: tuple[str, ...]
    summary: str


_DECLARED = (
    ResultKind("study", "study", "study-spec-v1", "study-result-v1",
               ("study.engine.sweep", "study.solvers.frontier", "study.engine.study_spec"),
               "parameter study: observables over swept structure and drive parameters"),
    ResultKind("scene", "scene", "study-scene-spec-v1", "study-scene-v1",
               ("study.scenes.scene_kind",),
               "steering scene of the planar disk: trajectory, calibration or plan"),
)

#: name -> ResultKind.
RESULT_KINDS: dict[str, ResultKind] = {k.name: k for k in _DECLARED}


def kind_of_schema(result_schema: str) -> ResultKind | None:
    """The kind whose files carry ``study_result_schema == result_schema``, if any."""
    return next((k for k in _DECLARED if k.result_schema == result_schema), None)

"""``study upgrade``: rewrite a result file of an older format in today's format
without recomputing it.

The file is checked by the rules of the format it was written in, copied beside the
output, taken through each format step its kind declares
(:attr:`study.engine.kinds.ResultFormat.upgrade`), given a line of history, sealed (its
content checksum recomputed, then validated by today's rules) and renamed over the
output. Its values, its provenance (the run that computed them) and its fingerprint are
kept: an upgraded file is as stale or as current as the one it came from, and
``study run`` recomputes it when the spec or the code changed. The input is never
modified.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from study.engine.kinds import ResultKind, kind_of_schema
from study.engine.outputs import check_output
from study.engine.provenance import utc_now
from study.engine.store import commit, exclusive, new_temporary
from study.engine.validation.files import validate_file
from study.engine.validation.formats import written_by, written_format
from study.engine.validation.reading import (
    LIBRARY_ERRORS,
    ResultError,
    open_netcdf,
    read_attributes,
    unreadable,
)
from study.version import VERSION

__all__ = ["UpgradeReport", "upgrade_result"]


@dataclass(frozen=True)
class UpgradeReport:
    """What :func:`upgrade_result` did.

    Attributes
    ----------
    source, output : pathlib.Path
    kind : ResultKind
    from_format, to_format : int
        The file's format before and after (equal: it was current, and was copied).
    written_by : str
        The version of study that wrote the file.
    """

    source: Path
    output: Path
    kind: ResultKind
    from_format: int
    to_format: int
    written_by: str

    @property
    def summary(self) -> str:
        """One line for people."""
        if self.from_format == self.to_format:
            return (f"{self.output}: {self.source} is already in today's {self.kind.label} "
                    f"format {self.to_format}; copied unchanged")
        return (f"{self.output}: {self.kind.label} upgraded from format {self.from_format} "
                f"(study {self.written_by}) to format {self.to_format} (study {VERSION}); "
                "values, provenance and fingerprint kept, nothing recomputed")


def upgrade_result(source: str | Path, output: str | Path, *, command: str = "",
                   overwrite: bool = False) -> UpgradeReport:
    """Rewrite the result file ``source`` in today's format as ``output``.

    Parameters
    ----------
    source : path
        A result file of any kind written by this or an earlier version of study.
    output : path
        The file to write (never ``source`` itself; an existing file only if it is a
        result of the same kind, or with ``overwrite``).
    command : str
        The command line recorded in the file's history.
    overwrite : bool
        Replace an existing file at ``output`` that is not a result of this kind.

    Raises
    ------
    ResultError
        ``source`` does not validate by the rules of its own format, or was written by
        a later version of study.
    OutputError
        ``output`` is ``source``, a folder, or a file of another kind.
    """
    source, output = Path(source), Path(output)
    validate_file(source)
    attrs = read_attributes(source)
    kind = kind_of_schema(str(attrs.get("study_result_schema")))
    if kind is None:  # validate_file refuses it first
        raise ResultError(f"{source}: not a result file of a known kind")
    written = written_format(kind, attrs, source)
    check_output(output, kind.result_schema, inputs=[source], overwrite=overwrite)
    steps = [f for f in kind.formats if f.number > written.number]
    current = kind.current_format.number
    with exclusive(output):
        temporary = new_temporary(output)
        try:
            shutil.copyfile(source, temporary)
            if steps:
                _apply(temporary, kind, steps, written.number, command or
                       f"study upgrade {source} -o {output}")
        except BaseException:
            temporary.unlink(missing_ok=True)
            raise
        commit(temporary, output)
    return UpgradeReport(source, output, kind, written.number, current,
                         written_by(attrs))


def _apply(path: Path, kind: ResultKind, steps: list, before: int, command: str) -> None:
    nc = open_netcdf(path, "a")
    try:
        for step in steps:
            step.upgrade_file(nc)
            nc.setncattr(kind.format_attribute, step.number)
        now = utc_now()
        history = str(nc.getncattr("history")) if "history" in nc.ncattrs() else ""
        line = (f"{now}: {command} (format {before} -> {steps[-1].number} by study "
                f"{VERSION}; values unchanged, nothing recomputed)")
        nc.setncattr("history", f"{history}\n{line}".strip())
        if "date_modified" in nc.ncattrs():
            nc.setncattr("date_modified", now)
    except LIBRARY_ERRORS as err:
        raise unreadable(path, err) from None
    finally:
        nc.close()

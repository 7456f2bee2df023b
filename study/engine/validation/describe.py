"""What a result file holds, for people (``study info``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from study.engine.contact_attributes import method_summary
from study.engine.kinds import kind_of_schema
from study.engine.validation.checks import is_number
from study.engine.validation.formats import format_note, written_by
from study.engine.validation.reading import slabs, unreadable

__all__ = ["describe"]


def _format(value: Any) -> str:
    """A number as ``%.6g``, anything else as text."""
    if is_number(value):
        return f"{float(value):.6g}"
    return str(value)


def _flag_counts(variable: xr.DataArray) -> str:
    """``name share (count)`` of every value a flag variable holds, read in slabs."""
    counts: dict[Any, int] = {}
    for index in slabs(tuple(variable.shape), variable.dtype.itemsize):
        values = np.asarray(variable[index[0] if index == (Ellipsis,) else index].values)
        for value, count in zip(*np.unique(values, return_counts=True), strict=True):
            counts[value.item()] = counts.get(value.item(), 0) + int(count)
    names: dict[Any, str] = {}
    try:
        codes = np.atleast_1d(np.asarray(variable.attrs.get("flag_values"))).tolist()
        meanings = str(variable.attrs.get("flag_meanings", "")).split()
        names = dict(zip(codes, meanings, strict=False))
    except (TypeError, ValueError):
        names = {}
    total = sum(counts.values()) or 1
    return ", ".join(f"{names.get(value, f'value {value}')} {count / total:.1%} ({count})"
                     for value, count in sorted(counts.items()))


def _provenance_of(attrs: dict[str, Any]) -> dict[str, Any]:
    try:
        document = json.loads(str(attrs.get("provenance", "{}")))
    except (ValueError, RecursionError):
        return {}
    return document if isinstance(document, dict) else {}


def _section(document: dict[str, Any], key: str) -> dict[str, Any]:
    value = document.get(key)
    return value if isinstance(value, dict) else {}


def _describe_dataset(dataset: xr.Dataset, path: str) -> str:
    attrs = dataset.attrs
    provenance = _provenance_of(attrs)
    run = _section(provenance, "run")
    package = _section(provenance, "package")
    lines = [f"{path or attrs.get('study_name')}: {attrs.get('title')}"]
    schema = attrs.get("study_result_schema")
    result_kind = kind_of_schema(schema) if isinstance(schema, str) else None
    # Each kind names its results by its own attribute (a fit by its fit spec's name),
    # and a scene says which sort of scene it is.
    what = result_kind.name if result_kind else "study"
    name = attrs.get(result_kind.name_attribute if result_kind else "study_name")
    variant = attrs.get(result_kind.variant_attribute) if (
        result_kind and result_kind.variant_attribute) else None
    kind = variant if isinstance(variant, str) else ""
    coupling = attrs.get("study_coupling")
    lines.append(f"  {what} {name!r}"
                 f"{f' ({kind})' if kind else ''}"
                 f"{f', {coupling} coupling' if isinstance(coupling, str) else ''}, "
                 "spec sha256 "
                 f"{str(attrs.get('study_spec_sha256', ''))[:16]}, schema "
                 f"{attrs.get('study_result_schema')}")
    # Every kind's method: its contact laws
    # (study.engine.contact_attributes.contact_law_attributes);
    # only a study chooses a solver, the other kinds' models are fixed.
    lines.append(f"  method: {method_summary(attrs, dataset.dims, solver=what == 'study')}")
    try:
        warnings = json.loads(str(attrs.get("study_warnings", "[]")))
    except ValueError:
        warnings = []
    lines += [f"  warning: {w}" for w in (warnings if isinstance(warnings, list) else [])]
    if result_kind is not None:
        note = format_note(result_kind, attrs, path or str(attrs.get("study_name")))
        lines += [f"  {note}"] if note else []
    for name, size in dataset.sizes.items():
        if name not in dataset.coords:
            lines.append(f"  dim {name!s:>7}: {size:6d}")
            continue
        coord = dataset[name]
        if coord.dtype.kind not in "iuf" or size == 0:
            shown = ", ".join(_format(v) for v in coord.values[:12])
            lines.append(f"  axis {name!s:>6}: {shown}{', ...' if size > 12 else ''}")
            continue
        lines.append(
            f"  axis {name!s:>6}: {size:6d} values, {_format(coord.values.min())} .. "
            f"{_format(coord.values.max())} {coord.attrs.get('units', '')}")
    for name, coord in dataset.coords.items():
        if coord.ndim == 1 and name not in dataset.dims:
            shown = ", ".join(_format(v) for v in coord.values[:12])
            lines.append(f"  {name} along {coord.dims[0]}: {shown}"
                         f"{', ...' if coord.size > 12 else ''} {coord.attrs.get('units', '')}")
    fixed = [f"{name}={_format(dataset[name].values.item())}" for name in dataset.coords
             if dataset[name].ndim == 0]
    if fixed:
        lines.append("  fixed: " + ", ".join(fixed))
    for name, var in dataset.data_vars.items():
        # Values in each parameter's own units name the variable that holds them.
        units = var.attrs.get("units", "")
        if "units" not in var.attrs and "units_variable" in var.attrs:
            units = f"in {var.attrs['units_variable']}"
        lines.append(f"  {name} {var.dims} [{units}]: "
                     f"{var.attrs.get('long_name', '')}")
    for name, var in dataset.variables.items():
        if "flag_meanings" in var.attrs and var.dtype.kind in "iu" and var.size:
            lines.append(f"  {name}: {_flag_counts(var)}")
    made = [f"  made by study {written_by(attrs)}"]
    # Fits and designs keep their provenance flat (git_commit, end_time, wall_seconds).
    git = package if "git_commit" in package else provenance
    if "git_commit" in git:
        made.append(f" (git {str(git.get('git_commit'))[:12]}"
                    f"{', dirty' if git.get('git_dirty') is True else ''})")
    host = run.get("host") or _section(provenance, "environment").get("host")
    if host:
        made.append(f" on {host}")
    if run:
        made.append(f", {run.get('started_utc')} .. {run.get('finished_utc')}")
    elif "end_time" in provenance:
        made.append(f", finished {provenance.get('end_time')}")
    wall = run.get("wall_seconds", provenance.get("wall_seconds"))
    details = [f"{wall:.2f} s" if is_number(wall) else f"{wall} s"]
    if "scheduler" in run:
        details.append(f"scheduler {run.get('scheduler')}, {run.get('workers')} workers")
    if "points" in run:
        details.append(f"{run.get('points')} points: {run.get('points_computed')} computed, "
                       f"{run.get('points_reused')} reused")
    elif "chunks" in run:
        details.append(f"{run.get('chunks')} chunks: {run.get('chunks_computed')} computed, "
                       f"{run.get('chunks_reused')} reused")
    lines.append("".join(made) + f" ({'; '.join(details)})")
    for line in str(attrs.get("history", "")).splitlines():
        lines.append(f"  history: {line}")
    return "\n".join(lines)


def describe(path_or_dataset: str | Path | xr.Dataset, path: str = "") -> str:
    """A readable summary of a result of any kind: what was swept, what is inside
    (with the counts of every flag value), where it came from.

    Parameters
    ----------
    path_or_dataset : path or xarray.Dataset
        A (validated) result file, read lazily and in slabs, or a dataset.
    path : str
        Name to show (default: the file's path, or the study name).
    """
    if isinstance(path_or_dataset, xr.Dataset):
        return _describe_dataset(path_or_dataset, path)
    source = Path(path_or_dataset)
    try:
        with xr.open_dataset(source, engine="netcdf4") as dataset:
            return _describe_dataset(dataset, path or str(source))
    except (OSError, RuntimeError) as err:
        raise unreadable(source, err) from None

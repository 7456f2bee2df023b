"""Selecting part of a result file by coordinate values: ``--sel KEY=VALUE``.

The grammar of one selection (the command line repeats ``--sel``; every key once):

``KEY=VALUE``
    the value of coordinate ``KEY`` nearest to ``VALUE`` (the dimension is dropped and
    ``KEY`` stays as a scalar coordinate). ``VALUE`` must lie within the coordinate's
    range, widened by half its mean spacing: ``Q=100`` on a file with ``Q`` in 15 .. 30
    is refused rather than silently read as 30. A coordinate with one value (a
    structure parameter fixed by the spec, ``M`` say) matches only that value, to a
    relative 1e-9.
``KEY==VALUE``
    exactly ``VALUE`` (to a relative 1e-12, so that ``f==14.2`` finds ``14.2`` written by
    ``linspace``); refused, with the available values, when absent.
``KEY=START:STOP``
    every value from ``START`` to ``STOP`` inclusive (either may be empty: ``a=6:``);
    the dimension is kept.
``KEY=V1,V2,...`` and ``KEY==V1,V2,...``
    a list: each value as a single one would be (nearest, or exact), under the same
    rules; the dimension is kept, in the file's order (``f=13,14.5,16``: three curves).
    Two values that find the same one are refused.

``KEY`` is any coordinate of the file: a dimension coordinate (``f``, ``a``, ``Q``, ``M``,
``alpha``, ``cs``, ``m_add``, ``t``, ``segment`` ...), a one-dimensional auxiliary
coordinate (``M`` along ``m_add`` in a mass-ratio study, ``strategy_name`` in a plan
scene: its dimension is selected where it takes that value), a scalar coordinate (a
fixed parameter: checked, nothing to select), or a dimension without a coordinate
(``plate``: ``VALUE`` is the position, 0-based). Text coordinates (labels) match
exactly. Errors (:class:`SelectionError`, a ``ValueError``) name the file, the
selection and what is available. What was selected is recorded in the attribute
``study_selection`` with the coordinates' units (``f=14.5 Hz``; none for units ``1``),
which figure titles repeat.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import xarray as xr

from study.model.inputs import instance_of

__all__ = ["Selection", "SelectionError", "available", "parse_selection", "select"]

#: Relative tolerance of an exact match (values written by linspace, printed to 15 digits).
EXACT_RTOL = 1e-12
#: Relative tolerance of a match against a coordinate with a single value.
SINGLE_RTOL = 1e-9

_GRAMMAR = ("KEY=VALUE (nearest), KEY==VALUE (exact), KEY=V1,V2,... (a list, each nearest; "
            "== for exact) or KEY=START:STOP (a range)")
_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class SelectionError(ValueError):
    """A selection that cannot be parsed or applied; names the file, key and values."""


@dataclass(frozen=True)
class Selection:
    """One ``--sel`` option.

    Attributes
    ----------
    key : str
        Coordinate (or dimension) name.
    mode : {"nearest", "exact", "range"}
    value : str
        The value as written (``START:STOP`` for a range, ``V1,V2`` for a list).
    """

    key: str
    mode: str
    value: str

    @property
    def values(self) -> tuple[str, ...]:
        """The values of a list (one value: a tuple of one)."""
        return tuple(v.strip() for v in self.value.split(","))

    @property
    def is_list(self) -> bool:
        """Whether several values are selected (the dimension is kept)."""
        return self.mode != "range" and "," in self.value

    def __str__(self) -> str:
        return f"{self.key}{'==' if self.mode == 'exact' else '='}{self.value}"


def parse_selection(texts: Iterable[str]) -> list[Selection]:
    """Parse ``KEY=VALUE`` / ``KEY==VALUE`` / ``KEY=START:STOP`` options.

    Raises
    ------
    SelectionError
        For a malformed option or a key given twice.
    """
    if isinstance(texts, str):
        texts = [texts]
    if not isinstance(texts, Iterable):
        raise SelectionError(f"selections must be a list of KEY=VALUE texts, got {texts!r}")
    selections: list[Selection] = []
    for text in texts:
        key, sep, value = str(text).partition("=")
        key = key.strip()
        mode = "nearest"
        if value.startswith("="):
            mode, value = "exact", value[1:]
        value = value.strip()
        if not sep or not _KEY.match(key) or not value:
            raise SelectionError(f"--sel {text!r}: expected {_GRAMMAR}")
        if ":" in value:
            if "," in value:
                raise SelectionError(f"--sel {text!r}: a list takes values, not ranges "
                                     f"({_GRAMMAR})")
            if mode == "exact":
                raise SelectionError(f"--sel {text!r}: a range takes one '=' ({_GRAMMAR})")
            mode = "range"
        if "," in value:
            items = [v.strip() for v in value.split(",")]
            if not all(items):
                raise SelectionError(f"--sel {text!r}: an empty value in the list "
                                     f"({_GRAMMAR})")
            twice = sorted({v for v in items if items.count(v) > 1})
            if twice:
                raise SelectionError(f"--sel {text!r}: {', '.join(twice)} listed twice")
            value = ",".join(items)
        if any(s.key == key for s in selections):
            raise SelectionError(f"--sel {text!r}: {key} is selected twice")
        selections.append(Selection(key, mode, value))
    return selections


def _fmt(value: object) -> str:
    if isinstance(value, (float, np.floating)):
        return f"{float(value):.10g}"
    return str(value)


def _values_text(values: np.ndarray) -> str:
    """The values of a coordinate: all of them if few, else first, last and count."""
    values = np.asarray(values).ravel()
    if values.size <= 12:
        return ", ".join(_fmt(v) for v in values)
    return (f"{values.size} values, {_fmt(values[0])}, {_fmt(values[1])}, ... "
            f"{_fmt(values[-1])}")


def available(dataset: xr.Dataset) -> str:
    """What a selection can name in ``dataset``: every coordinate and its values."""
    instance_of("dataset", dataset, xr.Dataset, "an xarray.Dataset")
    lines = []
    for name in dataset.dims:
        if name in dataset.coords:
            coord = dataset[name]
            units = coord.attrs.get("units")
            lines.append(f"{name} [{units}]: {_values_text(coord.values)}" if units
                         else f"{name}: {_values_text(coord.values)}")
        else:
            lines.append(f"{name}: positions 0 .. {dataset.sizes[name] - 1} (no coordinate)")
    for name, coord in dataset.coords.items():
        if name in dataset.dims:
            continue
        if coord.ndim == 1:
            lines.append(f"{name} (along {coord.dims[0]}): {_values_text(coord.values)}")
        elif coord.ndim == 0:
            lines.append(f"{name}: {_fmt(coord.values.item())} (fixed)")
    return "; ".join(lines) if lines else "no coordinates"


def _number(text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise SelectionError(f"{where}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise SelectionError(f"{where}: {text!r} is not a finite number")
    return value


def _positions(values: np.ndarray, sel: Selection, where: str, dataset: xr.Dataset) -> object:
    """Index (int) or index array of ``values`` (a 1-D coordinate) for ``sel``; a list
    gives the positions of its values, each found as a single one, in the file's order."""
    if not sel.is_list:
        return _positions_of_one(values, sel, where, dataset)
    found: dict[int, str] = {}
    for item in sel.values:
        hits = np.atleast_1d(_positions_of_one(values, Selection(sel.key, sel.mode, item),
                                               where, dataset))
        for hit in map(int, hits):
            if hit in found:
                raise SelectionError(
                    f"{where}: {found[hit]} and {item} both select {sel.key}="
                    f"{_fmt(values[hit])}; give values of {sel.key} that differ by more "
                    f"than its spacing (available: {_values_text(values)})")
            found[hit] = item
    return np.array(sorted(found), dtype=np.intp)


def _positions_of_one(values: np.ndarray, sel: Selection, where: str,
                      dataset: xr.Dataset) -> object:
    """Index (int) or index array of ``values`` for a selection of one value or a range."""
    shown = _values_text(values)
    if values.dtype.kind not in "iuf":
        # Labels: exact, one or several positions (a range makes no sense).
        if sel.mode == "range":
            raise SelectionError(f"{where}: {sel.key} holds text ({shown}); "
                                 "select one value")
        hits = np.flatnonzero(values.astype(str) == sel.value)
        if hits.size == 0:
            raise SelectionError(f"{where}: {sel.key} has no value {sel.value!r}; "
                                 f"available: {shown}")
        return int(hits[0]) if hits.size == 1 else hits
    numbers = values.astype(float)
    if sel.mode == "range":
        start, _, stop = sel.value.partition(":")
        low = _number(start, where) if start.strip() else -math.inf
        high = _number(stop, where) if stop.strip() else math.inf
        scale = np.max(np.abs(numbers)) if numbers.size else 0.0
        slack = EXACT_RTOL * scale
        hits = np.flatnonzero((numbers >= low - slack) & (numbers <= high + slack))
        if hits.size == 0:
            raise SelectionError(f"{where}: no {sel.key} in {sel.value}; available: {shown}")
        return hits
    value = _number(sel.value, where)
    distance = np.abs(numbers - value)
    best = int(np.argmin(distance))
    scale = max(abs(value), float(np.max(np.abs(numbers))))
    if sel.mode == "exact":
        if distance[best] > EXACT_RTOL * scale:
            raise SelectionError(f"{where}: {sel.key} has no value {sel.value} exactly; "
                                 f"available: {shown} (or {sel.key}={sel.value} for the "
                                 "nearest)")
        return best
    if numbers.size == 1:
        if distance[best] > SINGLE_RTOL * scale:
            raise SelectionError(f"{where}: {sel.key} has the single value "
                                 f"{_fmt(numbers[0])} in this file")
        return best
    half = 0.5 * (numbers.max() - numbers.min()) / (numbers.size - 1)
    if value < numbers.min() - half or value > numbers.max() + half:
        raise SelectionError(f"{where}: {sel.value} is outside the values of {sel.key} "
                             f"({shown})")
    return best


def _units(coord: xr.DataArray | None) -> str:
    """`` UNITS`` of a coordinate for the record of a selection (none for ``1``)."""
    units = "" if coord is None else str(coord.attrs.get("units", ""))
    return "" if units in ("", "1") else f" {units}"


def select(dataset: xr.Dataset, selections: Iterable[Selection | str],
           source: str = "") -> xr.Dataset:
    """Apply selections to a result dataset.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result (study or scene).
    selections : Selection or str
        Parsed selections, or option texts (``"Q=30"``) to parse.
    source : str
        The file's name, for messages.

    Returns
    -------
    xarray.Dataset
        The selected part. A nearest or exact selection of one value drops the
        dimension and keeps the chosen value as a scalar coordinate; a list or a range
        keeps the dimension. The attribute ``study_selection`` lists what was selected,
        with units (``"Q=30 (asked 29), f=13,14.5,16 Hz"``), appended to any earlier
        selection.

    Raises
    ------
    SelectionError
        Naming ``source``, the selection, and the available keys or values.
    TypeError
        For a ``dataset`` that is not an :class:`xarray.Dataset`.
    """
    instance_of("dataset", dataset, xr.Dataset, "an xarray.Dataset")
    if isinstance(selections, str | Selection):
        selections = [selections]
    if not isinstance(selections, Iterable):
        raise SelectionError(f"selections must be a list of KEY=VALUE texts, got "
                             f"{selections!r}")
    parsed = [s if isinstance(s, Selection) else None for s in selections]
    texts = [s for s in selections if not isinstance(s, Selection)]
    items = [s for s in parsed if s is not None] + parse_selection(texts)
    prefix = f"{source}: " if source else ""
    chosen: list[str] = []
    for sel in items:
        where = f"{prefix}--sel {sel}"
        if sel.key in dataset.coords:
            coord = dataset[sel.key]
        elif sel.key in dataset.dims:
            coord = None
        else:
            raise SelectionError(f"{where}: no coordinate {sel.key!r} in this file; "
                                 f"available: {available(dataset)}")
        if coord is None:
            size = dataset.sizes[sel.key]
            positions = xr.DataArray(np.arange(size), dims=(sel.key,))
            index = _positions(positions.values, sel, where, dataset)
            dim = sel.key
        elif coord.ndim == 0:
            _positions(np.atleast_1d(coord.values), sel, where, dataset)
            chosen.append(f"{sel.key}={_fmt(coord.values.item())}{_units(coord)}")
            continue
        elif coord.ndim == 1:
            dim = coord.dims[0]
            index = _positions(coord.values, sel, where, dataset)
        else:
            raise SelectionError(f"{where}: {sel.key} is {coord.ndim}-dimensional; "
                                 f"available: {available(dataset)}")
        dataset = dataset.isel({dim: index})
        units = _units(coord)
        if isinstance(index, int) or sel.is_list:
            got = (np.atleast_1d(dataset[sel.key].values) if sel.key in dataset.coords
                   else np.atleast_1d(index))
            text = ",".join(_fmt(v) for v in got)
            asked = ",".join(sel.values)
            note = "" if sel.mode != "nearest" or text == asked else f" (asked {sel.value})"
            chosen.append(f"{sel.key}={text}{units}{note}")
        else:
            count = int(np.size(index))
            span = str(sel)
            if sel.key in dataset.coords and dataset[sel.key].dtype.kind in "iuf":
                held = dataset[sel.key].values
                span = f"{sel.key}={_fmt(held.min())} to {_fmt(held.max())}"
            chosen.append(f"{span}{units} ({count} value{'' if count == 1 else 's'})")
    if chosen:
        earlier = dataset.attrs.get("study_selection")
        dataset = dataset.copy()
        dataset.attrs["study_selection"] = ", ".join(
            ([str(earlier)] if earlier else []) + chosen)
    return dataset

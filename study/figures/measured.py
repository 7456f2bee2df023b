"""Measurements beside the model: ``study figure NAME FILE --measurements lab.csv``.

Measurement files (:mod:`study.analyses.measurements`: CSV, SI units, optional per-row
``sigma``) are read, the rows of the quantity a figure compares are picked, and drawn
with error bars (one standard deviation; none where ``sigma`` is blank):

* ``thresholds``: ``threshold`` rows, marker by direction (forward ``^`` beside
  a*_+, backward ``v`` beside a*_-, unknown ``o``: the lower of the two);
* ``velocity-curves``: ``velocity`` rows, each in the colour of the curve of the
  nearest frequency (within half the spacing of the curves' frequencies, or 1 % of
  ``f`` for a single curve);
* ``mass-ratio``: ``threshold`` rows of a structure named by ``m_add`` or ``M``.

A row that names its structure (``m_add`` or ``M``) is drawn on a figure of one
structure only when it is that structure (``M`` to 1 %, ``m_add`` to 1 % or 1 mg).
Every refusal is a :class:`study.figures.FigureError` naming the file(s): no row of
the quantity the figure compares (and what the files hold instead), rows all of
another structure, or values in other units than the format's; velocities plainly
in mm s-1 where m s-1 is expected are refused by
:func:`study.analyses.measurements.check_velocity_units`, the check ``study fit`` makes too.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import xarray as xr

from study.analyses.measurements import QUANTITIES, read_measurements
from study.figures import FigureError

__all__ = [
    "MARKERS",
    "M_ADD_ATOL",
    "M_RTOL",
    "draw_rows",
    "load",
    "pick",
    "same_structure",
]

#: Marker of a row by threshold direction (velocity rows: ``o``).
MARKERS = {"forward": "^", "backward": "v", "unknown": "o", "": "o"}

#: A row's ``M`` is the file's when within this relative difference.
M_RTOL = 0.01
#: A row's ``m_add`` is the file's when within this [kg] (or 1 % of it).
M_ADD_ATOL = 1e-6

#: The quantity each figure compares, for messages.
COMPARED = {
    "thresholds": "threshold",
    "velocity-curves": "velocity",
    "mass-ratio": "threshold",
}


def _names(paths: Sequence[str | Path]) -> str:
    return ", ".join(str(p) for p in paths)


def load(paths: Sequence[str | Path]) -> xr.Dataset:
    """Read measurement files (:func:`study.analyses.measurements.read_measurements`).

    Raises
    ------
    study.analyses.measurements.MeasurementError
        For a missing or invalid file (file, line and column named).
    FigureError
        For a row whose value is not in its quantity's units.
    """
    data = read_measurements(list(paths))
    quantity = data["quantity"].values.astype(str)
    units = data["value_units"].values.astype(str)
    for i, (q, u) in enumerate(zip(quantity, units, strict=True)):
        expected = QUANTITIES[q].units
        if u != expected:
            raise FigureError(f"{data['source'].values[i]}, line {int(data['line'][i])}: "
                              f"a {q!r} value in {u!r}; the figures compare it in "
                              f"{expected!r}")
    data.attrs["study_measurement_files"] = _names(paths)
    return data


def pick(data: xr.Dataset, quantity: str, figure: str) -> np.ndarray:
    """Indices of the rows of ``quantity``.

    Raises
    ------
    FigureError
        When there are none: naming the files, what they hold and what each figure
        compares.
    """
    quantities = data["quantity"].values.astype(str)
    rows = np.flatnonzero(quantities == quantity)
    if rows.size:
        return rows
    held = ", ".join(f"{q} ({int(np.count_nonzero(quantities == q))} rows)"
                     for q in dict.fromkeys(quantities))
    compared = "; ".join(f"{f}: {q} rows" for f, q in COMPARED.items())
    raise FigureError(
        f"{data.attrs.get('study_measurement_files', 'measurements')}: no {quantity!r} "
        f"rows to draw on figure {figure!r}; the files hold {held} (figures compare "
        f"{compared})")


def _scalar(dataset: xr.Dataset, name: str) -> float | None:
    if name in dataset.coords and dataset[name].ndim == 0:
        return float(dataset[name])
    return None


def same_structure(data: xr.Dataset, rows: np.ndarray, dataset: xr.Dataset,
                   figure: str) -> np.ndarray:
    """The rows (of ``rows``) measured on the structure of ``dataset``: rows naming no
    structure, or an ``M`` / ``m_add`` equal to the file's (selected) one.

    Raises
    ------
    FigureError
        When every row is of another structure (the rows' and the file's named).
    """
    m_rows = data["M"].values[rows]
    add_rows = data["m_add"].values[rows]
    m_file = _scalar(dataset, "M")
    add_file = _scalar(dataset, "m_add")
    keep = np.ones(rows.size, dtype=bool)
    has_m = np.isfinite(m_rows)
    if m_file is not None:
        keep &= ~has_m | (np.abs(m_rows - m_file) <= M_RTOL * m_file)
    else:
        keep &= ~has_m
    has_add = np.isfinite(add_rows)
    if add_file is not None:
        keep &= ~has_add | (np.abs(add_rows - add_file)
                            <= M_ADD_ATOL + M_RTOL * abs(add_file))
    elif has_add.any():
        # A file without m_add (M given directly): an m_add row is another structure.
        keep &= ~has_add
    if keep.any():
        return rows[keep]
    named = sorted({f"M = {m:g}" for m in m_rows[has_m]}
                   | {f"m_add = {m:g} kg" for m in add_rows[has_add]})
    own = ", ".join(f"{n} = {v:g}" for n, v in (("M", m_file), ("m_add", add_file))
                    if v is not None) or "M swept"
    raise FigureError(
        f"{data.attrs.get('study_measurement_files', 'measurements')}: the rows for "
        f"figure {figure!r} are of other structures ({', '.join(named)}) than this "
        f"file's ({own}); select the structure with --sel (M=... or m_add=...) or give "
        "rows without M and m_add")


def draw_rows(ax, data: xr.Dataset, rows: np.ndarray, x: str, scale: float = 1.0,
              colour=None, colours=None, label: str | None = None, **style) -> None:
    """Error bars of ``rows`` against column ``x`` (``"f"`` or ``"a"``), ``value`` times
    ``scale``; marker by direction; one colour, or one per row (``colours``)."""
    xs = data[x].values[rows]
    ys = scale * data["value"].values[rows]
    sigma = scale * data["sigma"].values[rows]
    directions = data["direction"].values.astype(str)[rows]
    for k in range(rows.size):
        c = colours[k] if colours is not None else (colour or "black")
        err = sigma[k] if np.isfinite(sigma[k]) else None
        ax.errorbar(xs[k], ys[k], yerr=err, fmt=MARKERS.get(directions[k], "o"), ms=6,
                    mfc=c, mec="black", mew=0.8, ecolor="black", elinewidth=1.0,
                    capsize=2.5, zorder=6, label=label if k == 0 else None, **style)

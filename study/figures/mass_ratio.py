"""The paper's Fig. 3: motion thresholds of the structure with on-board loads.

Left: ``a* = min(a*_+, a*_-)`` against the drive frequency for every load (the
lift-off acceleration dashed in the same colour). Right: the lowest threshold over
the frequency axis of the file against the mass ratio ``M = m1 / (m0 + m_add)``,
with the closed form at resonance ``g / sqrt(1 + x^2)``
(``x = max |x_pm|``, :func:`study.analyses.thresholds.collapse_variable`) and the exact minimum
over ``f`` of the closed-form thresholds (:func:`study.analyses.thresholds.lowest_threshold`)
over a fine range of ``M`` for the same structure. The paper's statement (about g/2 at
resonance for M = 6.6 %) is drawn only for the paper's structure (:mod:`study.model.paper`,
``M`` aside). More than 8 loads get a colour bar of ``M`` instead of a legend entry
each. With ``--measurements lab.csv``, the measured thresholds of rows naming their
structure (``m_add`` or ``M``) are drawn with error bars: on the left in the colour of
their load, on the right the lowest measured threshold of each structure at its ``M``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from study.analyses.thresholds import lowest_threshold, resonance_threshold
from study.figures import FigureError, measured
from study.figures.common import (
    coupling_label,
    grid_minimum,
    is_paper_file,
    require_axis,
    require_dims,
    save,
    selection_text,
    structure_from_dataset,
    structure_text,
    value_colours,
)
from study.model import lift_off_acceleration
from study.model.structure import Structure

__all__ = ["draw"]

#: The paper's statement for the 1.7 g load (Fig. 3 discussion).
PAPER_M = 0.066

_BOX = {"facecolor": "white", "edgecolor": "none", "alpha": 0.9, "pad": 1.5}


def _loads(dataset: xr.Dataset
           ) -> tuple[xr.Dataset, str | None, np.ndarray, np.ndarray | None]:
    """The dataset (other axes of one value squeezed), the load axis: its name, the
    mass ratios along it and the added masses [kg]."""
    ratio = dataset["M"]
    if ratio.ndim > 1:
        raise FigureError(f"figure 'mass-ratio' needs M along one axis, got dims {ratio.dims}")
    dim = ratio.dims[0] if ratio.ndim == 1 else None
    dataset = require_dims(dataset, "mass-ratio", ("f", dim), "thresholds over (load, f)",
                           variable="a_star_plus")
    require_axis(dataset, "mass-ratio", "f", "the thresholds against f")
    m_add = None
    if "m_add" in dataset.coords:
        m_add = np.atleast_1d(dataset["m_add"].values).astype(float)
    return dataset, dim, np.atleast_1d(dataset["M"].values).astype(float), m_add


def _label(ratio: float, m_add: float | None) -> str:
    if m_add is None:
        return f"M = {100 * ratio:.1f} %"
    return f"m_add = {1e3 * m_add:.1f} g, M = {100 * ratio:.1f} %"


def _measured_structures(data: xr.Dataset, rows: np.ndarray, dataset: xr.Dataset,
                         ratios: np.ndarray, m_add: np.ndarray | None
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per threshold row naming its structure: the row, its load index (-1: none of
    the file's) and its mass ratio (from M, the file's load, or m1/(m0 + m_add))."""
    m_rows = data["M"].values[rows]
    add_rows = data["m_add"].values[rows]
    named = np.isfinite(m_rows) | np.isfinite(add_rows)
    if not named.any():
        raise FigureError(
            f"{data.attrs.get('study_measurement_files', 'measurements')}: figure "
            "'mass-ratio' draws thresholds per structure; no threshold row names its "
            "structure (give an m_add [kg] or M column)")
    rows, m_rows, add_rows = rows[named], m_rows[named], add_rows[named]
    load = np.full(rows.size, -1)
    ratio = m_rows.copy()
    m0 = float(dataset["m0"]) if "m0" in dataset.coords and dataset["m0"].ndim == 0 else None
    m1 = float(dataset["m1"]) if "m1" in dataset.coords and dataset["m1"].ndim == 0 else None
    for k in range(rows.size):
        if np.isfinite(add_rows[k]):
            if m_add is not None:
                gap = np.abs(m_add - add_rows[k])
                j = int(np.argmin(gap))
                if gap[j] <= measured.M_ADD_ATOL + measured.M_RTOL * abs(m_add[j]):
                    load[k] = j
                    ratio[k] = ratios[j]
            if not np.isfinite(ratio[k]) and m0 is not None and m1 is not None:
                ratio[k] = m1 / (m0 + add_rows[k])
        else:
            gap = np.abs(ratios - m_rows[k])
            j = int(np.argmin(gap))
            if gap[j] <= measured.M_RTOL * ratios[j]:
                load[k] = j
    if not np.isfinite(ratio).all():
        k = int(np.flatnonzero(~np.isfinite(ratio))[0])
        raise FigureError(
            f"{data['source'].values[rows[k]]}, line {int(data['line'][rows[k]])}: "
            f"m_add = {add_rows[k]:g} kg is none of this file's loads and the file holds "
            "no m0, m1 to give its M; give its M column instead")
    return rows, load, ratio


class _Loads(NamedTuple):
    """The file's loads: their axis (None: one load), mass ratios [1], added masses [kg]
    if given, colour by index, and a colour bar for many (else None)."""

    dim: str | None
    ratios: np.ndarray
    m_add: np.ndarray | None
    colours: dict[int, object]
    bar: object


class _Measured(NamedTuple):
    """Measured threshold rows naming their structure (:func:`_measured_structures`)."""

    data: xr.Dataset
    rows: np.ndarray
    load: np.ndarray
    ratio: np.ndarray


def draw(dataset: xr.Dataset, output: Path,
         measurements: Sequence[str | Path] | None = None) -> list[Path]:
    """Draw Fig. 3 from a ``mass-ratio`` result file; returns the PNG and the PDF.

    ``measurements``: measurement files whose ``threshold`` rows with ``m_add`` or
    ``M`` are drawn beside the model."""
    dataset, dim, ratios, m_add = _loads(dataset)
    paper = is_paper_file(dataset, ignore=("M",))
    colors, bar = value_colours(100 * ratios)
    loads = _Loads(dim, ratios, m_add, {i: colors[i] for i in range(ratios.size)}, bar)
    found = None
    if measurements:
        data = measured.load(measurements)
        found = _Measured(data, *_measured_structures(
            data, measured.pick(data, "threshold", "mass-ratio"), dataset, ratios, m_add))

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12.5, 5.2), layout="constrained",
                                 gridspec_kw={"width_ratios": [1.25, 1.0]})
    minima, structures = _threshold_panel(fig, ax, dataset, loads, found)
    _minimum_panel(bx, dataset, loads, minima, structures[0], found, paper)

    title = (
        f"{'Fig. 3: ' if paper else ''}motion threshold with on-board loads "
        f"({structure_text(dataset, omit=('ck',), tex=False)})"
    )
    if found is not None:
        title += f", with {found.rows.size} measured"
    if "velocity" in dataset:
        # Thresholds are computed with the base at rest: the same in both couplings.
        title += (f"; file computed with {coupling_label(dataset)}: the thresholds (base at "
                  "rest) are the same in both couplings")
    selected = selection_text(dataset)
    fig.suptitle(title.replace("; ", "\n", 1) + (f"\n{selected}" if selected else ""),
                 fontsize=11)
    return save(fig, output, dataset, title)


def _threshold_panel(fig: plt.Figure, ax: plt.Axes, dataset: xr.Dataset, loads: _Loads,
                     found: _Measured | None
                     ) -> tuple[list[tuple[float, float, bool]], list[Structure]]:
    """Left: the threshold against f for every load with its lift-off and its minimum.

    Returns per load the minimum over f ``(a*, f, not resolved)`` and the structure."""
    f = dataset["f"].values
    # The file's accelerations bound the thresholds drawn; one selected (--sel a=7) is
    # drawn as a line: below it, the structure moves at that acceleration.
    a_top = a_line = None
    if "a" in dataset.coords and dataset["a"].size > 1:
        a_top = float(dataset["a"].values.max())
    elif "a" in dataset.coords:
        a_line = float(np.ravel(dataset["a"].values)[0])
    minima, structures, beyond_drawn = _load_curves(ax, dataset, loads)
    ax.plot([], [], color="0.3", lw=1.0, ls="--",
            label="lift-off $a_{lift}$ (model invalid above)")
    if beyond_drawn:
        ax.plot([], [], color="0.3", lw=1.0, ls=":", label="$a^*$ above lift-off (invalid)")
    ax.plot([], [], "o", color="0.6", mec="k", mew=0.6, label="minimum over f")
    g = structures[0].g
    ax.axhline(g, color="0.5", lw=0.8)
    ax.text(f[0], g, "  g", va="bottom", ha="left", fontsize=8, color="0.35")
    top = a_top if a_top is not None else 1.25 * g
    if a_line is not None:
        top = max(top, 1.15 * a_line)
        ax.axhline(a_line, color="tab:purple", lw=1.0, ls="-.",
                   label=f"selected a = {a_line:g} m s$^{{-2}}$: moves where $a^* < a$")
    ax.set(xlim=(f[0], f[-1]), ylim=(0.0, top), xlabel="drive frequency f [Hz]",
           ylabel="motion threshold $a^* = \\min(a^*_+, a^*_-)$ [m s$^{-2}$]",
           title="Threshold against frequency for each on-board load")
    if found is not None:
        on_load = found.load >= 0
        if on_load.any():
            measured.draw_rows(ax, found.data, found.rows[on_load], "f",
                               colours=[loads.colours[j] for j in found.load[on_load]])
            ax.plot([], [], "o", mfc="0.6", mec="k", label="measured $\\pm\\sigma$ "
                    "(colour of its load;\n^ forward, v backward, o unknown)")
    if loads.bar is not None:
        fig.colorbar(loads.bar, ax=ax, pad=0.01,
                     label=f"mass ratio M [%] ({loads.ratios.size} loads)")
    ax.legend(loc="lower left", fontsize=8, framealpha=0.9)
    return minima, structures


def _load_curves(ax: plt.Axes, dataset: xr.Dataset, loads: _Loads
                 ) -> tuple[list[tuple[float, float, bool]], list[Structure], bool]:
    """Each load's threshold (faint above lift-off), its lift-off acceleration and its
    minimum over f. Returns per load the minimum ``(a*, f, not resolved)`` and the
    structure, and whether some threshold lies above lift-off."""
    f = dataset["f"].values
    dim, ratios, m_add, bar = loads.dim, loads.ratios, loads.m_add, loads.bar
    minima, structures = [], []
    beyond_drawn = False
    for i in range(ratios.size):
        at = {dim: i} if dim is not None else {}
        structure = structure_from_dataset(dataset, **at)
        structures.append(structure)
        a_star = np.minimum(dataset["a_star_plus"].isel(at).values,
                            dataset["a_star_minus"].isel(at).values)
        if "lift_off_acceleration" in dataset:
            a_lift = dataset["lift_off_acceleration"].isel(at).values
        else:
            a_lift = lift_off_acceleration(structure, f)
        color = loads.colours[i]
        label = _label(ratios[i], None if m_add is None else m_add[i])
        # A threshold above lift-off is outside the model: drawn faint, never as valid.
        valid = a_star < a_lift
        ax.plot(f, np.where(valid, a_star, np.nan), color=color, lw=1.8,
                label=None if bar is not None else label)
        if not valid.all():
            ax.plot(f, np.where(valid, np.nan, a_star), color=color, lw=1.0, ls=":",
                    alpha=0.6)
            beyond_drawn = True
        ax.plot(f, a_lift, color=color, lw=1.0, ls="--")
        if not valid.any():
            minima.append((np.nan, np.nan, True))
            continue
        j, resolved = grid_minimum(f, np.where(valid, a_star, np.inf), structure.f0,
                                   structure.Q)
        minima.append((a_star[j], f[j], not resolved))
        ax.plot(f[j], a_star[j], "o", color=color, ms=5, mec="k", mew=0.6)
    return minima, structures, beyond_drawn


def _minimum_panel(bx: plt.Axes, dataset: xr.Dataset, loads: _Loads,
                   minima: list[tuple[float, float, bool]], base: Structure,
                   found: _Measured | None, paper: bool) -> None:
    """Right: the minimum over f against M, with the closed forms over a fine M range,
    the lowest measured threshold of each structure and, for the paper's structure,
    its statement."""
    f = dataset["f"].values
    g = base.g
    ratios, color_of = loads.ratios, loads.colours
    spanned = ratios if found is None else np.concatenate([ratios, found.ratio])
    fine = np.linspace(min(1e-3, 0.5 * spanned.min()), min(1.0, 1.25 * spanned.max()), 121)
    at_resonance = np.array([min(resonance_threshold(replace(base, M=m))) for m in fine])
    f_range = (float(f[0]), float(f[-1]))
    exact_min = np.array([lowest_threshold(replace(base, M=m), f_range)[0] for m in fine])
    bx.plot(100 * fine, at_resonance, color="k", lw=1.6,
            label="closed form at $f_0$: $g/\\sqrt{1+x^2}$, $x = \\max|x_\\pm|$")
    bx.plot(100 * fine, exact_min, color="0.45", lw=1.2, ls="--",
            label=f"closed form, minimum over f in [{f[0]:g}, {f[-1]:g}] Hz")
    for i in range(ratios.size):
        a_min, _, at_edge = minima[i]
        bx.plot(100 * ratios[i], a_min, "o", ms=8, color=color_of[i], mec="k", mew=0.8,
                mfc="none" if at_edge else color_of[i])
    bx.plot([], [], "o", color="0.6", mec="k", ms=8,
            label=f"data: min over f in [{f[0]:g}, {f[-1]:g}] Hz")
    if any(m[2] for m in minima):
        bx.plot([], [], "o", mfc="none", mec="k", ms=8,
                label="not resolved: f step > $f_0/(10Q)$ or at the range edge")
    if found is not None:
        _lowest_measured(bx, found, color_of)
    if paper:
        _paper_statement(bx, base, f_range)
    bx.set(xlim=(0.0, 100 * fine[-1]), ylim=(0.0, 1.05 * g),
           xlabel="mass ratio M = m$_1$/m [%]",
           ylabel="minimum threshold over f, $a^*_{min}$ [m s$^{-2}$]",
           title="Minimum threshold against the mass ratio")
    secondary = bx.secondary_yaxis("right", functions=(lambda y: y / g, lambda y: y * g))
    secondary.set_ylabel("$a^*_{min}$ / g")
    bx.legend(loc="best", fontsize=8, framealpha=0.9)


def _lowest_measured(bx: plt.Axes, found: _Measured, color_of: dict) -> None:
    """The lowest measured threshold of each structure, at its mass ratio."""
    data, rows = found.data, found.rows
    for value in np.unique(found.ratio):
        group = np.flatnonzero(found.ratio == value)
        k = group[int(np.argmin(data["value"].values[rows[group]]))]
        colour = color_of[found.load[k]] if found.load[k] >= 0 else "white"
        sigma = data["sigma"].values[rows[k]]
        bx.errorbar(100 * value, data["value"].values[rows[k]],
                    yerr=sigma if np.isfinite(sigma) else None, fmt="D", ms=6,
                    mfc=colour, mec="k", ecolor="k", capsize=2.5, zorder=6)
    bx.plot([], [], "D", mfc="0.6", mec="k",
            label="measured: lowest threshold of each structure $\\pm\\sigma$")


def _paper_statement(bx: plt.Axes, base: Structure, f_range: tuple[float, float]
                     ) -> None:
    """The paper's statement (about g/2 at resonance for M = 6.6 %) beside the model's
    values there."""
    g = base.g
    bx.axhline(g / 2, color="tab:red", lw=1.0, ls="-.", label="g/2")
    bx.axvline(100 * PAPER_M, color="tab:red", lw=0.8, ls=":")
    bx.annotate('paper: "about g/2 at resonance\nfor M = 6.6 %"',
                xy=(100 * PAPER_M, g / 2), xytext=(0.7, 0.93),
                textcoords="axes fraction", fontsize=8.5, color="tab:red", ha="center",
                bbox=_BOX, arrowprops={"arrowstyle": "->", "color": "tab:red", "lw": 0.8})
    at_paper = replace(base, M=PAPER_M)
    paper_res = min(resonance_threshold(at_paper))
    paper_min = lowest_threshold(at_paper, f_range)[0]
    bx.text(0.7, 0.83,
            f"model at M = 6.6 %: {paper_res:.2f} m s$^{{-2}}$ = {paper_res / g:.2f} g "
            f"at $f_0$,\n{paper_min:.2f} m s$^{{-2}}$ = {paper_min / g:.2f} g at the "
            "minimum over f",
            transform=bx.transAxes, fontsize=8, ha="center", va="top", color="0.2",
            bbox=_BOX)

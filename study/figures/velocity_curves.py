"""The paper's Fig. 1C inset: mean velocity against drive acceleration at fixed frequencies.

Drawn from a ``velocity-curves`` result file alone (``study figure velocity-curves FILE``).
Each curve stops at the first lift-off point of its frequency: beyond it the model
does not apply. With flight (``velocity-curves-flight``) the curves go on past lift-off:
their bouncing points are drawn over a wide pale band, and the same curves without
flight (``without_flight``) dotted, ending where they lift off. Points that did not
converge leave gaps and are marked on the axis.
Up to 8 curves get a legend entry each; more get a colour bar of the frequency. A file of
more than 12 frequencies draws 12 of them, evenly spread on the colour scale (closer
near the resonance; the title says so; ``--sel f=...`` draws the ones chosen instead). With
``--measurements lab.csv`` the measured velocities are drawn with their error bars, each
in the colour of the curve of the nearest frequency (:mod:`study.figures.measured`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.colors import ListedColormap, Normalize
from matplotlib.lines import Line2D

from study.analyses.measurements import check_velocity_units
from study.figures import FigureError, common, measured
from study.figures.common import (
    MAX_LEGEND_ENTRIES,
    VALID,
    coupling_label,
    one_way_velocity,
    parameter_text,
    require_axis,
    restore_dim,
    selected_keys,
    single_structure,
)
from study.model.status import Status

__all__ = ["FREQUENCY_COLORS", "MAX_CURVES", "draw", "drawn_curves", "frequency_position"]

#: Curves drawn at most without ``--sel f=...``: the paper's twelve; beyond, as many
#: evenly spread (:func:`drawn_curves`), the title says so and how to pick others.
MAX_CURVES = 12

#: Diverging colours for the drive frequency: blues below the resonance (forward
#: motion), reds above (backward); light near f0, dark far from it, never so light
#: that a line vanishes on white.
FREQUENCY_COLORS = ListedColormap(
    np.vstack([
        colormaps["Blues"](np.linspace(1.0, 0.4, 128)),
        colormaps["Reds"](np.linspace(0.4, 1.0, 128)),
    ]),
    name="below-above-f0",
)


#: The variables drawn over (f, a) and those over f, which keep one frequency selected.
_ALONG_F = ("velocity", "status", "velocity_one_way", "status_one_way", "a_star_plus",
            "a_star_minus", "lift_off_acceleration", "velocity_without_flight",
            "status_without_flight")


def frequency_position(f: np.ndarray, f0: float) -> np.ndarray:
    """Position in :data:`FREQUENCY_COLORS` of each frequency, centred on ``f0``.

    ``0.5 + 0.5 sign(f - f0) sqrt(|f - f0| / max|f - f0|)``: monotone in ``f``, 0.5 at
    the resonance; the square root spreads the colours of frequencies close to ``f0``,
    where the curves differ most.
    """
    offset = np.asarray(f, dtype=float) - f0
    span = max(float(np.max(np.abs(offset))), 1e-12)
    return 0.5 + 0.5 * np.sign(offset) * np.sqrt(np.abs(offset) / span)


def drawn_curves(dataset: xr.Dataset, f0: float, measured_curves=()) -> np.ndarray:
    """The indices along ``f`` of the curves drawn: every one up to :data:`MAX_CURVES`
    or where ``--sel`` chose the frequencies; else :data:`MAX_CURVES` evenly spread on
    the colour scale (:func:`frequency_position`: ends included, closer together near
    the resonance ``f0`` [Hz], where the curves differ most), the one nearest ``f0``
    in place of its neighbour, and those of
    ``measured_curves`` (the curves measurements are drawn on), so that a file of 81
    frequencies still reads."""
    count = dataset.sizes["f"]
    if count <= MAX_CURVES or "f" in selected_keys(dataset):
        return np.arange(count)
    position = frequency_position(dataset["f"].values, f0)
    targets = np.linspace(position.min(), position.max(), MAX_CURVES)
    chosen = {int(np.argmin(np.abs(position - t))) for t in targets}
    resonance = int(np.argmin(np.abs(position - 0.5)))  # the curve nearest f0
    if resonance not in chosen:  # in place of the chosen one nearest to it
        chosen.remove(min(chosen, key=lambda i: abs(position[i] - 0.5)))
        chosen.add(resonance)
    return np.array(sorted(chosen | {int(i) for i in measured_curves}))


def _matched(data, rows: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows whose frequency is a curve's, and the index of that curve: the nearest
    within half the smallest spacing of the curves (1 % of f for a single curve)."""
    if f.size > 1:
        tolerance = 0.5 * float(np.min(np.diff(np.sort(f))))
    else:
        tolerance = 0.01 * float(f[0])
    fr = data["f"].values[rows]
    nearest = np.argmin(np.abs(fr[:, None] - f[None, :]), axis=1)
    ok = np.abs(fr - f[nearest]) <= tolerance * (1 + 1e-9)
    if not ok.any():
        raise FigureError(
            f"{data.attrs.get('study_measurement_files', 'measurements')}: no velocity row "
            f"at a frequency of the curves (rows at {', '.join(f'{x:g}' for x in np.unique(fr))}"
            f" Hz; curves at {', '.join(f'{x:g}' for x in f[:12])}"
            f"{' ...' if f.size > 12 else ''} Hz, matched within {tolerance:.3g} Hz); "
            "select the frequencies with --sel f=START:STOP or compute curves at the "
            "measured frequencies")
    return rows[ok], nearest[ok]


def draw(dataset: xr.Dataset, output: Path,
         measurements: Sequence[str | Path] | None = None) -> list[Path]:
    """Draw velocity against acceleration, one line per frequency, into ``output.png/.pdf``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result holding velocity and status over (f, a), of one structure (or
        selected to one with ``--sel``).
    output : pathlib.Path
        File stem.
    measurements : sequence of paths, optional
        Measurement files whose ``velocity`` rows (of this structure, at the curves'
        frequencies) are drawn with their error bars.

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    dataset = single_structure(dataset, "velocity-curves")
    require_axis(dataset, "velocity-curves", "a", "velocity against a, one curve per f")
    # One frequency selected (--sel f=14.5): its curve alone.
    dataset = restore_dim(dataset, "f", _ALONG_F)
    structure = common.structure_from_dataset(dataset)
    data = rows = curve = None
    if measurements:
        data = measured.load(measurements)
        rows = measured.same_structure(data, measured.pick(data, "velocity",
                                                           "velocity-curves"),
                                       dataset, "velocity-curves")
        status = dataset["status"].transpose("f", "a").values
        speed = np.abs(dataset["velocity"].transpose("f", "a").values)
        valid_speed = np.where(np.isin(status, VALID), speed, 0.0)
        check_velocity_units(data, rows, float(np.nanmax(valid_speed, initial=0.0)))
        rows, curve = _matched(data, rows, dataset["f"].values)
    shown = drawn_curves(dataset, structure.f0, () if curve is None else np.unique(curve))
    total = dataset.sizes["f"]
    if shown.size < total:
        if curve is not None:
            curve = np.searchsorted(shown, curve)
        dataset = dataset.isel(f=shown)
    f = dataset["f"].values
    a = dataset["a"].values
    velocity = 1e3 * dataset["velocity"].transpose("f", "a").values  # mm s-1
    status = dataset["status"].transpose("f", "a").values
    paper = one_way_velocity(dataset, "f", "a")  # beside a two-way study
    without = None  # beside a study with flight: the curves stopped at lift-off
    if "velocity_without_flight" in dataset and "status_without_flight" in dataset:
        without = (1e3 * dataset["velocity_without_flight"].transpose("f", "a").values,
                   dataset["status_without_flight"].transpose("f", "a").values)
    # The colours run over the frequency, centred on f0 (blue below, red above); many
    # curves share one colour bar instead of a legend entry each.
    fine = np.linspace(float(f.min()), float(f.max()), 256) if f.size > 1 else f
    cmap = ListedColormap(FREQUENCY_COLORS(frequency_position(fine, structure.f0)))
    norm = Normalize(float(f.min()), float(f.max()) if f.size > 1 else float(f[0]) + 1.0)
    colour_bar = f.size > MAX_LEGEND_ENTRIES
    colours = [FREQUENCY_COLORS(p) for p in frequency_position(f, structure.f0)]

    fig, ax = plt.subplots(figsize=(8.0, 5.2), layout="constrained")
    ax.axhline(0.0, color="black", lw=0.8)
    handles, any_lift, any_stuck = _curves(ax, a, f, velocity, status, paper, colours,
                                           colour_bar)
    any_bounce, without_lift = _flight(ax, a, velocity, status, without, colours)
    xlim = (float(a[0]), float(a[-1]))
    if rows is not None:
        measured.draw_rows(ax, data, rows, "a", scale=1e3,
                           colours=[colours[c] for c in curve])
        handles.append(Line2D([], [], ls="none", marker="o", ms=6, mfc="0.6", mec="black",
                              label="measured $\\pm\\sigma$\n(colour of its curve)"))
        xs = data["a"].values[rows]
        xlim = (min(xlim[0], float(xs.min())), max(xlim[1], 1.03 * float(xs.max())))
    if paper is not None:
        handles.append(Line2D([], [], color="0.3", lw=0.9, ls="--",
                              label="one-way (paper's) model,\nsame frequency"))
    if any_lift:
        handles.append(Line2D([], [], ls="none", marker="o", ms=5.5, mfc="white", mec="0.3",
                              mew=1.6, label="curve ends: lift-off\nabove (model invalid)"))
    if any_bounce:
        handles.append(Line2D([], [], color="0.3", lw=6, alpha=0.3, solid_capstyle="butt",
                              label=Status.BOUNCING.legend.replace(" and ", " and\n", 1)))
    if without is not None:
        handles.append(Line2D([], [], color="k", lw=0.9, ls=":", marker="o", mfc="white",
                              mec="k", ms=4.5, markevery=[1],
                              label="without flight (same\ncoupling): ends at lift-off"
                              if without_lift else "without flight (same\ncoupling)"))
    if any_stuck:
        handles.append(Line2D([], [], ls="none", marker="x", ms=5, color="0.3",
                              label=f"{Status.NOT_CONVERGED.legend}\nat this a (a gap)"))
    ax.set(xlim=xlim, xlabel="drive acceleration a [m s$^{-2}$]",
           ylabel="mean velocity v [mm s$^{-1}$]  (> 0: forward)")
    title = ("Mean steady velocity against drive acceleration at fixed frequencies, "
             f"{coupling_label(dataset)}")
    if rows is not None:
        title += f", with {rows.size} measured"
    subset = ""
    if f.size < total:
        subset = (f"\n{f.size} of the file's {total} frequencies (closer near $f_0$"
                  + (", and those measured" if curve is not None else "")
                  + "); others: --sel f=F1,F2,... or --sel f=START:STOP")
    ax.set_title(title.replace("frequencies, ", "frequencies\n", 1)
                 + f"\n{parameter_text(dataset)}{subset}", fontsize=11)
    _legend(fig, ax, handles, colour_bar, ScalarMappable(norm=norm, cmap=cmap), f,
            structure.f0)
    return common.save(fig, output, dataset,
                       f"{title} ({common.structure_text(dataset, tex=False)})")


def _curves(ax: plt.Axes, a: np.ndarray, f: np.ndarray, velocity: np.ndarray,
            status: np.ndarray, paper: np.ndarray | None, colours: list,
            colour_bar: bool) -> tuple[list, bool, bool]:
    """One velocity curve per frequency [mm s-1] (up to its first lift-off), the
    one-way model's beside a two-way study, and marks where the solver did not
    converge. Returns the curves' legend handles, whether a curve ends at lift-off and
    whether any point did not converge."""
    handles = []
    any_lift = any_stuck = False
    lw = 1.6 if f.size <= 30 else 1.0
    for i, frequency in enumerate(f):
        color = colours[i]
        lifted = np.flatnonzero(status[i] == Status.LIFT_OFF)
        end = int(lifted[0]) if lifted.size else a.size
        valid = np.isin(status[i, :end], VALID)
        shown = np.where(valid, velocity[i, :end], np.nan)
        (line,) = ax.plot(a[:end], shown, color=color, lw=lw, label=f"{frequency:g} Hz")
        if not colour_bar:
            handles.append(line)
        if paper is not None:
            ax.plot(a, 1e3 * paper[i], color=color, lw=0.9, ls="--", alpha=0.8)
        if lifted.size and end > 0 and valid[-1]:
            any_lift = True
            ax.plot(a[end - 1], shown[-1], ls="none", marker="o", ms=5.5 if lw > 1 else 3.5,
                    mfc="white", mec=color, mew=1.6 if lw > 1 else 1.0, zorder=4)
        stuck = np.flatnonzero(status[i] == Status.NOT_CONVERGED)
        if stuck.size:
            any_stuck = True
            ax.plot(a[stuck], np.full(stuck.size, 0.03), ls="none", marker="x", ms=5,
                    color=color, transform=ax.get_xaxis_transform(), clip_on=False)
    return handles, any_lift, any_stuck


def _flight(ax: plt.Axes, a: np.ndarray, velocity: np.ndarray, status: np.ndarray,
            without: tuple[np.ndarray, np.ndarray] | None, colours: list
            ) -> tuple[bool, bool]:
    """Over a study with flight: a pale band under the bouncing points of each curve,
    and (``without``, [mm s-1] and statuses) the curves without flight, dotted, each
    ending with an open circle at its last point before lift-off. Returns whether any
    point bounces and whether any curve without flight lifts off."""
    any_bounce = any_lift = False
    for i, colour in enumerate(colours):
        bouncing = status[i] == Status.BOUNCING
        if bouncing.any():
            any_bounce = True
            # The band also spans the step into the region: its edge is the lift-off.
            band = bouncing | np.append(bouncing[1:], False)
            ax.plot(a, np.where(band, velocity[i], np.nan), color=colour, lw=6, alpha=0.3,
                    solid_capstyle="butt", zorder=1)
        if without is None:
            continue
        v_without, s_without = without
        lifted = np.flatnonzero(s_without[i] == Status.LIFT_OFF)
        end = int(lifted[0]) if lifted.size else a.size
        shown = np.where(np.isin(s_without[i, :end], VALID), v_without[i, :end], np.nan)
        ax.plot(a[:end], shown, color="k", lw=0.9, ls=":", zorder=3)
        if lifted.size and end > 0 and np.isfinite(shown[-1]):
            any_lift = True
            ax.plot(a[end - 1], shown[-1], ls="none", marker="o", ms=4.5, mfc="white",
                    mec="k", zorder=4)
    return any_bounce, any_lift


def _legend(fig: plt.Figure, ax: plt.Axes, handles: list, colour_bar: bool,
            mappable: ScalarMappable, f: np.ndarray, f0: float) -> None:
    """The frequencies' colour bar (many curves) and the legend."""
    if colour_bar:
        bar = fig.colorbar(mappable, ax=ax, pad=0.01)
        bar.set_label(f"drive frequency f [Hz] ({f.size} curves; blue < $f_0$ = "
                      f"{f0:g} Hz < red)")
    if handles:
        ax.legend(handles=handles, loc="best" if colour_bar else "upper left",
                  bbox_to_anchor=None if colour_bar else (1.01, 1.0),
                  borderaxespad=0.5 if colour_bar else 0.0, fontsize=8.5,
                  title=None if colour_bar else "drive frequency f\n(blue < $f_0$ < red)",
                  title_fontsize=9, frameon=colour_bar)

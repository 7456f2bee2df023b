"""A bifurcation diagram of branches: where a periodic motion exists, where it is stable
and where it bifurcates, against the drive parameter it was continued in.

Drawn from :func:`study.branch` (and :func:`study.doubled_branch`) results from Python,
or from a study result that holds the ``branches`` observable (the branches its slow
sweeps ride, :mod:`study.solvers.sweep_branches`): the registered figure
``branch-diagram`` (``study figure branch-diagram FILE``, :func:`compose_result`), a
column per value of the drive axis not swept. Top: each branch's mean velocity
against the swept drive, solid where its orbit is stable and dashed where it is not
(a line split where ``stable`` changes, each piece of one style), each located
bifurcation marked with its kind's declared marker
(:data:`study.model.bifurcations.KINDS`; hollow where its location did not converge,
``bifurcation_location``) and named in the legend by its kind's name. With
flight, below: the largest hop of the base above the table the same way. Slow sweeps
(:func:`study.solvers.protocol.slow_sweep`) may be drawn over it: the velocity each
point settles on, each jump an arrow from the velocity before it to the one after.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D

from study.figures.common import (
    coupling_label,
    require_axis,
    require_dims,
    save,
    selection_text,
    structure_text,
)
from study.model.bifurcations import KINDS, LOCATED, kind_of_code

if TYPE_CHECKING:
    from study.solvers.protocol import SweptState

__all__ = ["BRANCH_VARIABLES", "compose", "compose_result", "draw", "kind_label",
           "result_branches", "stability_pieces"]

#: What a dataset must hold to be drawn as a branch (a :func:`study.branch` result).
BRANCH_VARIABLES = ("f", "a", "velocity", "stable", "bifurcation_kind", "bifurcation_f",
                    "bifurcation_a", "bifurcation_velocity", "bifurcation_step")
#: Columns of the diagram of a result at most (one per value of the axis not swept).
MAX_COLUMNS = 6
#: What each drive axis is, for labels.
_AXES = {"f": "drive frequency f [Hz]", "a": "drive acceleration a [m s$^{-2}$]"}
#: Short axis labels of the usual quantities (others: their ``long_name``).
_LABELS = {"velocity": "mean velocity", "largest_hop": "largest hop above the table"}
#: Units drawn in thousandths, and how they are then written.
_MILLI = {"m": "mm", "m s-1": "mm s$^{-1}$"}
#: The kinds at which an orbit changes its stability: a line's style switches there.
_STABILITY_KINDS = {k.code for k in KINDS
                    if k.name in ("fold", "period_doubling", "torus", "branch_point")}
_STRUCTURE_UNITS = {"f0": "Hz", "alpha": "degree", "g": "m s-2"}


def kind_label(code: int) -> str:
    """A bifurcation kind's legend text: its declared name
    (:data:`study.model.bifurcations.KINDS`), underscores as spaces."""
    return kind_of_code(int(code)).name.replace("_", " ")


def draw(branches: xr.Dataset | Sequence[xr.Dataset], output: str | Path, *,
         sweeps: Sequence[tuple[np.ndarray, SweptState]] | None = None,
         quantity: str = "velocity", labels: Sequence[str] | None = None) -> list[Path]:
    """Draw the diagram of :func:`compose` into ``output.png`` and ``output.pdf``, or
    that of :func:`compose_result` where ``branches`` is a study result holding the
    ``branches`` observable (``study figure branch-diagram FILE``).

    Parameters are those of :func:`compose`; ``output`` is the file stem (a ``.png`` or
    ``.pdf`` suffix is replaced). Returns the PNG and the PDF.
    """
    if isinstance(branches, xr.Dataset) and "branch_velocity" in branches.variables:
        fig, title = compose_result(branches)
        return save(fig, output, branches, title)
    branches = _branches(branches)
    fig = compose(branches, sweeps=sweeps, quantity=quantity, labels=labels)
    record = xr.Dataset(attrs={
        "study_name": "study.branch (Python API)",
        "study_version": branches[0].attrs.get("study_version", "?")})
    return save(fig, output, record, fig.get_suptitle().replace("\n", ", "))


def compose(branches: xr.Dataset | Sequence[xr.Dataset], *,
            sweeps: Sequence[tuple[np.ndarray, SweptState]] | None = None,
            quantity: str = "velocity", labels: Sequence[str] | None = None) -> plt.Figure:
    """The bifurcation diagram of one or more branches, not saved.

    Parameters
    ----------
    branches : xarray.Dataset or sequence of them
        :func:`study.branch` or :func:`study.doubled_branch` results, all continued
        along the same drive parameter (``along``), of the same structure.
    sweeps : sequence of (array_like, SweptState), optional
        Slow sweeps drawn over the branches: each the swept values [Hz or m s-2, along
        the branches' parameter] and the :func:`study.solvers.protocol.slow_sweep`
        result on them (one run: the other drive axis of one value). Each point is the
        velocity it settles on; a jump (``jumped``) is an arrow at the jumped point,
        from the velocity of the point before to its own.
    quantity : str, default "velocity"
        The variable along ``step`` drawn in the top panel (``"velocity"`` [m s-1],
        ``"largest_multiplier"`` [1], ``"airborne_fraction"`` [1], ...), in thousandths
        for m and m s-1. The bifurcations are marked where the branch holds their value
        of it (``bifurcation_velocity``); in the other panels a dotted vertical line
        marks each at its drive value.
    labels : sequence of str, optional
        The branches' legend names (default ``branch 1``, ``branch 2``, ...).

    Returns
    -------
    matplotlib.figure.Figure
        The top panel ``quantity``; with flight (any branch's ``flight`` attribute) and
        ``quantity`` not ``largest_hop``, a second panel of ``largest_hop`` [mm]. Each
        branch's pieces have ``gid`` ``"branch N stable"`` or ``"branch N unstable"``,
        its bifurcation markers ``"branch N <kind name>"``; a sweep's path ``"sweep
        N"`` and its jump arrows (annotations) ``"sweep N jump"``.

    Raises
    ------
    ValueError
        ``branches`` empty or holding a dataset that is not a branch (naming its index
        and what it lacks), branches along different parameters, ``quantity`` not a
        variable along ``step`` of every branch (naming those that are), ``labels`` of
        the wrong length, or ``sweeps`` that are not (values, SweptState) pairs of one
        run along the branches' parameter.
    """
    branches = _branches(branches)
    along = str(branches[0].attrs["along"])
    other = "a" if along == "f" else "f"
    names = _labels(labels, len(branches))
    _check_quantity(branches, quantity)
    paths = _sweeps(sweeps, along)
    flight = any(int(b.attrs.get("flight", 0)) for b in branches)
    panels = _panels(quantity, flight)
    fig, axes = plt.subplots(len(panels), 1, figsize=(8.5, 4.5 + 2.8 * (len(panels) - 1)),
                             layout="constrained", sharex=True, squeeze=False,
                             height_ratios=(3.0, 2.0)[:len(panels)])
    axes = axes[:, 0]
    kinds_seen = _fill(axes, branches, names, paths, panels, along)
    axes[0].legend(handles=_legend(axes[0], kinds_seen, bool(paths)), fontsize=8,
                   loc="best")
    fixed = np.unique(np.concatenate([b[other].values for b in branches]))
    where = ""
    if fixed.size == 1:
        where = (f" at a = {fixed[0]:g} m s$^{{-2}}$" if other == "a"
                 else f" at f = {fixed[0]:g} Hz")
    fig.suptitle(f"Branches along {along}{where}, solid stable, dashed unstable"
                 f"{', with flight' if flight else ''}\n{_structure(branches[0])}",
                 fontsize=11)
    return fig


def compose_result(dataset: xr.Dataset) -> tuple[plt.Figure, str]:
    """The bifurcation diagram of a study result with the ``branches`` observable
    (a slow sweep, ``[sweep] protocol``), not saved, and its title.

    One column per value of the drive axis not swept (``--sel`` one to draw it alone):
    the branches the sweeps rode there (:func:`result_branches`, each as
    :func:`compose` draws a branch: solid stable, dashed unstable, its bifurcations
    marked), the sweeps' velocities over them (each jump an arrow) and, where the file
    holds the ``jumps`` observable, each located jump ringed at its drive and velocity
    (``gid`` ``"sweep N located jump"``). With flight the largest hop below.

    Raises
    ------
    FigureError
        A file of several structures (naming the ``--sel`` to give).
    """
    along = str(dataset.attrs.get("study_protocol_along", "f"))
    other = "a" if along == "f" else "f"
    dataset = require_dims(dataset, "branch-diagram",
                           ("direction", "f", "a", "branch", "step", "bifurcation"),
                           "the branches of one structure")
    require_axis(dataset, "branch-diagram", along, f"the sweeps and branches against "
                 f"{along}")
    flight = "largest_hop" in dataset.variables
    panels = _panels("velocity", flight)
    columns = np.atleast_1d(dataset[other].values)
    if columns.size > MAX_COLUMNS:
        from study.figures import FigureError

        middle = float(columns[columns.size // 2])
        raise FigureError(
            f"figure 'branch-diagram' draws a column per value of {other}, at most "
            f"{MAX_COLUMNS}; this file (study {dataset.attrs.get('study_name')!r}) holds "
            f"{columns.size}: select one or a few, e.g. --sel {other}={middle:g} or --sel "
            f"{other}={float(columns[0]):g}:{float(columns[MAX_COLUMNS - 1]):g}")
    fig, axes = plt.subplots(len(panels), columns.size, squeeze=False, sharex=True,
                             figsize=(1.0 + 4.6 * columns.size,
                                      4.5 + 2.8 * (len(panels) - 1)),
                             layout="constrained", height_ratios=(3.0, 2.0)[:len(panels)])
    kinds_seen: set[int] = set()
    for j, value in enumerate(columns):
        branches, names = result_branches(dataset, float(value))
        paths = _result_sweeps(dataset, along, j)
        column = axes[:, j]
        if branches:
            kinds_seen |= _fill(column, branches, names, paths, panels, along)
        else:
            column[0].text(0.5, 0.5, "no orbit to continue", ha="center",
                           transform=column[0].transAxes)
        _mark_located_jumps(column[0], dataset, along, j)
        column[0].set_title(f"a = {value:g} m s$^{{-2}}$" if other == "a"
                            else f"f = {value:g} Hz", fontsize=10)
        mine = [h for h in column[0].get_legend_handles_labels()[0]
                if str(h.get_gid()).startswith("branch ")]
        if mine:
            column[0].legend(handles=mine, fontsize=7, loc="best", title="branches",
                             title_fontsize=7)
    # The styles, the kinds marked, the sweeps and the jumps: one legend for all.
    common = [h for h in _legend(axes[0, 0], kinds_seen, True)
              if not str(h.get_gid()).startswith("branch ")]
    if any(str(line.get_gid()).endswith("located jump") for ax in axes[0]
           for line in ax.get_lines()) and not any(
               h.get_label() == "jump located (jumps)" for h in common):
        common.append(Line2D([], [], ls="none", marker="o", ms=9, mfc="none",
                             mec="black", label="jump located (jumps)"))
    fig.legend(handles=common, loc="outside lower center", ncol=min(len(common), 6),
               fontsize=8)
    head = f"Branches the slow sweeps ride along {along}, solid stable, dashed unstable"
    selected = selection_text(dataset)
    fig.suptitle(f"{head}\n{coupling_label(dataset)}\n{structure_text(dataset)}"
                 + (f"\n{selected}" if selected else ""), fontsize=11)
    return fig, (f"{head}, {coupling_label(dataset)} "
                 f"({structure_text(dataset, tex=False)})")


def result_branches(dataset: xr.Dataset, value: float) -> tuple[list[xr.Dataset],
                                                                list[str]]:
    """The branches of a study result (the ``branches`` observable) whose sweep ran at
    ``value`` of the drive axis not swept, each as a :func:`study.branch`-like dataset
    (its steps and bifurcations, the slots past them left out), and their legend
    names (the sweep and where it settled on the motion)."""
    along = str(dataset.attrs.get("study_protocol_along", "f"))
    other = "a" if along == "f" else "f"
    flight = "largest_hop" in dataset.variables
    if "branch" not in dataset["branch_sweep"].dims:  # one selected (--sel branch=N)
        dataset = dataset.assign({name: dataset[name].expand_dims("branch")
                                  for name in dataset.data_vars
                                  if str(name).startswith("branch_")})
    sweeps = dict(zip(dataset["branch_sweep"].attrs["flag_values"].tolist(),
                      dataset["branch_sweep"].attrs["flag_meanings"].split(), strict=True))
    found, names = [], []
    for b in range(dataset.sizes["branch"]):
        steps = int(dataset["branch_steps"].values[b])
        sweep = sweeps[int(dataset["branch_sweep"].values[b])]
        if (sweep == "none" or steps < 1
                or float(dataset[f"branch_start_{other}"].values[b]) != value):
            continue
        found.append(_file_branch(dataset, b, steps, along, flight))
        start = float(dataset[f"branch_start_{along}"].values[b])
        names.append(f"swept {sweep}, from {start:g} {'Hz' if along == 'f' else 'm/s²'}")
    return found, names


def _file_branch(dataset: xr.Dataset, b: int, steps: int, along: str, flight: bool
                 ) -> xr.Dataset:
    """Branch ``b`` of a result as a :func:`study.branch`-like dataset: its ``steps``
    steps and its bifurcations."""
    count = int(np.count_nonzero(dataset["branch_bifurcation_kind"].values[b]))

    def along_step(name: str, units: str) -> tuple[str, np.ndarray, dict[str, str]]:
        return ("step", dataset[name].values[b, :steps], {"units": units})

    def at(name: str) -> tuple[str, np.ndarray]:
        return ("bifurcation", dataset[name].values[b, :count])

    return xr.Dataset(
        {"f": along_step("branch_f", "Hz"), "a": along_step("branch_a", "m s-2"),
         "velocity": along_step("branch_velocity", "m s-1"),
         "stable": ("step", dataset["branch_stable"].values[b, :steps]),
         "largest_hop": along_step("branch_largest_hop", "m"),
         "bifurcation_kind": at("branch_bifurcation_kind"),
         "bifurcation_f": at("branch_bifurcation_f"),
         "bifurcation_a": at("branch_bifurcation_a"),
         "bifurcation_velocity": at("branch_bifurcation_velocity"),
         "bifurcation_step": at("branch_bifurcation_step"),
         # A file written before the location flag: every bifurcation taken as located.
         **({"bifurcation_location": at("branch_bifurcation_location")}
            if "branch_bifurcation_location" in dataset else {})},
        attrs={"along": along, "flight": int(flight)})


def _directions(dataset: xr.Dataset) -> list[str]:
    """The sweeps' directions of a result: its ``direction`` labels, else the one of its
    protocol."""
    if "direction" in dataset.coords:
        return [str(d) for d in np.atleast_1d(dataset["direction"].values)]
    return [str(dataset.attrs.get("study_protocol_direction", "up"))]


def _line(dataset: xr.Dataset, name: str, along: str, k: int, column: int
          ) -> np.ndarray:
    """A per-point variable along the swept axis: direction ``k``, the column
    ``column`` of the other axis (where it is a dimension: not once selected)."""
    values = dataset[name]
    if "direction" in values.dims:
        values = values.isel(direction=k)
    other = "a" if along == "f" else "f"
    if other in values.dims:
        values = values.isel({other: column})
    return np.asarray(values.transpose(along).values).reshape(-1)


def _result_sweeps(dataset: xr.Dataset, along: str, column: int
                   ) -> list[tuple[np.ndarray, Any]]:
    """The result's slow sweeps at one value of the other axis, as :func:`compose` takes
    them: each its swept values and velocities in its visiting order."""
    from types import SimpleNamespace

    swept = np.asarray(dataset[along].values, dtype=float)
    paths = []
    for k, direction in enumerate(_directions(dataset)):
        order = np.argsort(swept, kind="stable")
        if direction == "down":
            order = order[::-1]
        state = SimpleNamespace(
            velocity=_line(dataset, "velocity", along, k, column)[order],
            largest_hop=(_line(dataset, "largest_hop", along, k, column)[order]
                         if "largest_hop" in dataset.variables else None))
        jumped = _line(dataset, "jumped", along, k, column)[order].astype(bool)
        paths.append((swept[order], SimpleNamespace(state=state, jumped=jumped,
                                                    along=along, direction=direction)))
    return paths


def _mark_located_jumps(ax: plt.Axes, dataset: xr.Dataset, along: str,
                        column: int) -> None:
    """Ring each jump the ``jumps`` observable located, at its drive and velocity."""
    if "jump_f" not in dataset.variables:
        return
    for k, _ in enumerate(_directions(dataset)):
        x = _line(dataset, f"jump_{along}", along, k, column)
        y = _line(dataset, "jump_velocity", along, k, column)
        held = np.isfinite(x) & np.isfinite(y)
        if held.any():
            ax.plot(x[held], 1e3 * y[held], ls="none", marker="o", ms=13, mfc="none",
                    mec="black", mew=1.2, zorder=6, gid=f"sweep {k} located jump")


def _panels(quantity: str, flight: bool) -> list[str]:
    """The variables drawn, a panel each: ``quantity``, and with flight the largest
    hop below it."""
    return [quantity] + (["largest_hop"] if flight and quantity != "largest_hop" else [])


def _fill(axes: Any, branches: list[xr.Dataset], names: list[str],
          paths: list[tuple[np.ndarray, SweptState]], panels: list[str],
          along: str) -> set[int]:
    """Draw the branches and the sweeps into one column of panels (``axes``, one per
    variable of ``panels``); the codes of the kinds marked."""
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    kinds_seen: set[int] = set()
    for ax, variable in zip(axes, panels, strict=True):
        scale, units = _scale(branches[0][variable])
        exact = all(f"bifurcation_{variable}" in b for b in branches)
        for n, (dataset, name) in enumerate(zip(branches, names, strict=True)):
            colour = colours[n % len(colours)]
            _draw_branch(ax, dataset, along, variable, scale, colour, n,
                         name if ax is axes[0] else None)
            codes = dataset["bifurcation_kind"].values.astype(int)
            x = dataset[f"bifurcation_{along}"].values
            # Where the location did not converge the marker is hollow: the bifurcation
            # lies within a step, not at the point drawn.
            located = (dataset["bifurcation_location"].values == LOCATED
                       if "bifurcation_location" in dataset else np.ones(codes.size, bool))
            if exact:
                y = scale * dataset[f"bifurcation_{variable}"].values
                for kind in KINDS:
                    for exactly, face, suffix in ((True, colour, ""),
                                                  (False, "none", " not converged")):
                        chosen = (codes == kind.code) & (located == exactly)
                        if chosen.any():
                            ax.plot(x[chosen], y[chosen], ls="none", marker=kind.marker,
                                    ms=8, mfc=face, mec="black", mew=0.8, zorder=5,
                                    gid=f"branch {n} {kind.name}{suffix}")
                            kinds_seen.add(kind.code)
            else:
                for value in x:
                    ax.axvline(value, color=colour, ls=":", lw=0.7,
                               gid=f"branch {n} bifurcation")
        for m, (values, swept) in enumerate(paths):
            held = getattr(swept.state, variable, None)
            if held is not None:
                _draw_sweep(ax, values, np.asarray(held, dtype=float).reshape(-1),
                            np.asarray(swept.jumped).reshape(-1), scale, m,
                            f"slow sweep {swept.direction}" if ax is axes[0] else None)
        if variable == "velocity":
            ax.axhline(0.0, color="0.6", lw=0.6, zorder=0)
        long_name = _LABELS.get(variable) or branches[0][variable].attrs.get(
            "long_name", variable)
        ax.set_ylabel(f"{long_name} [{units}]" if units else long_name)
    axes[-1].set_xlabel(_AXES[along])
    return kinds_seen


def stability_pieces(x: np.ndarray, y: np.ndarray, stable: np.ndarray,
                     inserted: dict[int, list[tuple[float, float, int]]] | None = None
                     ) -> list[tuple[np.ndarray, np.ndarray, bool]]:
    """A branch's line cut into pieces of one stability each.

    Parameters
    ----------
    x, y : numpy.ndarray
        The steps' drive values and drawn values.
    stable : numpy.ndarray
        Whether each step's orbit is stable.
    inserted : dict, optional
        Exact points to put on the line between step ``k`` and ``k + 1`` (key ``k``):
        ``(x, y, kind code)`` each, in order (the located bifurcations).

    Returns
    -------
    list of (x, y, stable)
        One piece per run of equal ``stable``, in order; consecutive pieces share their
        end point. Where the stability changes between two steps the line is cut at a
        bifurcation inserted there (one of a kind that changes stability first), else
        at the midpoint of the two steps, so that each run of steps is one piece.
    """
    inserted = inserted or {}
    stable = np.asarray(stable).astype(bool)
    pieces = []
    xs, ys, current = [float(x[0])], [float(y[0])], bool(stable[0])
    for k in range(len(x) - 1):
        extra = [(float(p[0]), float(p[1])) for p in inserted.get(k, [])]
        if bool(stable[k + 1]) == current:
            xs += [p[0] for p in extra] + [float(x[k + 1])]
            ys += [p[1] for p in extra] + [float(y[k + 1])]
            continue
        if extra:
            codes = [int(p[2]) for p in inserted[k]]
            cut = next((j for j, c in enumerate(codes) if c in _STABILITY_KINDS), 0)
            before, after = extra[:cut + 1], extra[cut:]
        else:
            middle = (0.5 * float(x[k] + x[k + 1]), 0.5 * float(y[k] + y[k + 1]))
            before, after = [middle], [middle]
        xs += [p[0] for p in before]
        ys += [p[1] for p in before]
        pieces.append((np.array(xs), np.array(ys), current))
        xs = [p[0] for p in after] + [float(x[k + 1])]
        ys = [p[1] for p in after] + [float(y[k + 1])]
        current = bool(stable[k + 1])
    pieces.append((np.array(xs), np.array(ys), current))
    return pieces


def _draw_branch(ax: plt.Axes, dataset: xr.Dataset, along: str, variable: str,
                 scale: float, colour: str, n: int, label: str | None) -> None:
    """One branch's pieces on ``ax``: solid stable, dashed unstable, through its
    located bifurcations where it holds their value of ``variable``."""
    inserted: dict[int, list[tuple[float, float, int]]] = {}
    if f"bifurcation_{variable}" in dataset:
        for b in range(dataset.sizes["bifurcation"]):
            inserted.setdefault(int(dataset["bifurcation_step"].values[b]), []).append(
                (float(dataset[f"bifurcation_{along}"].values[b]),
                 scale * float(dataset[f"bifurcation_{variable}"].values[b]),
                 int(dataset["bifurcation_kind"].values[b])))
    x = dataset[along].values
    y = scale * dataset[variable].values.astype(float)
    for xs, ys, stable in stability_pieces(x, y, dataset["stable"].values, inserted):
        ax.plot(xs, ys, color=colour, lw=1.8 if stable else 1.3, zorder=3,
                ls="-" if stable else "--", label=label,
                gid=f"branch {n} {'stable' if stable else 'unstable'}")
        label = None  # one legend entry per branch


def _draw_sweep(ax: plt.Axes, x: np.ndarray, y: np.ndarray, jumped: np.ndarray,
                scale: float, m: int, label: str | None) -> None:
    """A slow sweep's path: its points joined where it did not jump, each jump an arrow
    at the jumped point from the value before to its own."""
    y = scale * y
    ends = np.flatnonzero(jumped)
    starts = np.concatenate([[0], ends])
    stops = np.concatenate([ends, [x.size]])
    for i0, i1 in zip(starts, stops, strict=True):
        if i1 <= i0:
            continue
        ax.plot(x[i0:i1], y[i0:i1], color="0.25", lw=0.7, marker="o", ms=3.5,
                mfc="none", zorder=2, label=label, gid=f"sweep {m}")
        label = None
    for j in ends:
        if j == 0:
            continue
        ax.annotate("", xy=(x[j], y[j]), xytext=(x[j], y[j - 1]), zorder=2,
                    arrowprops={"arrowstyle": "-|>", "color": "0.25", "lw": 0.9,
                                "shrinkA": 0, "shrinkB": 0}, gid=f"sweep {m} jump")


def _legend(ax: plt.Axes, kinds: set[int], swept: bool) -> list:
    """The branches' entries, the two line styles, each kind marked, and the jumps."""
    handles = [h for h in ax.get_legend_handles_labels()[0]]
    handles += [Line2D([], [], color="0.3", ls="-", label="stable orbit"),
                Line2D([], [], color="0.3", ls="--", label="unstable orbit")]
    handles += [Line2D([], [], ls="none", marker=kind.marker, ms=7, mfc="white",
                       mec="black", label=kind_label(kind.code))
                for kind in KINDS if kind.code in kinds]
    if swept:
        handles.append(Line2D([], [], color="black", marker=r"$\downarrow$", ls="none",
                              ms=9, label="jump of a slow sweep"))
    if any(line.get_gid() and str(line.get_gid()).endswith("located jump")
           for line in ax.get_lines()):
        handles.append(Line2D([], [], ls="none", marker="o", ms=9, mfc="none",
                              mec="black", label="jump located (jumps)"))
    return handles


def _branches(branches: object) -> list[xr.Dataset]:
    """``branches`` as a checked list of branch datasets along one parameter."""
    listed = [branches] if isinstance(branches, xr.Dataset) else list(branches)  # type: ignore[call-overload]
    if not listed:
        raise ValueError("branch_diagram: 'branches' is empty; give one or more "
                         "study.branch results")
    for n, dataset in enumerate(listed):
        where = "'branches'" if isinstance(branches, xr.Dataset) else f"'branches'[{n}]"
        if not isinstance(dataset, xr.Dataset):
            raise ValueError(f"branch_diagram: {where} must be a study.branch dataset, "
                             f"got {type(dataset).__name__}")
        if "curve_kind" in dataset.attrs:
            raise ValueError(f"branch_diagram: {where} is a study.bifurcation_curve "
                             "result (a bifurcation over the drive plane), not a branch")
        missing = [v for v in BRANCH_VARIABLES if v not in dataset.variables]
        if dataset.attrs.get("along") not in ("f", "a"):
            missing.append("the attribute 'along' ('f' or 'a')")
        if missing or "step" not in dataset.dims:
            raise ValueError(f"branch_diagram: {where} is not a study.branch dataset: it "
                             f"lacks {', '.join(missing) or 'the dimension step'}")
        if dataset.sizes["step"] < 1:
            raise ValueError(f"branch_diagram: {where} has no step")
    alongs = sorted({str(d.attrs["along"]) for d in listed})
    if len(alongs) > 1:
        raise ValueError("branch_diagram: 'branches' run along different parameters ("
                         + ", ".join(f"[{n}] along {d.attrs['along']}"
                                     for n, d in enumerate(listed))
                         + "); draw one diagram per parameter")
    return listed


def _labels(labels: Sequence[str] | None, count: int) -> list[str]:
    if labels is None:
        return [f"branch {n + 1}" for n in range(count)]
    labels = [str(label) for label in labels]
    if len(labels) != count:
        raise ValueError(f"branch_diagram: 'labels' must name each of the {count} "
                         f"branches, got {len(labels)}")
    return labels


def _check_quantity(branches: list[xr.Dataset], quantity: object) -> None:
    common = set.intersection(*[
        {str(v) for v in b.data_vars if b[v].dims == ("step",)
         and np.issubdtype(b[v].dtype, np.number)} for b in branches])
    if quantity not in common:
        raise ValueError(f"branch_diagram: 'quantity' must be a number along step of "
                         f"every branch ({', '.join(sorted(common))}), got {quantity!r}")


def _sweeps(sweeps: object, along: str) -> list[tuple[np.ndarray, SweptState]]:
    """The slow sweeps checked: (values, SweptState) pairs of one run along ``along``."""
    if sweeps is None:
        return []
    checked = []
    for m, pair in enumerate(sweeps):  # type: ignore[attr-defined]
        where = f"'sweeps'[{m}]"
        if not (isinstance(pair, tuple | list) and len(pair) == 2
                and all(hasattr(pair[1], name) for name in ("state", "jumped", "along"))):
            raise ValueError(f"branch_diagram: {where} must be a pair (swept values, "
                             f"slow_sweep result), got {type(pair).__name__}")
        values = np.asarray(pair[0], dtype=float)
        swept = pair[1]
        if swept.along != along:
            raise ValueError(f"branch_diagram: {where} is swept along {swept.along}, the "
                             f"branches run along {along}")
        shape = np.shape(swept.jumped)
        if values.ndim != 1 or np.prod(shape) != values.size or values.size not in shape:
            raise ValueError(f"branch_diagram: {where} must be one run: its values (of "
                             f"shape {values.shape}) the swept axis of its result (of "
                             f"shape {shape}), the other drive axis of one value")
        checked.append((values, swept))
    return checked


def _scale(variable: xr.DataArray) -> tuple[float, str]:
    """The factor a variable is drawn with and its units as written."""
    units = str(variable.attrs.get("units", ""))
    if units in _MILLI:
        return 1e3, _MILLI[units]
    return 1.0, "" if units in ("", "1") else units


def _structure(dataset: xr.Dataset) -> str:
    """The structure's parameters a branch records (``structure_*``), as titles write
    them."""
    coords = {}
    for name in ("f0", "Q", "alpha", "M", "cs", "ck", "g", "restitution"):
        key = f"structure_{name}"
        if key in dataset.attrs:
            coords[name] = xr.Variable((), float(dataset.attrs[key]),
                                       {"units": _STRUCTURE_UNITS.get(name, "1")})
    return structure_text(xr.Dataset(coords=coords))

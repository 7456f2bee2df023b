"""What the figures share: saving as PNG and PDF with provenance in the metadata, the
structure a file was computed for, the paper's regime points (:mod:`study.model.paper`), what
a figure needs selected, colours for many curves, and a few checks."""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from study.analyses.selection import available
from study.figures.record import DRAWN_FROM
from study.model.contact import DEFAULT_LIFT_OFF
from study.model.paper import PAPER_POINTS, is_paper_structure
from study.model.status import INVALID_STATUSES, Status

__all__ = [
    "IRREGULAR",
    "MAX_LEGEND_ENTRIES",
    "MIN_CELLS",
    "PAPER_POINTS",
    "VALID",
    "cell_edges",
    "coupling_label",
    "disk_text",
    "grid_minimum",
    "in_the_air",
    "is_coarse",
    "is_flight",
    "is_paper_file",
    "is_two_way",
    "leaves_the_table",
    "lift_off_label",
    "map_mesh",
    "one_way_velocity",
    "parameter_text",
    "provenance_line",
    "require_axis",
    "require_dims",
    "restore_dim",
    "save",
    "scene_suptitle",
    "selected_keys",
    "selection_text",
    "single_structure",
    "spread_indices",
    "status_handles",
    "status_hatches",
    "status_layers",
    "structure_from_dataset",
    "structure_text",
    "value_colours",
]

#: Curves beyond this many get a colour bar instead of one legend entry each.
MAX_LEGEND_ENTRIES = 8

#: An axis with fewer values than this is coarse: a figure draws it as what it is, a
#: line or marker per value, never as a map's cells (cells over a = 10 and 12 would
#: read as values over 9-13 that were not computed).
MIN_CELLS = 5


def provenance_line(dataset: xr.Dataset) -> str:
    """One line naming the data a figure came from (study, spec hash, fingerprint)."""
    attrs = dataset.attrs
    return (
        f"data: study '{attrs.get('study_name')}', spec sha256 "
        f"{attrs.get('study_spec_sha256', '?')}, fingerprint "
        f"{attrs.get('study_fingerprint', '?')}, created {attrs.get('date_created', '?')} "
        f"by study {attrs.get('study_version', '?')}"
    )


def save(fig: plt.Figure, output: str | Path, dataset: xr.Dataset, title: str) -> list[Path]:
    """Write ``output.png`` and ``output.pdf`` with the data's provenance in their metadata.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (closed afterwards).
    output : path
        File stem; a ``.png``/``.pdf`` suffix is replaced.
    dataset : xarray.Dataset
        The result file's dataset the figure was drawn from.
    title : str
        What the figure shows (also its metadata title).

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    stem = Path(output)
    if stem.suffix in (".png", ".pdf"):
        stem = stem.with_suffix("")
    source = provenance_line(dataset)
    selected = selection_text(dataset)
    if selected and selected not in title:
        title = f"{title} ({selected})"
    spec_hash = f"study_spec_sha256={dataset.attrs.get('study_spec_sha256', '')}"
    software = f"study {dataset.attrs.get('study_version', '')}"
    png_metadata = {"Title": title, "Description": source, "Source": spec_hash,
                    "Software": software}
    request = dataset.attrs.get(DRAWN_FROM)
    if request:
        png_metadata[DRAWN_FROM] = request
    pdf_metadata = {"Title": title, "Subject": source, "Keywords": spec_hash,
                    "Creator": software}
    try:
        written = [_save_atomic(fig, stem.with_suffix(".png"), dpi=150,
                                metadata=png_metadata),
                   _save_atomic(fig, stem.with_suffix(".pdf"), metadata=pdf_metadata)]
    finally:
        plt.close(fig)
    return written


def _save_atomic(fig: plt.Figure, path: Path, **options) -> Path:
    """``fig.savefig(path)`` through a temporary in the same folder, renamed over
    ``path``: a killed run never leaves a half-written figure under its name."""
    import os
    import tempfile

    from study.figures import FigureError

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix,
                                        dir=path.parent)
    except OSError as err:
        raise FigureError(f"{path}: cannot write the figure ({err.strerror or err})") from None
    os.close(handle)
    temporary = Path(name)
    try:
        fig.savefig(temporary, format=path.suffix[1:], **options)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o666 & ~umask)
        os.replace(temporary, path)
    except OSError as err:
        raise FigureError(f"{path}: cannot write the figure ({err.strerror or err})") from None
    finally:
        temporary.unlink(missing_ok=True)
    return path


def structure_from_dataset(dataset: xr.Dataset, **at: int):
    """The :class:`study.Structure` a result was computed for.

    Fixed parameters come from the file's scalar coordinates; for a swept one give
    its index, e.g. ``structure_from_dataset(ds, M=3)`` (``m_add`` for mass studies).
    """
    params = {}
    for name in ("f0", "Q", "alpha", "M", "cs", "ck", "g"):
        if name in dataset.coords and dataset[name].ndim == 0:
            params[name] = float(dataset[name])
    for name, index in at.items():
        params[name] = float(dataset[name].values[index])
        if name == "m_add":
            params["M"] = float(dataset["M"].values[index])
            del params["m_add"]
    if "ck" not in params and "cs" in params:
        params["ck"] = params["cs"]
    from study.model.structure import Structure, tilt_warnings

    with tilt_warnings(False):  # a result file's tilts are in degree by its schema
        return Structure(**params)


#: Statuses with a valid velocity (0 when static; bouncing with flight).
VALID = tuple(s for s in Status if s not in INVALID_STATUSES)


#: The statuses of motions averaged on the period map (no orbit).
IRREGULAR = (Status.CHAOTIC, Status.QUASI_PERIODIC)


def in_the_air(status: np.ndarray, airborne: np.ndarray | None = None) -> np.ndarray:
    """Where the base leaves the table in the steady motion: the bouncing orbits, and
    the irregular motions that spend time in the air (``airborne``, the airborne
    fraction of the same shape, None without flight)."""
    flying = status == Status.BOUNCING
    if airborne is not None:
        with np.errstate(invalid="ignore"):
            flying |= np.isin(status, IRREGULAR) & (np.nan_to_num(airborne) > 0.0)
    return flying


def status_layers(ax: plt.Axes, f: np.ndarray, a: np.ndarray, status: np.ndarray
                  ) -> list[Status]:
    """Paint each status declared with a flat colour (:attr:`Status.colour`: the points
    without a velocity) where it holds; ``status`` over ``(a, f)``. Returns the
    statuses painted, in code order, for :func:`status_handles`."""
    from matplotlib.colors import ListedColormap

    painted = []
    for flag in Status:
        region = status == flag
        if flag.colour is None or not np.any(region):
            continue
        ax.pcolormesh(f, a, np.ma.masked_where(~region, np.ones(region.shape)),
                      cmap=ListedColormap([flag.colour]), vmin=0, vmax=1,
                      shading="nearest", rasterized=True)
        painted.append(flag)
    return painted


def status_handles(statuses: Iterable[Status]) -> list:
    """Legend entries of status layers: each status's declared flat colour or hatch and
    its legend text (:attr:`Status.legend`), once each, in code order."""
    from matplotlib.patches import Patch

    handles = []
    for flag in sorted(set(statuses)):
        if flag.colour is not None:
            handles.append(Patch(facecolor=flag.colour, edgecolor="0.3", lw=0.5,
                                 label=flag.legend))
        elif flag.hatch is not None:
            handles.append(Patch(facecolor="none", edgecolor="black", hatch=flag.hatch,
                                 label=flag.legend))
    return handles


def status_hatches(ax: plt.Axes, f: np.ndarray, a: np.ndarray, status: np.ndarray,
                   statuses: Iterable[Status] = tuple(Status)) -> list[Status]:
    """Hatch each status declared with a hatch (:attr:`Status.hatch`: classes of motion
    with a velocity drawn apart, such as continuous sliding and the irregular motions)
    over its velocity where it holds, of ``statuses`` (default all); ``status`` over
    ``(a, f)``. Returns the statuses hatched, for :func:`status_handles`."""
    hatched = []
    for flag in statuses:
        region = status == flag
        if flag.hatch is None or not np.any(region):
            continue
        if min(region.shape) > 1:
            ax.contourf(f, a, region.astype(float), levels=[0.5, 1.5], colors="none",
                        hatches=[flag.hatch])
        else:  # a single row or column: no area to hatch, a mark per point
            grid_a, grid_f = np.meshgrid(a, f, indexing="ij")
            ax.plot(grid_f[region], grid_a[region], ls="none", marker="o", ms=3,
                    mfc="none", mec="black")
        hatched.append(flag)
    return hatched


def selected_keys(dataset: xr.Dataset) -> set[str]:
    """The keys of the ``--sel`` selections a dataset was cut by (``{"Q", "a"}``)."""
    chosen = str(dataset.attrs.get("study_selection", ""))
    return {part.split("=", 1)[0].strip() for part in chosen.split(", ") if "=" in part}


def selection_text(dataset: xr.Dataset) -> str:
    """``"selected: Q=30, M=0.1"`` for a dataset cut by ``--sel``, else ``""``."""
    chosen = dataset.attrs.get("study_selection")
    return f"selected: {chosen}" if chosen else ""


def require_dims(dataset: xr.Dataset, figure: str, keep: tuple[str, ...],
                 what: str, variable: str | None = None) -> xr.Dataset:
    """Refuse a file with more dimensions than a figure draws, saying what to select.

    A dimension the figure does not draw but that holds a single value (a selection
    ``--sel Q=30:30``, or a sweep of one value) is not refused: it is squeezed to a
    scalar coordinate, as ``--sel Q=30`` leaves it.

    Parameters
    ----------
    dataset : xarray.Dataset
        The (possibly already selected) result.
    figure : str
        The figure's name, for the message.
    keep : tuple of str
        The dimensions the figure draws (``("f", "a", "branch")`` for one structure).
    what : str
        What the figure draws, for the message (``"one structure over (f, a)"``).
    variable : str, optional
        Only this variable's dimensions count (else every dimension of the file).

    Returns
    -------
    xarray.Dataset
        ``dataset``, its other dimensions of one value squeezed to scalar coordinates.

    Raises
    ------
    FigureError
        Naming every other dimension with its values and the ``--sel`` to give.
    """
    from study.figures import FigureError

    dims = dataset[variable].dims if variable is not None else tuple(dataset.dims)
    single = [str(d) for d in dims if d not in keep and dataset.sizes[d] == 1]
    if single:
        dataset = dataset.squeeze(single)
        dims = dataset[variable].dims if variable is not None else tuple(dataset.dims)
    extra = [str(d) for d in dims if d not in keep]
    if not extra:
        return dataset
    along = {str(c): dataset[c].variable for c in dataset.coords
             if dataset[c].ndim == 1 and dataset[c].dims[0] in extra}
    values = available(xr.Dataset(coords=along))
    example = " ".join(f"--sel {d}={_first(dataset, d)}" for d in extra)
    raise FigureError(
        f"figure {figure!r} draws {what}, but this file (study "
        f"{dataset.attrs.get('study_name')!r}) sweeps {', '.join(extra)}: select one value "
        f"of each, e.g. {example}; available: {values}"
    )


def require_axis(dataset: xr.Dataset, figure: str, dim: str, what: str,
                 instead: str = "") -> None:
    """Refuse a file (as selected) with fewer than two values of ``dim``, an axis the
    figure draws along (a curve or a map needs several points).

    Parameters
    ----------
    dataset : xarray.Dataset
        The (possibly already selected) result.
    figure : str
        The figure's name, for the message.
    dim : str
        The axis (``"f"``, ``"a"``, ``"t"``).
    what : str
        What the figure draws along it, for the message (``"the thresholds against f"``).
    instead : str, optional
        What to draw instead, appended to the message (``"'velocity-curves' draws ..."``).

    Raises
    ------
    FigureError
        Naming the figure, the axis, the single value left and the ``--sel`` to give.
    """
    from study.figures import FigureError

    if dim in dataset.dims and dataset.sizes[dim] >= 2:
        return
    selected = dataset.attrs.get("study_selection")
    if dim in dataset.dims or dim in dataset.coords:
        values = np.atleast_1d(dataset[dim].values) if dim in dataset.coords else None
        left = (f"{dim}={_text(values[0])}" if values is not None and values.size == 1
                else f"{dataset.sizes.get(dim, 1)} value of {dim}")
        found = f"the selection leaves only {left}" if selected else f"this file holds only {left}"
        advice = (f"select a range (--sel {dim}=START:STOP) or no value of {dim}"
                  if selected else f"compute several values of {dim}")
    else:
        found = f"this file has no axis {dim!r}"
        advice = f"draw it from {_source(figure)}"
    raise FigureError(
        f"figure {figure!r} draws {what}, which needs several values of {dim}; {found}: "
        f"{advice}" + (f"; {instead}" if instead else "")
    )


def _text(value: object) -> str:
    return f"{float(value):g}" if np.asarray(value).dtype.kind in "iuf" else str(value)


def _source(figure: str) -> str:
    from study.figures import FIGURES

    return FIGURES[figure].source if figure in FIGURES else "another file"


def restore_dim(dataset: xr.Dataset, dim: str, names: Iterable[str]) -> xr.Dataset:
    """Give back a dimension that a selection of one value dropped (``--sel a=7``): the
    variables and coordinates ``names`` that lack it get it, with length 1 (in front),
    and a scalar coordinate ``dim`` becomes its one-value coordinate again, so that a
    figure of a family of curves draws one curve.

    A dataset that has ``dim`` is returned as it is.
    """
    if dim in dataset.dims:
        return dataset
    value = None
    if dim in dataset.coords and dataset[dim].ndim == 0:
        value = dataset[dim].variable
        dataset = dataset.drop_vars(dim)
    restored = {}
    for name in names:
        if name in dataset.variables and dim not in dataset[name].dims:
            variable = dataset.variables[name]
            restored[name] = variable.set_dims((dim, *variable.dims),
                                               (1, *variable.shape))
    coords = {n: v for n, v in restored.items() if n in dataset.coords}
    data = {n: v for n, v in restored.items() if n not in dataset.coords}
    dataset = dataset.assign(data).assign_coords(coords)
    if value is not None:
        dataset = dataset.assign_coords(
            {dim: xr.Variable((dim,), np.atleast_1d(value.values), value.attrs)})
    return dataset


def _first(dataset: xr.Dataset, dim: str) -> str:
    if dim in dataset.coords and dataset[dim].ndim == 1 and dataset[dim].size:
        return _text(dataset[dim].values[0])
    return "0"


def single_structure(dataset: xr.Dataset, figure: str) -> xr.Dataset:
    """Refuse a file that sweeps structure parameters (the figure draws one structure),
    naming the ``--sel`` keys to give and their values; returns the dataset with any
    structure axis of one value squeezed to a scalar coordinate (:func:`require_dims`).

    Raises
    ------
    FigureError
        Naming the swept parameters and their values.
    """
    return require_dims(dataset, figure, ("f", "a", "branch"), "a single structure")


def is_coarse(values: np.ndarray) -> bool:
    """Whether an axis is too coarse for a map's cells: fewer than :data:`MIN_CELLS`
    values (a line or marker per value is drawn instead)."""
    return np.asarray(values).size < MIN_CELLS


def spread_indices(n: int, limit: int) -> list[int]:
    """Indices of at most ``limit`` of ``n`` values, evenly spread, ends included."""
    if n <= limit:
        return list(range(n))
    return sorted(set(np.rint(np.linspace(0, n - 1, limit)).astype(int).tolist()))


def cell_edges(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edges of a map's cells along one axis, and the index of the value each cell
    shows (-1 for a gap, drawn blank).

    On a regular grid a cell spans from midpoint to midpoint (a whole step at each end,
    as ``shading="nearest"``). On an irregular axis (a listed one, ``values = [...]``)
    each value's cell is only as wide as the axis's smallest step, centred on it, and
    the rest is left blank: a cell never stretches over values that were not computed.

    Parameters
    ----------
    values : numpy.ndarray
        The axis's values (at least 2, strictly monotone), in its units.

    Returns
    -------
    edges : numpy.ndarray
        ``cells + 1`` edges, in the units of ``values``.
    index : numpy.ndarray
        For each cell, the index into ``values`` it shows, or -1.
    """
    values = np.asarray(values, dtype=float)
    steps = np.diff(values)
    if values.size < 2 or not (np.all(steps > 0) or np.all(steps < 0)):
        raise ValueError(f"cell_edges needs at least 2 strictly monotone values, got "
                         f"{values.tolist()}")
    if np.allclose(steps, steps[0], rtol=1e-6, atol=0.0):
        middle = 0.5 * (values[1:] + values[:-1])
        edges = np.concatenate([[values[0] - 0.5 * steps[0]], middle,
                                [values[-1] + 0.5 * steps[-1]]])
        return edges, np.arange(values.size)
    half = 0.5 * float(np.min(np.abs(steps))) * np.sign(steps[0])
    edges = [values[0] - half]
    index = []
    for i, value in enumerate(values):
        if abs(value - half - edges[-1]) > 1e-9 * abs(half):  # a step wider: a gap
            edges.append(value - half)
            index.append(-1)
        edges.append(value + half)
        index.append(i)
    return np.array(edges), np.array(index)


def map_mesh(ax: plt.Axes, x: np.ndarray, y: np.ndarray, values: np.ndarray, **options):
    """``ax.pcolormesh`` of ``values`` (over ``(y, x)``) in cells of :func:`cell_edges`
    along each axis: a regular grid as ``shading="nearest"``, a listed axis's values in
    cells of its smallest step, blank between. Returns the mesh."""
    x_edges, x_index = cell_edges(x)
    y_edges, y_index = cell_edges(y)
    data = np.ma.masked_invalid(np.ma.asarray(values, dtype=float))
    shown = data[np.ix_(np.maximum(y_index, 0), np.maximum(x_index, 0))]
    gaps = (y_index[:, None] < 0) | (x_index[None, :] < 0)
    shown = np.ma.masked_where(gaps | np.ma.getmaskarray(shown), shown)
    return ax.pcolormesh(x_edges, y_edges, shown, **options)


def is_paper_file(dataset: xr.Dataset, ignore: tuple[str, ...] = ()) -> bool:
    """Whether the file's (selected) structure is the paper's (:mod:`study.model.paper`):
    only then are the paper's points and statements drawn."""
    params = {}
    for name in ("f0", "Q", "alpha", "M", "cs", "ck", "g"):
        if name in ignore:
            continue
        if name not in dataset.coords or dataset[name].ndim != 0:
            if name in ("ck", "g"):
                continue
            return False
        params[name] = float(dataset[name])
    return is_paper_structure(params, ignore=ignore)


def value_colours(values: np.ndarray, cmap="viridis", norm=None):
    """Colours for curves labelled by ``values`` and whether they need a colour bar.

    Returns ``(colours, mappable)``: one RGBA colour per value, and a
    ``ScalarMappable`` for ``fig.colorbar`` when there are more than
    :data:`MAX_LEGEND_ENTRIES` curves (else None: a legend entry each).
    """
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    values = np.asarray(values, dtype=float)
    cmap = colormaps[cmap] if isinstance(cmap, str) else cmap
    if norm is None:
        low, high = (float(values.min()), float(values.max())) if values.size else (0, 1)
        norm = Normalize(low, high if high > low else low + 1.0)
    if values.size == 1 and norm.vmin == values[0]:
        colours = [cmap(0.0)]
    else:
        colours = [cmap(float(norm(v)) * (0.85 if cmap.name == "viridis" else 1.0))
                   for v in values]
    if values.size <= MAX_LEGEND_ENTRIES:
        return colours, None
    mappable = ScalarMappable(norm=norm, cmap=cmap if cmap.name != "viridis" else
                              _truncated(cmap))
    return colours, mappable


def _truncated(cmap):
    from matplotlib.colors import ListedColormap

    return ListedColormap(cmap(np.linspace(0.0, 0.85, 256)), name=f"{cmap.name}-0.85")


def coupling_label(dataset: xr.Dataset) -> str:
    """Which coupling (and solver) computed the file's velocities, for titles.

    From the file's ``study_coupling`` and ``study_solver_method`` attributes: the
    paper's one-way model, or two-way coupling in which the sliding base also forces
    the plate's mode.
    """
    coupling = str(dataset.attrs.get("study_coupling", "one-way"))
    method = str(dataset.attrs.get("study_solver_method", "exact"))
    if coupling == "two-way":
        text = "two-way coupling (the sliding base also forces the mode)"
    else:
        text = "one-way coupling (the paper's model)"
    if is_flight(dataset):
        text += ", flight past lift-off"
    return text + (", time integration" if method == "integrator" else "")


def is_two_way(dataset: xr.Dataset) -> bool:
    """Whether the file's velocities are two-way coupled (``study_coupling``)."""
    return str(dataset.attrs.get("study_coupling", "one-way")) == "two-way"


def leaves_the_table(status: np.ndarray, airborne: np.ndarray | None = None
                     ) -> np.ndarray:
    """Where the study's own motion leaves the table: lift-off (without flight) and the
    motions in the air (:func:`in_the_air`: bouncing, irregular motions that fly)."""
    return (np.asarray(status) == Status.LIFT_OFF) | in_the_air(np.asarray(status), airborne)


def is_flight(dataset: xr.Dataset) -> bool:
    """Whether the file's solver followed the base past lift-off (``study_lift_off``)."""
    return str(dataset.attrs.get("study_lift_off", DEFAULT_LIFT_OFF)) == "flight"


def one_way_velocity(dataset: xr.Dataset, *order: str) -> np.ndarray | None:
    """The paper's one-way velocity held beside a two-way study (``paper_model``),
    NaN where that model does not move, transposed to ``order``; None if absent."""
    if "velocity_one_way" not in dataset or "status_one_way" not in dataset:
        return None
    velocity = dataset["velocity_one_way"].transpose(*order).values
    status = dataset["status_one_way"].transpose(*order).values
    moving = np.isin(status, (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING))
    return np.where(moving & (velocity != 0), velocity, np.nan)


#: The structure parameters every figure of a study names, in order: (TeX, plain) names.
STRUCTURE_SYMBOLS = {"f0": ("$f_0$", "f0"), "Q": ("Q", "Q"), "alpha": ("$\\alpha$", "alpha"),
                     "M": ("M", "M"), "cs": ("$c_s$", "cs"), "ck": ("$c_k$", "ck"),
                     "g": ("g", "g"), "restitution": ("e", "e")}

#: Units as titles write them, TeX and plain, from the file's CF spelling.
_UNIT_TEXT = {"degree": ("°", " degree"),
              "m s-2": (" m s$^{-2}$", " m s-2"), "m s-1": (" m s$^{-1}$", " m s-1")}


def _unit_text(units: str, tex: bool) -> str:
    if units in ("", "1"):
        return ""
    return _UNIT_TEXT.get(units, (f" {units}", f" {units}"))[0 if tex else 1]


def structure_text(dataset: xr.Dataset, omit: Iterable[str] = (), tex: bool = True) -> str:
    """Every structure parameter of :data:`STRUCTURE_SYMBOLS` the file holds, with units:
    a fixed one as ``f0 = 14.44 Hz``, a swept one (or several selected) as
    ``M = 0.08 .. 1 (6 values)``; ``cs = ck = 0.25`` when the two are equal.

    The one title builder of the figures: a figure's title names every parameter its
    data depend on (``omit`` those they do not, ``ck`` for thresholds).

    Parameters
    ----------
    dataset : xarray.Dataset
        The (selected) result.
    omit : iterable of str
        Parameters the drawn data do not depend on.
    tex : bool
        Matplotlib mathtext symbols (``$c_s$``) for a drawn title, else plain text
        (``cs``) for the files' metadata.
    """
    omit = set(omit)
    shown: dict[str, tuple[str, bool]] = {}
    for name in STRUCTURE_SYMBOLS:
        if name in omit or name not in dataset.coords:
            continue
        coord = dataset[name]
        values = np.atleast_1d(coord.values).astype(float)
        units = _unit_text(str(coord.attrs.get("units", "")), tex)
        if np.unique(values).size == 1:
            shown[name] = (f"{values[0]:g}{units}", True)
        else:
            shown[name] = (f"{values.min():.4g} .. {values.max():.4g}{units} "
                           f"({values.size} values)", False)
    merged = ("cs" in shown and "ck" in shown and shown["cs"][1] and shown["ck"][1]
              and shown["cs"][0] == shown["ck"][0])
    parts = []
    for name, (text, _) in shown.items():
        symbol = STRUCTURE_SYMBOLS[name][0 if tex else 1]
        if merged and name == "ck":
            continue
        if merged and name == "cs":
            symbol += " = " + STRUCTURE_SYMBOLS["ck"][0 if tex else 1]
        parts.append(f"{symbol} = {text}")
    return ", ".join(parts)


def disk_text(dataset: xr.Dataset, tex: bool = True) -> str:
    """The steered disk's parameters a scene's motion depends on, from the file: the
    disk's (radius, gyration radius, friction length, friction coefficients, g) on one
    line, each plate's (f0, Q, alpha, M, direction, attachment) on the next; ``""``
    for a file that does not hold them."""
    attrs = dataset.attrs
    if "disk_radius" not in attrs or "plate_f0" not in dataset:
        return ""
    symbols = {name: STRUCTURE_SYMBOLS[name][0 if tex else 1]
               for name in ("f0", "Q", "alpha", "M", "cs", "ck", "g")}
    mm = 1e3
    disk = (f"disk: radius {mm * float(attrs['disk_radius']):.3g} mm, gyration radius "
            f"{mm * float(attrs.get('disk_gyration_radius', math.nan)):.3g} mm, friction "
            f"length {mm * float(attrs.get('disk_friction_length', math.nan)):.3g} mm, "
            f"{symbols['cs']} = {float(attrs['disk_cs']):g}, {symbols['ck']} = "
            f"{float(attrs['disk_ck']):g}, g = {float(attrs['disk_g']):g}"
            f"{_unit_text('m s-2', tex)}")
    degree = _unit_text("degree", tex)
    plates = []
    names = (dataset["plate_name"].values.astype(str) if "plate_name" in dataset
             else [str(i) for i in range(dataset.sizes["plate"])])
    def plate(variable: str) -> np.ndarray:
        return (dataset[variable].values.astype(float) if variable in dataset
                else np.full(len(names), math.nan))

    for i, name in enumerate(names):
        def value(variable: str, i: int = i) -> float:
            return float(plate(variable)[i])
        plates.append(
            f"{name}: {symbols['f0']} = {value('plate_f0'):g} Hz, Q = {value('plate_Q'):g}, "
            f"{symbols['alpha']} = {value('plate_alpha'):g}{degree}, M = {value('plate_M'):g}, "
            f"towards {value('plate_direction'):g}{degree} at "
            f"({mm * value('plate_attachment_forward'):.3g}, "
            f"{mm * value('plate_attachment_left'):.3g}) mm")
    return f"{disk}\nplates: " + "; ".join(plates)


def scene_suptitle(fig: plt.Figure, dataset: xr.Dataset, head: str, fontsize: float) -> None:
    """A scene figure's title: ``head``, then the disk's and plates' parameters
    (:func:`disk_text`) and what ``--sel`` selected, each on its own line if any."""
    selected = selection_text(dataset)
    disk = disk_text(dataset)
    fig.suptitle(head + (f"\n{disk}" if disk else "")
                 + (f"\n{selected}" if selected else ""), fontsize=fontsize)


def parameter_text(dataset: xr.Dataset, omit: Iterable[str] = ()) -> str:
    """The structure's parameters (:func:`structure_text`) and on a second line what
    ``--sel`` selected, if anything."""
    text = structure_text(dataset, omit)
    selected = selection_text(dataset)
    return f"{text}\n{selected}" if selected else text


def lift_off_label(dataset: xr.Dataset) -> str:
    """What the closed-form lift-off curve is on a map of this file's velocities.

    It is the acceleration above which the normal force of the structure on a base at
    rest turns negative. In the one-way model the base's sliding never acts back on
    the mode, so that is where the model's lift-off is. With two-way coupling a
    sliding base changes the forces: moving points lie above it and lift-off points
    below, so it is only the estimate for a base at rest.
    """
    if str(dataset.attrs.get("study_coupling", "one-way")) == "two-way":
        return "lift-off of the base at rest (one-way estimate)"
    return "lift-off acceleration: n < 0 above"


#: The f grid resolves a threshold minimum when its step is below f0 / (RESOLUTION Q):
#: the nearest grid point is then within f0 / (20 Q) of the minimum, where the mode's
#: gain has dropped by less than 0.5 %.
RESOLUTION = 10.0


def grid_minimum(f: np.ndarray, curve: np.ndarray, f0: float, Q: float) -> tuple[int, bool]:
    """Index of the lowest value of ``curve`` over the grid ``f`` and whether it is a
    resolved minimum: not at an end of the range, and the step below ``f0 / (10 Q)``.
    An unresolved minimum is only an upper bound of the true one."""
    j = int(np.argmin(curve))
    step = float(np.max(np.diff(f))) if f.size > 1 else np.inf
    return j, 0 < j < f.size - 1 and step <= f0 / (RESOLUTION * Q)

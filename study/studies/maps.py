"""Labelled maps in memory: the dataset of a study, computed without a file.

:func:`compute_map` writes the study spec its arguments describe (kept in the
dataset's ``study_spec`` attribute: ``study run`` on that text writes the same
values to a file), validates it as a spec file is validated, and computes it through
the engine's own pieces: the chunks of :mod:`study.studies.sweep`, the observables of
:mod:`study.studies.observables` and the result layout of :mod:`study.studies.layout`. Variables,
dims, units, long names, flag attributes and status names are those of the file.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from study.model.contact import DEFAULT_COUPLING
from study.model.inputs import (
    SuspectInputWarning,
    as_real_array,
    bounded_integer,
    radian_tilt_note,
    tilt_looks_like_radians,
)
from study.model.parameters import STRUCTURE as STRUCTURE_TABLE
from study.model.starts import DEFAULT_START, Drop, toml_value
from study.model.structure import Structure, check_structure
from study.solvers.settings import SolverSettings, check_coupling, check_flight, check_start
from study.studies.layout import (
    coordinates,
    data_variables,
    direction_methods,
    method_attributes,
    method_of,
    observables_by_grid,
    plan_study,
)
from study.studies.observables import (
    OBSERVABLES,
    UNSWEPT_VARIABLES,
    BasinSettings,
)
from study.studies.phases import PhaseInput, computed_phase, post_map_phases
from study.studies.spec import StudySpec, parse_spec
from study.studies.spec_types import STRUCTURE_PARAMETERS
from study.studies.sweep import Rectangle, Task, compute_task
from study.studies.variables import GRID_SIZES
from study.version import VERSION

__all__ = ["MAP_SPEC_SOURCE", "compute_map", "map_spec_text"]

#: Where a map's spec "comes from", in its error messages and attributes.
MAP_SPEC_SOURCE = "study.compute_map"


def _toml_number(value: float) -> str:
    return repr(float(value))


def _toml_values(values: NDArray[np.float64]) -> str:
    return "{ values = [" + ", ".join(_toml_number(v) for v in values) + "] }"


def _toml_scalar(name: str, value: object, table: str = "protocol") -> str:
    """A protocol or basins value as TOML (a string, a boolean or a number; anything
    else is refused naming the key)."""
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, bool | np.bool_):
        return "true" if value else "false"
    if isinstance(value, int | float | np.integer | np.floating):
        return repr(value.item() if isinstance(value, np.generic) else value)
    raise TypeError(f"{table}[{name!r}] must be "
                    f"{'a string' if table == 'protocol' else 'an integer'}, got {value!r}")


def map_spec_text(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
                  observables: tuple[str, ...], coupling: str,
                  sweep: Mapping[str, NDArray[np.float64]],
                  settings: SolverSettings, flight: bool = False,
                  protocol: Mapping[str, object] | None = None,
                  basins: Mapping[str, object] | None = None) -> str:
    """The study spec (TOML) of a :func:`compute_map` call.

    The structure's parameters are fixed in ``[structure]`` except those swept; a
    kinetic friction equal to the static one (the default) follows a swept ``cs``.
    Every solver setting that decides the numbers is written where it is not the
    default (as a spec that omits it), ``protocol`` as ``[sweep] protocol``, as
    given (the spec reader checks it), and ``basins`` as ``[basins]``, as given.
    """
    fixed = structure.as_dict()
    if "cs" in sweep and "ck" not in sweep and structure.ck == structure.cs:
        del fixed["ck"]
    # Read only past lift-off: at its default it stays out, as in a spec that omits it.
    if structure.restitution == STRUCTURE_TABLE["restitution"].default:
        del fixed["restitution"]
    lines = ["[study]", 'name = "map"',
             "observables = [" + ", ".join(f'"{o}"' for o in observables) + "]", "",
             "[structure]"]
    lines += [f"{name} = {_toml_number(value)}" for name, value in fixed.items()
              if name not in sweep]
    lines += ["", "[sweep]"]
    lines += [f"{name} = {_toml_values(values)}" for name, values in sweep.items()]
    lines += [f"f = {_toml_values(f)}", f"a = {_toml_values(a)}"]
    if protocol is not None:
        lines += ["protocol = { " + ", ".join(f"{key} = {_toml_scalar(key, value)}"
                                              for key, value in protocol.items()) + " }"]
    lines += ["", "[solver]", f'coupling = "{coupling}"',
              f"max_events = {int(settings.max_events)}",
              f"max_map_iterations = {int(settings.max_map_iterations)}"]
    # Only when on, as in a spec that omits it: the text of a map without flight stays.
    lines += ["flight = true"] if flight else []
    lines += ["continuation = true"] if settings.continuation else []
    # The averaging of irregular motions, only where not the default (as the canonical
    # spec names them): the text of a map at the defaults stays.
    averaging = settings.averaging_changes()
    if "velocity_tolerance" in averaging:
        lines += [f"velocity_tolerance = {_toml_number(averaging['velocity_tolerance'])}"]
    if "max_average_periods" in averaging:
        lines += [f"max_average_periods = {int(averaging['max_average_periods'])}"]
    # And the start, where not the release.
    if settings.start != DEFAULT_START:
        lines += [f"start = {toml_value(settings.start, _toml_number)}"]
    if basins is not None:
        lines += ["", "[basins]"]
        lines += [f"{key} = {_toml_scalar(key, value, 'basins')}"
                  for key, value in basins.items()]
    return "\n".join([*lines, ""])


def _axis(name: str, values: ArrayLike) -> NDArray[np.float64]:
    array = as_real_array(name, values)
    if array.ndim > 1:
        raise ValueError(f"{name} must be a scalar or 1-D array, got shape {array.shape}")
    return np.atleast_1d(array)


def _observables(observables: object) -> tuple[str, ...]:
    if isinstance(observables, str) or not isinstance(observables, Iterable):
        raise TypeError(f"observables must be a list of names, got {observables!r}")
    names = tuple(observables)
    if not all(isinstance(name, str) for name in names):
        raise TypeError(f"observables must be a list of names, got {observables!r}")
    unknown = [name for name in names if name not in OBSERVABLES]
    if unknown:
        raise ValueError(f"observables: {', '.join(map(repr, unknown))} unknown; allowed: "
                         f"{', '.join(OBSERVABLES)}")
    return names


def compute_map(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    *,
    observables: Iterable[str] = ("thresholds", "velocity"),
    coupling: str = DEFAULT_COUPLING,
    flight: bool = False,
    sweep: Mapping[str, ArrayLike] | None = None,
    settings: SolverSettings | None = None,
    workers: int | None = None,
    start: str | Drop | None = None,
    protocol: Mapping[str, str] | None = None,
    basins: Mapping[str, int] | None = None,
) -> xr.Dataset:
    """A labelled map over the drive ``(f, a)`` and any swept structure parameter.

    The dataset a study file of the same spec holds, computed in memory: the same
    variables, dims, coordinates, ``units``, ``long_name`` and CF flag attributes
    (``status`` holds :class:`study.Status` codes named by its ``flag_meanings``),
    and bit for bit the same values.

    Parameters
    ----------
    structure : Structure
        The structure; the parameters named in ``sweep`` are replaced by the swept
        values.
    f : array_like
        Drive frequencies [Hz], 1-D (a scalar is one frequency), finite, > 0, distinct.
    a : array_like
        Drive acceleration amplitudes [m s-2], 1-D, finite, >= 0, distinct.
    observables : list of str, default ("thresholds", "velocity")
        What to compute, any of a spec's ``[study] observables``
        (:data:`study.studies.observables.OBSERVABLES`: ``"velocity"``,
        ``"thresholds"``, ``"floquet"``, ...; ``"frontier"`` needs ascending ``f``).
        Some apply to one coupling or to flight only (``"floquet"``, ``"paper_model"``:
        two-way; ``"without_flight"``: flight), as each declares
        (:attr:`study.studies.observables.Observable.couplings`, ``flight``; the user
        guide's table of observables lists them).
    coupling : {"one-way", "two-way"}, default "one-way"
        The paper's model, or the mode also forced by the sliding base
        (:data:`study.solvers.exact.DEFAULT_COUPLING` is the default).
    flight : bool, default False
        Past lift-off the base flies and lands by impacts (``[solver] flight = true``
        of a spec; needs ``coupling="two-way"`` and ``M < 1``); the velocity
        observable then also gives ``airborne_fraction`` [1], ``largest_hop`` [m] and
        ``impacts_per_period`` [1], and ``status`` may be ``bouncing``. Default: the
        solver stops with ``lift_off`` where the normal force vanishes.
    sweep : dict of str to array_like, optional
        Structure parameters to sweep, ``{"Q": [10, 17.5, 30], "alpha": [...]}``, each
        1-D in the parameter's units (``f0`` [Hz], ``alpha`` [degree], ``g`` [m s-2];
        ``Q``, ``M``, ``cs``, ``ck`` [1]); each becomes a dimension, in the order
        given, before ``f`` and ``a``.
    settings : SolverSettings, optional
        Budgets of the exact solver.
    workers : int, optional
        Threads computing the map [1]; default one per core.
    start : {"release", "switch-on"} or Drop, optional
        The state each point's motion starts from (``[solver] start`` of a spec;
        :func:`study.steady_state`); overrides ``settings.start``. Recorded in the
        dataset's attribute ``study_start``.
    protocol : dict, optional
        A slow sweep, as ``[sweep] protocol`` of a spec: ``{"along": "f" or "a",
        "direction": "up", "down" or "both"}`` (direction default ``"up"``;
        :func:`study.solvers.protocol.slow_sweep`). Needs ``coupling="two-way"``, at
        least 2 values along ``along``, no ``continuation`` and no ``"frontier"``; the
        observable ``"unswept"`` needs it. ``"both"`` gives every per-point variable a
        leading ``direction`` dimension (``up``, ``down``); the dataset records
        ``study_protocol_along`` and ``study_protocol_direction``. Default: every point
        from its start.
    basins : dict, optional
        How the observable ``"basins"`` samples each point, as ``[basins]`` of a spec:
        ``{"starts": 24, "seed": 0, "max_attractors": 8, "sweep_steps": 8}`` (any of
        them; those are the defaults). Only with ``"basins"`` among ``observables``; the
        dataset records ``study_basins_starts``, ``study_basins_seed``,
        ``study_basins_max_attractors``, ``study_basins_sweep_steps`` and
        ``study_basins_reach`` (what the starts reach), and its per-attractor variables
        (``basin_velocity``, ``basin_fraction``, ...) have a last dimension
        ``attractor`` of ``max_attractors`` slots.

    Returns
    -------
    xarray.Dataset
        Dims ``(*sweep, f)`` for closed-form variables (``a_star_plus``,
        ``a_star_minus``, ...), ``(*sweep, f, a)`` for solver variables (``velocity``
        [m s-1], ``status``, ...), ``(*sweep, a, branch)`` for the frontier; the
        fixed structure parameters are scalar coordinates. Global attributes say how
        the values were computed, as a result file's do
        (:func:`study.studies.layout.method_attributes`: ``study_solver_method``,
        ``study_coupling``, ``study_friction_law``, ``study_lift_off``, with flight
        ``study_lift_off_restitution``, and ``source``), and hold the equivalent spec
        file (``study_spec``): ``study run`` on it writes this dataset's variables to a
        file.

    Warns
    -----
    study.SuspectInputWarning
        A swept ``alpha`` holds tilts that look like radians (as
        :class:`study.Structure` warns).

    Raises
    ------
    TypeError
        ``structure`` is not a :class:`study.Structure`; ``f``, ``a`` or a swept
        parameter is not real numbers (strings, booleans, complex, dates); ``flight``
        is not a bool.
    ValueError
        An unknown coupling or observable, an observable the coupling or flight does
        not allow, or values out of range (as a spec's, the message names the key);
        ``flight`` with one-way coupling or ``M = 1``.

    See Also
    --------
    run : the same from a spec file, written to a result file.
    steady_velocity : velocities as plain arrays.

    Examples
    --------
    >>> import numpy as np, study
    >>> s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    >>> ds = study.compute_map(s, np.linspace(12, 17, 11), np.linspace(0, 10, 6))
    >>> ds["velocity"].dims
    ('f', 'a')
    >>> ds["velocity"].attrs["units"]
    'm s-1'
    """
    structure = check_structure(structure)
    coupling = check_coupling(coupling)
    flight = check_flight(flight, coupling, structure)
    names = _observables(observables)
    settings = SolverSettings() if settings is None else settings
    if not isinstance(settings, SolverSettings):
        raise TypeError(f"settings must be a study.SolverSettings, got {settings!r}")
    settings = check_start(settings, start, coupling, flight)
    swept: dict[str, NDArray[np.float64]] = {}
    for name, values in dict(sweep or {}).items():
        if name not in STRUCTURE_PARAMETERS:
            raise ValueError(f"sweep: {name!r} is not a structure parameter; allowed: "
                             f"{', '.join(STRUCTURE_PARAMETERS)}")
        swept[name] = _axis(f"sweep[{name!r}]", values)
    radian_like = [v for v in swept.get("alpha", ()) if tilt_looks_like_radians(v)]
    if radian_like:
        warnings.warn(
            f"sweep['alpha'] holds {len(radian_like)} tilts that look like angles in "
            f"radians (first {radian_like[0]!r} degree): {radian_tilt_note(radian_like[0])}",
            SuspectInputWarning, stacklevel=2)
    f_values = _axis("f", f)
    a_values = _axis("a", a)
    if protocol is not None and not isinstance(protocol, Mapping):
        raise TypeError('protocol must be a dict such as {"along": "f", "direction": "up"}, '
                        f"got {protocol!r}")
    if basins is not None and not isinstance(basins, Mapping):
        raise TypeError('basins must be a dict such as {"starts": 24, "seed": 0}, got '
                        f"{basins!r}")
    if "basins" in names:  # its settings spelled out in the equivalent spec
        basins = {**BasinSettings().canonical(), **(basins or {})}
    text = map_spec_text(structure, f_values, a_values, names, coupling, swept, settings,
                         flight, protocol, basins)
    spec = parse_spec(text, MAP_SPEC_SOURCE)
    return _computed(spec, workers)


def _computed(spec: StudySpec, workers: int | None) -> xr.Dataset:
    """Every chunk of ``spec`` computed on threads and gathered into its layout."""
    rows, points, _ = observables_by_grid(spec)
    method = method_of(spec)
    methods = direction_methods(spec)
    f = spec.axis("f").values
    a = spec.axis("a").values if spec.needs_solver else np.empty(0)
    sizes = {**GRID_SIZES, **spec.dimension_sizes, **{axis.name: len(axis) for axis in spec.axes},
             "direction": len(spec.directions)}
    variables = data_variables(spec, (*rows, *points))
    values: dict[str, NDArray[Any]] = {
        v.name: np.full(tuple(sizes[d] for d in v.dims),
                        np.nan if np.dtype(v.dtype).kind == "f" else 0, dtype=v.dtype)
        for v in variables
    }
    # The chunks of the study's file: a slow sweep's whole runs, each direction's.
    tasks = []
    for chunk in plan_study(spec):
        part = f[chunk.f_start:chunk.f_stop]
        # Rows, and the values of each point from its start alone, with the first
        # direction only (they do not depend on it), as the file's.
        here = tuple(o.name for o in points if chunk.direction == 0 or not o.unswept)
        rectangles = ((Rectangle(np.arange(part.size), np.arange(a.size)),)
                      if here and a.size else ())
        tasks.append(Task(chunk, spec.structure_at(chunk.structure_index), part, a,
                          tuple(o.name for o in rows) if chunk.direction == 0 else (),
                          here, rectangles, methods[chunk.direction]))
    threads = workers if workers is not None else (os.cpu_count() or 1)
    threads = bounded_integer("workers", threads, 1)
    with ThreadPoolExecutor(max_workers=min(int(threads), len(tasks))) as pool:
        for task, (row_values, blocks) in zip(tasks, pool.map(compute_task, tasks),
                                              strict=True):
            where = (*task.chunk.structure_index, slice(task.chunk.f_start, task.chunk.f_stop))
            for name, computed in row_values.items():
                values[name][where] = computed
            lead = (task.chunk.direction,) if spec.both_directions else ()
            for computed in blocks:
                for name, block in computed.items():
                    at = where if name in UNSWEPT_VARIABLES else (*lead, *where)
                    values[name][(*at, slice(None))] = block
    data = {v.name: (v.dims, values[v.name], v.attrs) for v in variables}
    shape = tuple(len(axis) for axis in spec.structure_axes)
    for phase in post_map_phases(spec):
        # After the map, as the runner computes them (:mod:`study.studies.phases`).
        items = {index: PhaseInput(index, structure, f, a, method, spec,
                                   {name: values[name][index] if not spec.both_directions
                                    or name in UNSWEPT_VARIABLES
                                    else values[name][(slice(None), *index)]
                                    for name in phase.reads})
                 for index, structure in spec.structures()}
        _, arrays = computed_phase(phase, items, shape)
        data.update({variable.name: (variable.dims, arrays[variable.name], variable.attrs)
                     for variable in data_variables(spec, (phase.observable,))})
    dataset = xr.Dataset(
        data, coords={c.name: (c.dims, c.values, c.attrs) for c in coordinates(spec)})
    dataset.attrs = {
        "title": f"study.compute_map: {', '.join(spec.observables)}",
        **method_attributes(spec),
        "study_version": VERSION,
        "study_spec": spec.text,
    }
    return dataset

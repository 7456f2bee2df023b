"""Branches of periodic orbits as labelled datasets: a motion continued in one drive
parameter through its folds, each bifurcation on it located exactly.

:func:`branch` answers "where does this motion exist, where does it lose stability,
where does a slow sweep jump off it?" with curves instead of grids: the orbit the
start reaches at ``(f, a)`` is continued by pseudo-arclength continuation on the exact
period map (:mod:`study.kernels.two_way.bifurcations`), through its folds onto the
unstable part and on, and every fold, period doubling, torus, grazing, slip onset and
lift-off on it is located to 1e-10 of the drive (docs/theory/branches.md).
:func:`doubled_branch` follows the orbit of twice the period born at a period doubling.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from study.model import as_acceleration, as_frequency
from study.model.bifurcations import (
    CURVE_ENDS,
    ENDS,
    KINDS,
    LOCATED,
    LOCATION_FLAGS,
    curve_end_named,
    end_named,
    kind_of_code,
)
from study.model.starts import Drop
from study.model.structure import Structure, check_structure
from study.solvers.branch import (
    DEFAULT_MAX_STEP,
    DEFAULT_MAX_STEPS,
    Trace,
    doubled_trace,
    trace,
)
from study.solvers.curves import (
    DEFAULT_CURVE_MAX_STEP,
    DEFAULT_CURVE_WINDOW,
    CurveSeed,
    follow_curve,
)
from study.solvers.settings import SolverSettings
from study.version import VERSION

__all__ = ["bifurcation_curve", "branch", "doubled_branch", "event_signature"]

#: The state's components on the section, with their units.
STATE_NAMES = ("delta", "delta_rate", "speed", "gap", "gap_rate")
STATE_UNITS = ("m", "m s-1", "m s-1", "m", "m s-1")


def branch(structure: Structure, f: float, a: float, *, along: str, to: float,
           start: str | Drop | NDArray[np.float64] = "release", coupling: str = "two-way",
           flight: bool = False, settings: SolverSettings | None = None,
           periods: int | None = None, max_steps: int = DEFAULT_MAX_STEPS,
           max_step: float = DEFAULT_MAX_STEP) -> xr.Dataset:
    """The branch of the periodic motion reached from ``start`` at ``(f, a)``, continued
    along ``along`` towards ``to``, with its bifurcations located.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : float
        Drive frequency at the start [Hz], > 0.
    a : float
        Drive acceleration at the start [m s-2], >= 0.
    along : {"f", "a"}
        The drive parameter the branch is continued in.
    to : float
        Where to continue it to [Hz for ``f``, m s-2 for ``a``], not the start's value.
    start : {"release", "switch-on"}, Drop or array_like, default "release"
        The motion to continue: the one this start reaches at ``(f, a)`` (as
        :func:`study.steady_state` finds it; a static point continues as the static
        motion), or an orbit's state at phase 0, ``(delta, delta', v[, h, h'])`` [m,
        m s-1, m s-1, m, m s-1], polished by Newton's method (``periods`` its period).
    coupling : {"two-way"}
        The exact two-way model's period map is continued.
    flight : bool, default False
        The base may fly and land (the 5-state map); without it the branch ends in a
        lift-off where its orbit would leave the table.
    settings : SolverSettings, optional
        The solver's budgets (``max_events``) and, for a named start, its start.
    periods : int, optional
        With a state given, the orbit's period in drive periods (default 1).
    max_steps : int, default 400
        The budget of steps [1], >= 2.
    max_step : float, default 0.02
        The longest step [1], in the space of the state (in its natural sizes at the
        start) and the drive (the whole way from the start to ``to`` being 1).

    Returns
    -------
    xarray.Dataset
        Along ``step``: ``f`` [Hz], ``a`` [m s-2], ``velocity`` [m s-1], ``stable``,
        the Floquet multipliers (``multiplier_modulus``, ``multiplier_angle`` [rad] over
        ``multiplier``), ``largest_multiplier``, ``event_signature`` (the period's
        events: its sticks, slips, flights and impacts), ``slips_per_period``,
        ``impacts_per_period``, ``stick_fraction``, ``airborne_fraction``,
        ``largest_hop`` [m], ``branch_direction`` (+1 where the branch runs towards
        ``to``, -1 past a fold) and the state on the section. Along ``bifurcation``:
        ``bifurcation_kind`` (a flag variable, :data:`study.model.bifurcations.KINDS`),
        ``bifurcation_f``, ``bifurcation_a``, ``bifurcation_velocity``,
        ``bifurcation_test`` (the test function's value there),
        ``bifurcation_location`` (``located``, or ``not_converged``:
        :data:`study.model.bifurcations.LOCATION_FLAGS`),
        ``bifurcation_multiplier_modulus`` and ``_angle``, ``bifurcation_step`` and the
        state and Jacobian there. Attributes: ``branch_end`` (why the trace stopped:
        :data:`study.model.bifurcations.ENDS`), ``along``, ``to``, ``start``,
        ``orbit_period``, the structure's parameters, the passes of the period map.

    Raises
    ------
    ValueError
        An unknown ``along`` or ``coupling`` (naming the allowed values), ``to`` at the
        start, a start whose motion is not a periodic orbit there (naming its status),
        a state from which Newton's method reaches no orbit, or budgets out of range.
    """
    traced, label = trace(structure, f, a, along=along, to=to, start=start,
                          coupling=coupling, flight=flight, settings=settings,
                          periods=periods, max_steps=max_steps, max_step=max_step)
    return branch_dataset(check_structure(structure), traced, along=along, to=to,
                          start=label)


def doubled_branch(structure: Structure, parent: xr.Dataset, bifurcation: int, *,
                   to: float | None = None, settings: SolverSettings | None = None,
                   max_steps: int = DEFAULT_MAX_STEPS,
                   max_step: float = DEFAULT_MAX_STEP) -> xr.Dataset:
    """The branch of the orbit of twice the period born at the period doubling
    ``bifurcation`` (an index along ``parent``'s ``bifurcation`` dimension) of the
    branch ``parent`` (a :func:`branch` result of ``structure``), continued towards
    ``to`` [Hz or m s-2; default the parent's ``to``].

    Raises
    ------
    ValueError
        ``bifurcation`` is not a period doubling of ``parent`` (the message lists its
        period doublings), or ``structure`` is not the parent's.
    """
    structure = _parents_structure(structure, parent, "doubled_branch")
    traced = doubled_trace(structure, _trace_of(parent), int(bifurcation),
                           to=to if to is not None else parent.attrs["to"],
                           settings=settings, max_steps=max_steps, max_step=max_step)
    return branch_dataset(structure, traced, along=parent.attrs["along"],
                          to=to if to is not None else parent.attrs["to"],
                          start=f"period doubling {int(bifurcation)} of a branch")


def _parents_structure(structure: Structure, parent: xr.Dataset, caller: str) -> Structure:
    """``structure``, checked, if it is the one ``parent`` was traced on."""
    structure = check_structure(structure)
    for name, value in structure.as_dict().items():
        if f"structure_{name}" in parent.attrs and not np.isclose(
                parent.attrs[f"structure_{name}"], value, rtol=1e-12, atol=0.0):
            raise ValueError(f"{caller}: the structure's {name} = {value!r} is not "
                             f"the parent branch's ({parent.attrs[f'structure_{name}']!r})")
    return structure


#: A curve's points by default (the window its bifurcation is sought in at the next
#: point is :data:`study.solvers.curves.DEFAULT_CURVE_WINDOW`).
DEFAULT_CURVE_POINTS = 11


def bifurcation_curve(structure: Structure, parent: xr.Dataset, bifurcation: int, *,
                      to: float, num: int = DEFAULT_CURVE_POINTS,
                      settings: SolverSettings | None = None,
                      window: float = DEFAULT_CURVE_WINDOW,
                      end_tolerance: float = 1e-6,
                      max_step: float = DEFAULT_CURVE_MAX_STEP) -> xr.Dataset:
    """The curve of a located bifurcation over the drive plane: the bifurcation
    ``bifurcation`` (an index along ``parent``'s ``bifurcation`` dimension) of the
    branch ``parent`` (a :func:`branch` result of ``structure``, continued along one
    drive parameter), followed in the other one to ``to``.

    At each of ``num`` values of the other parameter, evenly spaced from the
    bifurcation's to ``to``, the orbit of the last point found (a point of the branch
    before its bifurcation) is corrected at the new drive and continued along the first
    parameter through a window past the last location, and the same kind of bifurcation
    is located on it as :func:`branch` locates it (to 1e-10 of the drive). Each point of
    the curve is so exact; the curve between points is not interpolated. Where the
    bifurcation is no longer met (a fold's cusp, where it meets the branch's other fold;
    a curve cut by another bifurcation), the end is bracketed by bisection in the other
    parameter to ``end_tolerance``.

    Parameters
    ----------
    structure : Structure
        The structure ``parent`` was traced on.
    parent : xarray.Dataset
        A :func:`branch` result.
    bifurcation : int
        The index of the bifurcation along ``parent``'s ``bifurcation`` dimension.
    to : float
        Where to follow it to in the other drive parameter [m s-2 for a branch along
        ``f``, Hz for one along ``a``].
    num : int, default 11
        Points of the curve [1], >= 2, the bifurcation's own the first.
    settings : SolverSettings, optional
        The solver's budgets.
    window : float, default 0.02
        How far past the last location the bifurcation is sought at the next point, and
        how far before it the next point's branch starts [1, a fraction of the first
        parameter's value there], in (0, 0.5].
    end_tolerance : float, default 1e-6
        The relative width [1] to which a curve's end is bracketed in the other
        parameter, in [1e-12, 0.1].
    max_step : float, default 0.25
        The longest step of the branch each point is sought on [1], in the scaled space
        of :func:`branch` (:data:`study.solvers.curves.DEFAULT_CURVE_MAX_STEP`).

    Returns
    -------
    xarray.Dataset
        Along ``point``: ``f`` [Hz] and ``a`` [m s-2] of the bifurcation,
        ``velocity`` [m s-1] of the orbit there, ``multiplier_modulus`` and
        ``multiplier_angle`` [rad] of the multiplier that crosses, ``test`` (the test
        function's value). Attributes: ``curve_kind``, ``curve_end`` (why it stopped:
        :data:`study.model.bifurcations.CURVE_ENDS`) with its meaning, and where a curve
        ended early ``curve_end_low`` and ``curve_end_high``, the values of the other
        parameter between which the bifurcation stops being met.

    Raises
    ------
    ValueError
        ``bifurcation`` not an index of ``parent``'s bifurcations, ``to`` at the
        bifurcation's value or out of range, ``num``, ``window`` or ``end_tolerance``
        out of range, or ``structure`` not the parent's.
    """
    structure = _parents_structure(structure, parent, "bifurcation_curve")
    along = str(parent.attrs["along"])
    other = "a" if along == "f" else "f"
    count = parent.sizes["bifurcation"]
    if isinstance(bifurcation, bool) or not isinstance(bifurcation, int | np.integer) or (
            not 0 <= int(bifurcation) < count):
        raise ValueError(f"bifurcation_curve: 'bifurcation' must be an index of the "
                         f"branch's {count} bifurcations, got {bifurcation!r}")
    index = int(bifurcation)
    kind = int(parent["bifurcation_kind"].values[index])
    if "bifurcation_location" in parent and int(
            parent["bifurcation_location"].values[index]) != LOCATED:
        raise ValueError(
            f"bifurcation_curve: bifurcation {index} of the branch was not located "
            f"(bifurcation_location is "
            f"{LOCATION_FLAGS[int(parent['bifurcation_location'].values[index])]!r}, "
            "it lies within a step): continue one whose bifurcation_location is "
            "'located', or trace the branch again with a smaller max_step")
    x_found = float(parent[f"bifurcation_{along}"].values[index])
    v_start = float(parent[f"bifurcation_{other}"].values[index])
    check = as_acceleration if other == "a" else as_frequency
    if np.ndim(to) != 0:
        raise ValueError(f"bifurcation_curve: 'to' must be one number, got {to!r}")
    try:
        to = float(check(to))
    except (TypeError, ValueError) as err:
        raise ValueError(f"bifurcation_curve: 'to': {err}") from None
    if abs(to - v_start) <= 1e-9 * abs(v_start):
        raise ValueError(f"bifurcation_curve: 'to' must differ from the bifurcation's "
                         f"{other} = {v_start:g}")
    num = int(_check_number("num", num, 2, 10_000, integer=True))
    window = _check_number("window", window, 1e-9, 0.5)
    end_tolerance = _check_number("end_tolerance", end_tolerance, 1e-12, 0.1)
    step = int(parent["bifurcation_step"].values[index])
    way = np.sign(x_found - float(parent[along].values[step])) or float(
        parent["branch_direction"].values[step])
    mu0 = parent["bifurcation_multiplier_modulus"].values[index] * np.exp(
        1j * parent["bifurcation_multiplier_angle"].values[index])
    seed = CurveSeed(
        kind=kind, along=along, x=x_found, value=v_start, way=float(way),
        periods=int(parent.attrs["orbit_period"]), flight=bool(parent.attrs["flight"]),
        x_steps=parent[along].values, states=parent["section_state"].values,
        sections=parent["section_phase"].values, step=step,
        row=(float(parent["bifurcation_f"].values[index]),
             float(parent["bifurcation_a"].values[index]),
             float(parent["bifurcation_velocity"].values[index]), mu0,
             float(parent["bifurcation_test"].values[index])))
    samples = np.linspace(v_start, to, num)[1:]
    followed = follow_curve(structure, seed, samples, samples[0] - v_start,
                            settings=settings, window=window, end_tolerance=end_tolerance,
                            max_step=max_step)
    rows, end, low, high = followed.rows, followed.end, followed.low, followed.high
    return _curve_dataset(structure, parent, kind, rows, along, end, low, high)


def _check_number(name: str, value: object, low: float, high: float,
                  integer: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer
                                                 | np.floating) or (
            integer and not float(value).is_integer()):
        what = "an integer" if integer else "a number"
        raise ValueError(f"bifurcation_curve: {name!r} must be {what} in [{low:g}, "
                         f"{high:g}], got {value!r}")
    if not low <= float(value) <= high:
        raise ValueError(f"bifurcation_curve: {name!r} must be in [{low:g}, {high:g}], "
                         f"got {value!r}")
    return float(value)


def _curve_dataset(structure: Structure, parent: xr.Dataset, kind: int,
                   rows: list[tuple[float, float, float, complex, float]], along: str,
                   end: int, low: float, high: float) -> xr.Dataset:
    """The labelled dataset of a bifurcation's curve."""
    # In the order found: the samples, then those found while bracketing an end, all
    # running from the bifurcation towards `to`.
    f, a, velocity, mu, test = (np.array(column) for column in zip(*rows, strict=True))
    named = kind_of_code(kind)
    finish = curve_end_named(end)
    data = {
        "f": ("point", f, {"units": "Hz", "long_name": "drive frequency of the "
                           f"{named.name}"}),
        "a": ("point", a, {"units": "m s-2", "long_name": "drive acceleration of the "
                           f"{named.name}"}),
        "velocity": ("point", velocity, {"units": "m s-1", "long_name": "mean velocity "
                                         "of the orbit there"}),
        "multiplier_modulus": ("point", np.abs(mu), {"units": "1", "long_name":
                                                     "modulus of the multiplier that "
                                                     "crosses there"}),
        "multiplier_angle": ("point", np.angle(mu), {"units": "rad",
                                                     "long_name": "its argument"}),
        "test": ("point", test, {"units": "1", "long_name": "the test function's value "
                                 "there (0 where located by bisection)"}),
    }
    dataset = xr.Dataset({name: xr.Variable(dims, values, attrs)
                          for name, (dims, values, attrs) in data.items()},
                         coords={"point": np.arange(f.size)})
    dataset.attrs.update({
        "title": f"curve of a {named.name} over the drive plane",
        "curve_kind": named.name,
        "curve_kind_meaning": named.meaning,
        "curve_end": finish.name,
        "curve_end_meaning": finish.meaning,
        "curve_ends": ", ".join(e.name for e in CURVE_ENDS),
        "along": along,
        "continued_in": "a" if along == "f" else "f",
        "curve_end_low": low,
        "curve_end_high": high,
        "coupling": "two-way",
        "flight": int(parent.attrs["flight"]),
        "orbit_period": int(parent.attrs["orbit_period"]),
        "study_version": VERSION,
        **{f"structure_{name}": value for name, value in structure.as_dict().items()},
    })
    return dataset


def _trace_of(dataset: xr.Dataset) -> Trace:
    """The :class:`Trace` a :func:`branch` result holds, as far as its bifurcations
    need (a doubled branch starts from one)."""
    attrs = dataset.attrs
    return Trace.of_bifurcations(
        kind=dataset["bifurcation_kind"].values, t=dataset["bifurcation_t"].values,
        section=dataset["bifurcation_section"].values,
        state=dataset["bifurcation_state"].values,
        step=dataset["bifurcation_step"].values,
        jacobians=dataset["bifurcation_jacobian"].values,
        omega0=float(attrs["segment_omega0"]), a0=float(attrs["segment_a0"]),
        omega1=float(attrs["segment_omega1"]), a1=float(attrs["segment_a1"]),
        periods=int(attrs["orbit_period"]), flight=bool(attrs["flight"]),
        reference=dataset["state_scale"].values)


def event_signature(slips: float, impacts: float, stick: float, airborne: float) -> str:
    """The events of an orbit's period in words: its stick, its slips, its flight and
    its impacts per drive period (``"stick"`` for the static orbit)."""
    parts = []
    if stick > 0.0:
        parts.append("stick")
    if slips > 0.0:
        parts.append(f"{slips:g} slip" + ("" if slips == 1 else "s"))
    if airborne > 0.0:
        parts.append("flight")
    if impacts > 0.0:
        parts.append(f"{impacts:g} impact" + ("" if impacts == 1 else "s"))
    return " + ".join(parts) if parts else "slide"


def branch_dataset(structure: Structure, traced: Trace, *, along: str, to: float,
                   start: str) -> xr.Dataset:
    """The labelled dataset of a :class:`~study.solvers.branch.Trace`."""
    n = traced.multipliers.shape[1]
    f, a = traced.drive(traced.column("t"))
    multipliers = traced.multipliers
    modulus = np.abs(multipliers)
    radius = traced.column("radius")
    rows = traced.bifurcations
    b_t = traced.bifurcation_column("t")
    b_f, b_a = traced.drive(b_t)
    b_mu = (traced.bifurcation_column("multiplier_real")
            + 1j * traced.bifurcation_column("multiplier_imag"))
    signature = np.array([event_signature(*values) for values in zip(
        traced.column("slips"), traced.column("impacts"), traced.column("stick"),
        traced.column("airborne"), strict=True)], dtype=object)
    state = traced.states()
    b_state = traced.bifurcation_states()
    flags = dict(flag_values=np.array([k.code for k in KINDS], dtype=np.int8),
                 flag_meanings=" ".join(k.name for k in KINDS))
    end = end_named(traced.end)
    data = {
        "f": ("step", f, {"units": "Hz", "long_name": "drive frequency"}),
        "a": ("step", a, {"units": "m s-2", "long_name": "drive acceleration amplitude"}),
        "velocity": ("step", traced.column("velocity"),
                     {"units": "m s-1", "long_name": "mean velocity of the orbit"}),
        "stable": ("step", (radius < 1.0).astype(np.int8),
                   {"units": "1", "long_name": "whether the orbit attracts its "
                    "neighbours (every Floquet multiplier inside the unit circle)",
                    "flag_values": np.array([0, 1], dtype=np.int8),
                    "flag_meanings": "unstable stable"}),
        "largest_multiplier": ("step", radius,
                               {"units": "1", "long_name": "largest modulus of the "
                                "orbit's Floquet multipliers"}),
        "multiplier_modulus": (("step", "multiplier"), modulus,
                               {"units": "1", "long_name": "modulus of each Floquet "
                                "multiplier of the orbit (the eigenvalues of the exact "
                                "Jacobian of its period map)"}),
        "multiplier_angle": (("step", "multiplier"), np.angle(multipliers),
                             {"units": "rad", "long_name": "argument of each Floquet "
                              "multiplier (0: real positive, pi: real negative)"}),
        "event_signature": ("step", signature,
                            {"long_name": "the events of the orbit's period: its stick, "
                             "slips, flight and impacts per drive period"}),
        "slips_per_period": ("step", traced.column("slips"),
                             {"units": "1", "long_name": "slip events per drive period"}),
        "impacts_per_period": ("step", traced.column("impacts"),
                               {"units": "1", "long_name": "impacts per drive period"}),
        "stick_fraction": ("step", traced.column("stick"),
                           {"units": "1", "long_name": "fraction of the period the base "
                            "is stuck"}),
        "airborne_fraction": ("step", traced.column("airborne"),
                              {"units": "1", "long_name": "fraction of the period the "
                               "base spends off the table"}),
        "largest_hop": ("step", traced.column("hop"),
                        {"units": "m", "long_name": "largest gap between the base and "
                         "the table over the orbit"}),
        "branch_direction": ("step", np.sign(traced.column("tangent_t")).astype(np.int8),
                             {"units": "1", "long_name": "the way the branch runs: +1 "
                              "towards `to`, -1 back (past a fold)"}),
        "section_phase": ("step", traced.column("section"),
                          {"units": "1", "long_name": "the Poincare section's place in "
                           "the orbit's period (a fraction of it from phase 0)"}),
        "section_state": (("step", "state"), state,
                          {"long_name": "the orbit's state on the section"}),
        "bifurcation_kind": ("bifurcation",
                             traced.bifurcation_column("kind").astype(np.int8),
                             {"units": "1", "long_name": "kind of bifurcation",
                              **flags}),
        "bifurcation_f": ("bifurcation", b_f, {"units": "Hz",
                                               "long_name": "drive frequency there"}),
        "bifurcation_a": ("bifurcation", b_a, {"units": "m s-2",
                                               "long_name": "drive acceleration there"}),
        "bifurcation_t": ("bifurcation", b_t,
                          {"units": "1", "long_name": "its place on the segment from "
                           "the start (0) to `to` (1)"}),
        "bifurcation_velocity": ("bifurcation", traced.bifurcation_column("velocity"),
                                 {"units": "m s-1", "long_name": "mean velocity of the "
                                  "orbit there"}),
        "bifurcation_test": ("bifurcation", traced.bifurcation_column("test"),
                             {"units": "1", "long_name": "the test function's value "
                              "there (0 where located by bisection)"}),
        "bifurcation_location": ("bifurcation", traced.bifurcation_locations(),
                                 {"units": "1", "long_name": "how it was placed: "
                                  "located to 1e-10 of the drive, or not_converged (it "
                                  "lies within the step after bifurcation_step)",
                                  "flag_values": np.arange(1, len(LOCATION_FLAGS),
                                                           dtype=np.int8),
                                  "flag_meanings": " ".join(LOCATION_FLAGS[1:])}),
        "bifurcation_multiplier_modulus": ("bifurcation", np.abs(b_mu),
                                           {"units": "1", "long_name": "modulus of the "
                                            "multiplier that crosses there"}),
        "bifurcation_multiplier_angle": ("bifurcation", np.angle(b_mu),
                                         {"units": "rad", "long_name": "its argument"}),
        "bifurcation_step": ("bifurcation", traced.bifurcation_column("step").astype(np.int32),
                             {"units": "1", "long_name": "the step before it"}),
        "bifurcation_section": ("bifurcation", traced.bifurcation_column("section"),
                                {"units": "1", "long_name": "the section's place in the "
                                 "orbit's period there"}),
        "bifurcation_state": (("bifurcation", "state"), b_state,
                              {"long_name": "the orbit's state on the section there"}),
        "bifurcation_jacobian": (("bifurcation", "state", "state_from"),
                                 traced.jacobians,
                                 {"units": "1", "long_name": "the Jacobian of the period "
                                  "map there, in SI units of the state"}),
        "state_scale": ("state", traced.reference,
                        {"long_name": "natural size of each state component at the "
                         "start (the continuation's scaling)"}),
    }
    coords = {"step": np.arange(traced.steps.shape[0]),
              "multiplier": np.arange(n),
              "bifurcation": np.arange(rows.shape[0]),
              "state": list(STATE_NAMES[:n]), "state_from": list(STATE_NAMES[:n])}
    dataset = xr.Dataset({name: xr.Variable(dims, values, attrs)
                          for name, (dims, values, attrs) in data.items()}, coords=coords)
    dataset["state"].attrs["units_of_each"] = ", ".join(STATE_UNITS[:n])
    dataset.attrs.update({
        "title": "branch of a periodic orbit continued on the exact period map",
        "branch_end": end.name,
        "branch_end_meaning": end.meaning,
        "branch_ends": ", ".join(e.name for e in ENDS),
        "along": along,
        "to": float(to),
        "start": start,
        "coupling": "two-way",
        "flight": int(traced.flight),
        "orbit_period": int(traced.periods),
        "newton_passes": traced.newton_passes,
        "map_passes": traced.map_passes,
        "segment_omega0": traced.omega0, "segment_a0": traced.a0,
        "segment_omega1": traced.omega1, "segment_a1": traced.a1,
        "study_version": VERSION,
        **{f"structure_{name}": value for name, value in structure.as_dict().items()},
    })
    return dataset

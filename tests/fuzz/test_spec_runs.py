"""Seeded mutation fuzz of specs of every workflow kind, run through ``study run``.

Every workflow under ``workflows/`` is made tiny (a few points, short scenes, a small
calibration, a one-waypoint plan) so that its accepted variants run in a fraction of
a second. Each case mutates one of them (one to three mutations: a key deleted;
values of the wrong type; huge, tiny, negative, zero or non-finite numbers and
non-finite strings; very long strings; unknown or duplicated keys and tables; deep
nesting; values swapped between keys; axis tables with wrong members, a huge ``num``
or many values; other encodings, stray bytes, truncated or empty files; and valid
variations: other observables, methods, kinds and boundary values) and runs it in
this process as a user would::

    study run CASE.toml -o OUT.nc --no-progress

under a hard time limit (``signal.setitimer``; a case that reaches it is a HANG).
Allowed outcomes:

* ``accepted``: exit 0, a result file that ``study validate`` accepts, and no NaN
  in it except where a flag variable says why (:data:`NAN_FLAGS`);
* ``refused``: exit 1 with one ``study: `` message on stderr that names the spec
  file and, when a key is at fault, the key, and says what is allowed.

Anything else fails the tier: an exception escaping ``main`` (a traceback), a hang,
exit 2 (no case is a usage error), output on stdout with a refusal, a silent NaN, or
a refusal that does not name the file or the key.

Run by ``make fuzz`` (CI runs it); not part of ``make test``. ``STUDY_FUZZ_SEED``,
``STUDY_FUZZ_SPECS`` (cases) and ``STUDY_FUZZ_LIMIT`` (seconds per case) explore
further.
"""

from __future__ import annotations

import contextlib
import copy
import faulthandler
import math
import os
import random
import re
import shutil
import signal
import sys
import threading
import time
import tomllib
import traceback
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np
import pytest

from study.cli import main
from study.engine.runner import load_any
from study.engine.spec_files import SpecError
from study.model.inputs import StudyWarning
from study.model.status import INVALID_STATUSES, Status
from study.scenes.scene_spec import SceneSpec
from tests.support.reliability import record

pytestmark = pytest.mark.fuzz

#: The seed (CI uses the default; set STUDY_FUZZ_SEED to explore others).
SEED = int(os.environ.get("STUDY_FUZZ_SEED", "20261122"))
#: Mutated specs run (at least 1000 in CI).
CASES = int(os.environ.get("STUDY_FUZZ_SPECS", "1200"))
#: Time limit of one case [s]. Accepted tiny specs take 0.05-0.5 s; a mutation may
#: make a spec legitimately larger (more points, a longer scene) but never near this.
#: A mutation may also reach a kernel the base specs did not compile (a flight study
#: switched to the integrator: about 30 s of compile on a fresh clone), so the limit
#: leaves room for one compile; a hang still ends the case.
LIMIT = float(os.environ.get("STUDY_FUZZ_LIMIT", "90"))
#: A file to append one line per case to (time, outcome, mutations), to watch a run.
LOG = os.environ.get("STUDY_FUZZ_LOG")
#: Time limit of a base spec's first run [s]: it compiles the numba kernels unless
#: their on-disk cache is current.
WARM_UP_LIMIT = 600.0
#: If the time limit's exception cannot surface (the main thread stuck in native code
#: that never returns), the process is ended with every thread's traceback this
#: much later [s]: the tier fails loudly instead of hanging CI.
BACKSTOP = 120.0

WORKFLOWS = Path(__file__).resolve().parents[2] / "workflows"

#: Float variables that may hold NaN, by result kind, with the flag variable that
#: says why and its codes that allow it. Any other NaN is a silent NaN.
_INVALID = tuple(int(s) for s in INVALID_STATUSES)
_IRREGULAR = (int(Status.CHAOTIC), int(Status.QUASI_PERIODIC))
NAN_FLAGS: dict[str, dict[str, tuple[str, tuple[int, ...]]]] = {
    "study": {
        "velocity": ("status", _INVALID),
        "slips_per_period": ("status", _INVALID),
        "forward_slip_fraction": ("status", _INVALID),
        "backward_slip_fraction": ("status", _INVALID),
        "velocity_one_way": ("status_one_way", _INVALID),
        # With flight: the same points stopped at lift-off, and the flight's statistics.
        "velocity_without_flight": ("status_without_flight", _INVALID),
        # Beside a slow sweep, each point from its start alone.
        "velocity_unswept": ("status_unswept", _INVALID),
        "airborne_fraction": ("status", _INVALID),
        "largest_hop": ("status", _INVALID),
        "impacts_per_period": ("status", _INVALID),
        # An irregular motion has no orbit, so no multiplier; its averages are written
        # where the motion was averaged (irregular statuses, and not_converged with
        # average_budget), else NaN.
        "floquet_multiplier": ("status", _INVALID + _IRREGULAR),
        **{name: ("status", tuple(int(s) for s in Status
                                  if s not in (Status.CHAOTIC, Status.QUASI_PERIODIC)))
           # The interval's ends are NaN where the average is (their comment says so).
           for name in ("averaged_velocity", "averaged_velocity_low",
                        "averaged_velocity_high")},
        "velocity_error": ("status", _INVALID),
        "lyapunov_exponent": ("status", _INVALID),
        "lyapunov_error": ("status", _INVALID),
        # A slow sweep's located jumps: none where it did not jump or none was found.
        **{f"jump_{name}": ("jump_bifurcation", (-1, 0))
           for name in ("f", "a", "velocity", "multiplier_modulus", "multiplier_angle")},
        # Fold curves: no fold located at this a (fold_status other than found, 0), and
        # no bracket where a curve reached the axis's end or was not followed.
        "fold_f": ("fold_status", (1, 2, 3)),
        "fold_velocity": ("fold_status", (1, 2, 3)),
        "fold_end_last": ("fold_end", (0, 1)),
        # The forward hop's period doubling: none at this a (doubling_status other than
        # found, 0).
        "doubling_f": ("doubling_status", (1, 2, 3)),
        "doubling_velocity": ("doubling_status", (1, 2, 3)),
        # The branches a sweep rides: padding past a structure's branches (branch_sweep
        # none), past a branch's steps (branch_stable no_step) and past its bifurcations
        # (kind none); a bifurcation whose location did not converge
        # (branch_bifurcation_location not_converged, 2) may have no multiplier.
        **{f"branch_start_{name}": ("branch_sweep", (-1,)) for name in ("f", "a")},
        **{f"branch_{name}": ("branch_stable", (-1,))
           for name in ("f", "a", "velocity", "largest_multiplier", "largest_hop")},
        **{f"branch_bifurcation_{name}": ("branch_bifurcation_kind", (0,))
           for name in ("f", "a", "velocity")},
        **{f"branch_bifurcation_multiplier_{name}": ("branch_bifurcation_location",
                                                     (0, 2))
           for name in ("modulus", "angle")},
        "fold_end_past": ("fold_end", (0, 1)),
        "frontier_frequency": ("frontier_kind", (0,)),
        "frontier_bracket": ("frontier_kind", (0,)),
        # Basins: an empty attractor slot (basin_status no_attractor, -1) holds NaN, and
        # an outcome outside the model has no velocity; an irregular one no multiplier.
        **{f"basin_{name}": ("basin_status", (-1, *_INVALID))
           for name in ("velocity", "velocity_error", "largest_hop", "exponent")},
        "basin_multiplier": ("basin_status", (-1, *_INVALID, *_IRREGULAR)),
        **{f"basin_{name}": ("basin_status", (-1,))
           for name in ("fraction", "fraction_low", "fraction_high")},
        # A phase section needs a motion: none where static or without a velocity.
        **{f"section_{name}": ("status", (*_INVALID, int(Status.STATIC)))
           for name in ("delta", "delta_rate", "speed", "gap")},
    },
    # Scene flags: motion status lift_off (3), not_converged (4) and friction_paradox
    # (5); a segment not_reached (2); a plan run other than completed (0).
    "calibration": {name: ("status", (3, 4, 5)) for name in (
        "forward_speed", "lateral_speed", "turn_rate", "slips_per_period", "stuck_fraction")},
    "trajectory": {name: ("segment_status", (2,)) for name in (
        "forward_displacement", "lateral_displacement", "heading_change",
        "segment_path_length")},
    "plan": {"miss_distance": ("run_status", (1, 2, 3))},
}


# ---------------------------------------------------------------------------
# The base specs: the workflows, made tiny


def _shrink_axis(axis: dict[str, Any], n: int) -> dict[str, Any]:
    if "values" in axis:
        return {"values": axis["values"][:n]}
    if "num" not in axis:  # not an axis: the sweep's protocol table, kept as it is
        return axis
    return {**axis, "num": min(axis["num"], n)}


def tiny(raw: dict[str, Any]) -> dict[str, Any]:
    """A workflow's tables made small enough to run in well under a second."""
    raw = copy.deepcopy(raw)
    if "study" in raw:
        raw["sweep"] = {key: _shrink_axis(axis, {"f": 4, "a": 3}.get(key, 2))
                        for key, axis in raw["sweep"].items()}
        solver = raw.setdefault("solver", {})
        solver["chunk_points"] = 6  # several chunks: the runner's bookkeeping counts
        if solver.get("method") == "integrator":
            solver.update(tolerance=1e-6, max_periods=200)
        return raw
    raw["integrator"] = {"tolerance": 1e-5}
    kind = raw["scene"]["kind"]
    if kind == "trajectory":
        raw["segment"] = [dict(segment, duration=0.2) for segment in raw["segment"][:3]]
    elif kind == "calibration":
        table = raw["calibration"]
        table.update(f=_shrink_axis(table["f"], 3), a=_shrink_axis(table["a"], 2),
                     max_periods=60)
    else:
        start = raw["plan"].get("start", [0.0, 0.0, 0.0])
        heading = math.radians(start[2])
        # One waypoint 1 cm straight ahead: a short leg, no turn to plan.
        raw["plan"].update(
            waypoints=[[round(start[0] + 0.01 * math.cos(heading), 6),
                        round(start[1] + 0.01 * math.sin(heading), 6)]],
            realisations=0, sample_interval=0.1)
        raw["integrator"] = {"tolerance": 1e-4}
    return raw


def base_specs() -> dict[str, dict[str, Any]]:
    """Every workflow, tiny, by file stem."""
    specs = {}
    for path in sorted(WORKFLOWS.glob("*.toml")):
        with path.open("rb") as handle:
            specs[path.stem] = tiny(tomllib.load(handle))
    return specs


# ---------------------------------------------------------------------------
# TOML out


class Raw(str):
    """TOML written as is (dates, times, hex integers, odd forms)."""


_BARE = re.compile(r"[A-Za-z0-9_-]+")


def _key(key: str) -> str:
    return key if _BARE.fullmatch(key) else _string(key)


def _string(text: str) -> str:
    out = ['"']
    for ch in text:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _value(value: Any) -> str:
    if isinstance(value, Raw):
        return str(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        if not value:
            return "{}"
        return "{ " + ", ".join(f"{_key(k)} = {_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"cannot write {value!r} as TOML")


def _is_table_array(value: Any) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def to_toml(doc: dict[str, Any]) -> str:
    """A document as TOML: top-level values, then tables, then arrays of tables."""
    lines = [f"{_key(k)} = {_value(v)}" for k, v in doc.items()
             if not isinstance(v, dict) and not _is_table_array(v)]
    for key, table in doc.items():
        if isinstance(table, dict):
            lines += ["", f"[{_key(key)}]"]
            lines += [f"{_key(k)} = {_value(v)}" for k, v in table.items()]
    for key, tables in doc.items():
        if _is_table_array(tables):
            for table in tables:
                lines += ["", f"[[{_key(key)}]]"]
                lines += [f"{_key(k)} = {_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------
# Mutations of the document. Each returns what it did and the keys a refusal it
# causes must name (one of them); None: the key is not what would be at fault.

_NUMBERS = (
    0, 0.0, -0.0, 1, -1, 2, 0.5, -1.5, 3, 1e-300, -1e-300, 5e-324, 1e-12, 1e-14, 1e-9, 1e-6,
    1e300, -1e300, 1.7976931348623157e308, -1.7976931348623157e308, 10**30, -(10**30),
    2**63 - 1, 2**63, 2**64, -(2**63), 10**7, 10**7 + 1, 1e7, 10**9, 1e16, 1e6, 999999.0,
    10000.0, 1000.0, 100.0, 90.0, 89.999, 0.999999, 1.000001, 360.0, -360.0, 3600.0,
    math.nan, math.inf, -math.inf, Raw("1e999"), Raw("-1e999"), Raw("0x10"), Raw("1_000"),
    Raw("0o17"), Raw("+1.5"),
)
_WRONG_TYPES = (
    True, False, "abc", "", "14.2", " 1 ", "1,5", "14.2 Hz", [], [1, 2], [[1.0, 2.0]],
    ["x"], {}, {"x": 1}, {"values": [1.0]}, Raw("1979-05-27T07:32:00Z"), Raw("07:32:00"),
    Raw("1979-05-27"), Raw("1979-05-27T07:32:00"),
)
_NON_FINITE_TEXT = ("nan", "NaN", "inf", "-inf", "Infinity", "1e999", "-1e999", "1e308",
                    "none", "null")
_UNKNOWN_KEYS = ("colour", "f00", "Q ", "q", "F", "x", "études", "name2", "_", "-",
                 "num", "values", "seed", "kind")


def _slots(node: Any, path: tuple = ()) -> list[tuple]:
    """Paths of every value below ``node`` (not ``node`` itself)."""
    found = []
    items = node.items() if isinstance(node, dict) else (
        enumerate(node) if isinstance(node, list) else ())
    for key, value in items:
        found.append((*path, key))
        found += _slots(value, (*path, key))
    return found


def _get(doc: Any, path: tuple) -> Any:
    for key in path:
        doc = doc[key]
    return doc


def _set(doc: Any, path: tuple, value: Any) -> None:
    _get(doc, path[:-1])[path[-1]] = value


_MEMBERS = ("values", "num", "start", "stop", "spacing")


def _named(path: tuple) -> set[str]:
    """The keys a message about the value at ``path`` should name (one of them): the
    nearest key, and the key above it for an axis member or a list's entry."""
    keys = [str(k) for k in path if isinstance(k, str)]
    if not keys:
        return set()
    named = {keys[-1]}
    if len(keys) > 1 and (keys[-1] in _MEMBERS or not isinstance(path[-1], str)):
        named.add(keys[-2])
    return named


def _where(path: tuple) -> str:
    return ".".join(str(k) for k in path)


def _leaf_paths(doc: dict[str, Any]) -> list[tuple]:
    return [p for p in _slots(doc) if not isinstance(_get(doc, p), dict | list)]


def _number_paths(doc: dict[str, Any]) -> list[tuple]:
    return [p for p in _leaf_paths(doc)
            if isinstance(_get(doc, p), int | float) and not isinstance(_get(doc, p), bool)]


def _pick_path(rng: random.Random, doc: dict[str, Any], numbers: bool = False
               ) -> tuple | None:
    paths = _number_paths(doc) if numbers else (
        _leaf_paths(doc) if rng.random() < 0.8 else _slots(doc))
    return rng.choice(paths) if paths else None


def m_delete(rng, doc):
    path = _pick_path(rng, doc) if rng.random() < 0.6 else rng.choice(_slots(doc) or [None])
    if path is None:
        return "delete nothing", None
    del _get(doc, path[:-1])[path[-1]]
    return f"delete {_where(path)}", _named(path)


def m_wrong_type(rng, doc):
    path = _pick_path(rng, doc)
    if path is None:
        return "nothing to retype", None
    value = rng.choice(_WRONG_TYPES)
    if isinstance(_get(doc, path), str) and rng.random() < 0.5:
        value = rng.choice([1.5, 0, -3, 1e300, math.nan])
    _set(doc, path, value)
    return f"{_where(path)} = {_value(value)[:40]}", _named(path)


def m_number(rng, doc):
    path = _pick_path(rng, doc, numbers=rng.random() < 0.85)
    if path is None:
        return "no number", None
    value = rng.choice(_NUMBERS)
    _set(doc, path, value)
    return f"{_where(path)} = {_value(value)}", _named(path)


def m_scale(rng, doc):
    path = _pick_path(rng, doc, numbers=True)
    if path is None:
        return "no number", None
    old = _get(doc, path)
    power = rng.choice([-300, -100, -12, -6, -3, -1, 1, 2, 3, 6, 12, 100, 300])
    value = float(old) * 10.0**power
    if rng.random() < 0.3:
        value = -value
    _set(doc, path, value)
    return f"{_where(path)} = {old!r} x 1e{power}", _named(path)


def m_int_float(rng, doc):
    path = _pick_path(rng, doc, numbers=True)
    if path is None:
        return "no number", None
    old = _get(doc, path)
    value = float(old) if isinstance(old, int) else (
        int(old) if math.isfinite(old) and abs(old) < 1e18 else 3)
    _set(doc, path, value)
    return f"{_where(path)} = {value!r} (was {old!r})", _named(path)


def m_non_finite_text(rng, doc):
    path = _pick_path(rng, doc, numbers=rng.random() < 0.8)
    if path is None:
        return "no value", None
    value = rng.choice(_NON_FINITE_TEXT)
    _set(doc, path, value)
    return f"{_where(path)} = {value!r}", _named(path)


def m_long_string(rng, doc):
    path = _pick_path(rng, doc)
    if path is None:
        return "no value", None
    size = rng.choice([1000, 100_000, 600_000])
    value = rng.choice(["x", "é", "\u2603", "a-b_"]) * (size // 4)
    _set(doc, path, value)
    return f"{_where(path)} = a string of {len(value)} characters", _named(path)


def m_unknown_key(rng, doc):
    tables = [p for p in _slots(doc) if isinstance(_get(doc, p), dict)]
    key = rng.choice(_UNKNOWN_KEYS)
    if rng.random() < 0.1:
        key = "k" * 5000
    value = rng.choice([1, 1.5, "x", [1], True])
    if not tables or rng.random() < 0.15:
        doc[key] = value
        return f"unknown top-level key {key[:20]!r}", {key}
    path = rng.choice(tables)
    if key in _get(doc, path):
        key += "_extra"
    _get(doc, path)[key] = value
    return f"unknown key {_where(path)}.{key[:20]}", {key}


def m_unknown_table(rng, doc):
    name = rng.choice(["extra", "Study", "scene ", "structures", "plate", "segment",
                       "calibration", "plan", "trajectory", "sweep", "solver", "integrator"])
    value: Any = rng.choice([{"x": 1}, {}, [{"x": 1}], {"name": "x"}])
    if name in doc:
        # A table that exists: it gains an unknown key (duplicate tables are a
        # text mutation).
        if isinstance(doc[name], dict):
            doc[name]["bogus"] = 1
            return f"[{name}] bogus = 1", {"bogus"}
        if _is_table_array(doc[name]):
            doc[name].append({"bogus": 1})
            return f"[[{name}]] with bogus = 1 appended", {"bogus", name}
    doc[name] = value
    return f"extra table {name!r} = {_value(value)}", {name, "x"}


def _nested(rng: random.Random) -> Any:
    depth = rng.choice([3, 8, 9, 50, 2000])
    if rng.random() < 0.5:
        return Raw("[" * depth + "1" + "]" * depth)
    return Raw("{ x = " * depth + "1" + " }" * depth)


def m_nest(rng, doc):
    path = _pick_path(rng, doc)
    if path is None:
        return "no value", None
    value = _nested(rng)
    _set(doc, path, value)
    return f"{_where(path)} = nested {value[:12]}...", _named(path)


def m_swap(rng, doc):
    paths = _leaf_paths(doc)
    if len(paths) < 2:
        return "nothing to swap", None
    one, two = rng.sample(paths, 2)
    first, second = _get(doc, one), _get(doc, two)
    _set(doc, one, second)
    _set(doc, two, first)
    return f"swap {_where(one)} and {_where(two)}", _named(one) | _named(two)


def _axis_paths(doc: dict[str, Any]) -> list[tuple]:
    found = []
    for table in ("sweep", "calibration"):
        if isinstance(doc.get(table), dict):
            found += [(table, key) for key, value in doc[table].items()
                      if isinstance(value, dict) and ({"values", "num"} & set(value))]
    return found


def m_axis(rng, doc):
    """An axis table with wrong members, a wrong or huge num, odd or many values."""
    paths = _axis_paths(doc)
    if not paths:
        return m_number(rng, doc)
    path = rng.choice(paths)
    axis = copy.deepcopy(_get(doc, path))
    # An earlier mutation of the same case may have removed a member already.
    values = axis.get("values")
    if isinstance(values, list) and values:
        lo, hi = values[0], values[-1]
    else:
        lo, hi = axis.get("start", 1.0), axis.get("stop", 2.0)
    if not all(isinstance(x, int | float) and not isinstance(x, bool) for x in (lo, hi)):
        lo, hi = 1.0, 2.0
    hi = hi if hi != lo else lo + 1.0
    choice = rng.randrange(16)
    if choice == 0:
        member = rng.choice(sorted(axis))
        del axis[member]
        what = f"without {member}"
    elif choice == 1:
        axis.update({"values": [lo, hi]} if "values" not in axis else {"num": 3})
        what = "both forms"
    elif choice == 2:
        axis = {"start": lo, "stop": hi, "num": 3,
                "spacing": rng.choice(["cubic", "LOG", 1, "log"])}
        if axis["spacing"] == "log":
            axis["start"] = rng.choice([0.0, -1.0, -0.0])
        what = f"spacing {axis['spacing']!r} from {axis['start']}"
    elif choice == 3:
        axis = {"start": lo, "stop": lo, "num": rng.choice([2, 3, 10**6])}
        what = "start == stop"
    elif choice == 4:
        axis = {"start": hi, "stop": lo, "num": 3}
        what = "descending"
    elif choice == 5:
        num = rng.choice([0, -1, 2.5, True, "3", 1e7, 3.0, Raw("0x3")])
        axis = {"start": lo, "stop": hi, "num": num}
        what = f"num = {num!r}"
    elif choice == 6:
        num = rng.choice([10**7, 10**7 + 1, 10**9, 10**30, 2**63, 2**64])
        axis = {"start": lo, "stop": hi, "num": num}
        what = f"huge num = {num}"
    elif choice == 7:
        values = rng.choice([[], ["x"], [lo, "x"], [[lo, hi]], [lo, lo], [math.nan],
                             [hi, lo], [1e300], [-1.0], [0.0], [True], 5.0, "1,2", [{}]])
        axis = {"values": values}
        what = f"values = {_value(values)}"
    elif choice == 8:
        count = rng.choice([100, 1000, 10_000, 100_000])
        values = np.unique(np.round(np.linspace(lo, hi, count), 6))
        axis = {"values": [float(v) for v in values]}
        what = f"{len(values)} values"
    elif choice == 9:
        axis = {"values": [lo] * rng.choice([2, 1000])}
        what = "repeated values"
    elif choice == 10:
        axis = {"start": 1e-300, "stop": 1e300, "num": rng.choice([3, 10**7]),
                "spacing": "log"}
        what = f"log from 1e-300 to 1e300, num {axis['num']}"
    elif choice == 11:
        axis = rng.choice([[lo, hi], lo, "10:20", True, {}])
        what = f"axis = {_value(axis)}"
    elif choice == 12:
        axis = {"start": rng.choice(["a", math.nan, None, [lo]]), "stop": hi, "num": 3}
        if axis["start"] is None:
            axis["start"] = Raw("1979-05-27")
        what = f"start = {_value(axis['start'])}"
    elif choice == 13:
        axis = {"start": lo, "stop": rng.choice([1e300, 1.7976931348623157e308, 1e6, 1e4]),
                "num": rng.choice([2, 3, 50])}
        what = f"stop = {axis['stop']!r}"
    elif choice == 14:
        axis = {"start": lo, "stop": lo * (1 + 1e-15) + 1e-300, "num": rng.choice([3, 10])}
        what = "range narrower than doubles resolve"
    else:
        axis["extra"] = 1
        what = "unknown member"
    _set(doc, path, axis)
    return f"axis {_where(path)}: {what}", {path[-1], "num", "values", "start", "stop",
                                            "spacing", "extra"}


def m_many(rng, doc):
    """Many entries: segments, plates, waypoints, observables, values."""
    lists = [p for p in _slots(doc) if isinstance(_get(doc, p), list) and _get(doc, p)]
    if not lists:
        return m_number(rng, doc)
    path = rng.choice(lists)
    items = _get(doc, path)
    count = rng.choice([17, 100, 1001, 10_001])
    grown = [copy.deepcopy(items[i % len(items)]) for i in range(count)]
    _set(doc, path, grown)
    return f"{_where(path)}: {count} entries", _named(path)


_OBSERVABLES = ("resonance", "thresholds", "lift_off", "velocity", "diagnostics",
                "floquet", "attractors", "paper_model", "frontier")


def m_variation(rng, doc):
    """A valid-looking variation: accepted cases must exercise more of the code."""
    if "study" in doc and isinstance(doc["study"], dict):
        choice = rng.randrange(5)
        if choice == 0:
            chosen = rng.sample(_OBSERVABLES, rng.randint(1, 4))
            doc["study"]["observables"] = chosen
            return f"observables = {chosen}", {"observables", "observable"}
        solver = doc.setdefault("solver", {})
        if not isinstance(solver, dict):
            return "no solver table", None
        if choice == 1:
            solver["method"] = rng.choice(["integrator", "exact", "Exact", "rk4"])
            solver.setdefault("max_periods", 200)
            return f"method = {solver['method']!r}", {"method", "max_periods"}
        if choice == 2:
            solver["coupling"] = rng.choice(["two-way", "one-way", "none"])
            solver.setdefault("max_periods", 200)
            if rng.random() < 0.5:
                # Continuation is refused with one-way coupling or the integrator.
                solver["continuation"] = rng.choice([True, False, "yes", 1])
                return (f"coupling = {solver['coupling']!r}, "
                        f"continuation = {solver['continuation']!r}",
                        {"coupling", "method", "max_periods", "continuation"})
            return f"coupling = {solver['coupling']!r}", {"coupling", "method", "max_periods"}
        if choice == 3:
            key = rng.choice(["max_events", "max_map_iterations", "chunk_points",
                              "frontier_tolerance", "tolerance", "steps_per_period",
                              "max_orbit_period", "period_tolerance", "max_periods"])
            solver[key] = rng.choice([1, 2, 10, 1e-12, 1e-3, 0.5, 100, 10**6])
            return f"[solver] {key} = {solver[key]!r}", {key}
        structure = doc.get("structure")
        if isinstance(structure, dict):
            key = rng.choice(["f0", "Q", "alpha", "M", "cs", "ck", "g"])
            structure[key] = rng.choice([1e-6, 0.001, 0.1, 1.0, 89.9, 90.0, 100.0, 1000.0,
                                         1e4, 1e6, 5e-324])
            return f"[structure] {key} = {structure[key]!r}", {key}
        return "no structure table", None
    scene = doc.get("scene")
    if not isinstance(scene, dict):
        return "no scene table", None
    choice = rng.randrange(4)
    if choice == 0:
        scene["kind"] = rng.choice(["trajectory", "calibration", "plan", "Plan", "map"])
        return f"kind = {scene['kind']!r}", {"kind", "segment", "trajectory",
                                             "calibration", "plan"}
    if choice == 1 and isinstance(doc.get("disk"), dict):
        key = rng.choice(["radius", "cs", "ck", "g", "gyration_radius", "friction_length"])
        doc["disk"][key] = rng.choice([1e-9, 1e-4, 0.005, 0.02, 0.1, 1.0, 10.0, 1000.0])
        return f"[disk] {key} = {doc['disk'][key]!r}", {key}
    if choice == 2 and _is_table_array(doc.get("plate")):
        plate = rng.choice(doc["plate"])
        key = rng.choice(["f0", "Q", "alpha", "M", "direction", "attachment"])
        plate[key] = rng.choice([1e-6, 0.1, 1.0, 90.0, 1e4, -360.0, [10.0, -10.0],
                                 [0.0, 0.0]])
        return f"[[plate]] {key} = {plate[key]!r}", {key}
    table = doc.get("integrator")
    if isinstance(table, dict):
        key = rng.choice(["tolerance", "slaving"])
        table[key] = rng.choice([1e-14, 1e-10, 1e-3, 0.1, 1e-300])
        return f"[integrator] {key} = {table[key]!r}", {key}
    return "no integrator table", None


DOC_MUTATIONS = (
    (m_delete, 10), (m_wrong_type, 10), (m_number, 14), (m_scale, 6), (m_int_float, 3),
    (m_non_finite_text, 4), (m_long_string, 2), (m_unknown_key, 4), (m_unknown_table, 3),
    (m_nest, 3), (m_swap, 6), (m_axis, 10), (m_many, 4), (m_variation, 12),
)


# ---------------------------------------------------------------------------
# Mutations of the text and of the bytes: not a key's fault


def t_duplicate(rng, text):
    lines = text.splitlines()
    candidates = [i for i, line in enumerate(lines) if line.strip()]
    if not candidates:
        return text + "x = 1\nx = 1\n", "duplicate key x"
    i = rng.choice(candidates)
    lines.insert(i + 1, lines[i])
    return "\n".join(lines) + "\n", f"line {i + 1} duplicated ({lines[i][:30]!r})"


def t_truncate(rng, text):
    cut = rng.randrange(len(text) + 1)
    return text[:cut], f"truncated at character {cut}"


def t_empty(rng, text):
    replacement = rng.choice(["", "\n", "   \n\t\n", "# only a comment\n", "\ufeff"])
    return replacement, f"empty file {replacement!r}"


def t_garbage(rng, text):
    lines = text.splitlines()
    i = rng.randrange(len(lines) + 1)
    junk = rng.choice(["= 5", "[[", "[study", 'x = "unterminated', "x = [1, 2",
                       "key value", "[]", "a.b.c = 1", "\"\" = 1", "x = 1 y = 2"])
    lines.insert(i, junk)
    return "\n".join(lines) + "\n", f"line {i + 1} = {junk!r}"


TEXT_MUTATIONS = ((t_duplicate, 4), (t_truncate, 4), (t_empty, 2), (t_garbage, 2))


def b_encoding(rng, text):
    encoding = rng.choice(["utf-16", "utf-16-le", "utf-16-be", "utf-32", "utf-8-sig",
                           "latin-1", "cp1252"])
    text = text.replace("\n[", "\n# température, \u00e9t\u00e9\n[", 1)
    return text.encode(encoding, errors="replace"), f"encoded as {encoding}"


def b_bytes(rng, text):
    data = text.encode("utf-8")
    at = rng.randrange(len(data) + 1)
    junk = rng.choice([b"\xff", b"\xc3\x28", b"\x00", b"\xed\xa0\x80", b"\xef\xbb\xbf",
                       b"\x80\x80", b"\xfe\xff", b"\xe2\x82"])
    return data[:at] + junk + data[at:], f"bytes {junk!r} at {at}"


BYTE_MUTATIONS = ((b_encoding, 5), (b_bytes, 3))


@dataclass
class Case:
    """One mutated spec: its bytes, what was done, and the keys a refusal must name."""

    number: int
    base: str
    data: bytes
    done: list[str] = field(default_factory=list)
    keys: set[str] | None = field(default_factory=set)


def _weighted(rng: random.Random, table):
    functions, weights = zip(*table, strict=True)
    return rng.choices(functions, weights)[0]


def make_case(number: int, rng: random.Random, bases: dict[str, dict[str, Any]]) -> Case:
    base = rng.choice(sorted(bases))
    doc = copy.deepcopy(bases[base])
    done: list[str] = []
    keys: set[str] | None = set()
    late = []
    for _ in range(rng.choice([1, 1, 1, 1, 2, 2, 3])):
        group = rng.choices(["doc", "text", "bytes"], [80, 12, 8])[0]
        if group == "doc":
            what, named = _weighted(rng, DOC_MUTATIONS)(rng, doc)
            done.append(what)
            if named is None or keys is None:
                keys = None
            else:
                keys |= named
        else:
            late.append(group)
    text = to_toml(doc)
    data = None
    for group in sorted(late, key=["text", "bytes"].index):
        if group == "text":
            text, what = _weighted(rng, TEXT_MUTATIONS)(rng, text)
        elif data is None:
            data, what = _weighted(rng, BYTE_MUTATIONS)(rng, text)
        else:
            continue
        done.append(what)
        keys = None  # a broken file is not one key's fault
    if data is None:
        data = text.encode("utf-8")
    return Case(number, base, data, done, keys)


# ---------------------------------------------------------------------------
# Running one case and judging it


class CaseTimeout(BaseException):
    """The case reached its time limit (a BaseException: no `except Exception` in the
    code under test may swallow it)."""


@contextlib.contextmanager
def time_limit(seconds: float):
    """Raise :class:`CaseTimeout` in the main thread after ``seconds``."""

    def expire(signum, frame):
        raise CaseTimeout

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    faulthandler.dump_traceback_later(seconds + BACKSTOP, exit=True, file=sys.__stderr__)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        faulthandler.cancel_dump_traceback_later()
        signal.signal(signal.SIGALRM, previous)


def drain_threads() -> str:
    """Wait for the computing threads a timed-out run leaves behind (a local run's
    chunks cannot be stopped): they would slow every later case down."""
    started = time.perf_counter()
    for thread in threading.enumerate():
        if thread is not threading.main_thread() and thread.name.startswith("study"):
            thread.join(BACKSTOP)
            if thread.is_alive():
                pytest.fail(f"a computing thread still runs {BACKSTOP:g} s after its case "
                            "timed out: the tier cannot go on")
    return f"its threads ended {time.perf_counter() - started:.1f} s later"


#: Work the fuzz runs per case at most, by :func:`estimated_seconds` [s]. A mutation
#: can make a spec legitimately large (1e7 values of an axis, a 1e4 s trajectory, a
#: drive far below the plates' resonance): the spec layer's budgets allow hours of
#: work, which is not a hang. Such a case is parsed by the spec layer (never a
#: traceback) but not run: outcome "large". It must stay rare.
WORK = 4.0


def _speed_factor(tolerance: float) -> float:
    """Steps of an error-controlled integrator grow as tolerance^(-1/5)."""
    return max(1.0, (1e-5 / tolerance) ** 0.2)


def estimated_seconds(spec: Any) -> float:
    """A generous estimate of what running ``spec`` costs on one core [s], from its
    sizes alone (measured on the tiny workflows: an exact point about 5 us, a chunk
    about 2 ms, a planar drive period 1-4 ms plus 25 us per plate oscillation)."""
    if isinstance(spec, SceneSpec):
        f0 = max(plate.f0 for plate in spec.disk.plates)
        speed = _speed_factor(spec.settings.tolerance)

        def period(f: float) -> float:
            return (4e-3 + 2.5e-5 * f0 / f) * speed

        options = spec.options
        if spec.kind == "trajectory":
            return sum(row["duration"] * row["f"] * period(row["f"])
                       for row in options["segments"])
        if spec.kind == "calibration":
            return options["a"].size * options["max_periods"] * sum(
                period(f) for f in options["f"])
        legs = np.diff(np.vstack([options["start"][:2], options["waypoints"]]), axis=0)
        # At 5 mm s-1, every turn 1 s, flown by 3 strategies and corrected 5 times.
        drive = float(np.hypot(legs[:, 0], legs[:, 1]).sum()) / 5e-3 + 1.0 * len(legs)
        flights = 3 * (options["realisations"] + 1) + 5 * (options["realisations"] + 2)
        frequencies = options["frequencies"].values()
        return flights * drive * max(frequencies) * period(min(frequencies))
    sizes = [len(axis) for axis in spec.axes]
    structures = math.prod(len(axis) for axis in spec.structure_axes)
    chunks = structures * max(1, len(spec.axis("f")) * (
        len(spec.axis("a")) if spec.axis("a") is not None else 1) // spec.chunk_points + 1)
    seconds = 2e-3 * chunks + 1e-6 * math.prod(sizes)
    if not spec.needs_solver:
        return seconds
    points = math.prod(sizes)
    if spec.method == "exact":
        seconds += 5e-6 * points * max(1.0, spec.solver.max_events / 1e4)
    else:
        def extreme(name: str, pick) -> float:
            axis = spec.axis(name)
            return float(pick(axis.values)) if axis is not None else float(
                spec.fixed.get(name, 9.8))
        f0, q = extreme("f0", np.max), extreme("Q", np.max)
        f = float(np.min(spec.axis("f").values))
        periods = min(spec.integrator.max_periods, 50 + 5 * q)
        seconds += points * periods * (4e-5 + 2.5e-6 * f0 / f) * _speed_factor(
            spec.integrator.tolerance)
    if "frontier" in spec.observables:
        seconds += structures * len(spec.axis("a") or ()) * 4e-3
    return seconds


def declared_work(path: Path) -> float:
    """:func:`estimated_seconds` of the spec at ``path``; 0 if it does not parse."""
    try:
        with time_limit(LIMIT), warnings.catch_warnings():
            # A suspect value (a tilt that looks like radians) is study run's to say.
            warnings.simplefilter("ignore", StudyWarning)
            spec = load_any(path)
    except SpecError:
        return 0.0
    return estimated_seconds(spec)


@dataclass
class Outcome:
    kind: str  # accepted, refused, large, or a failure class
    detail: str = ""
    seconds: float = 0.0
    work: float = 0.0  # estimated_seconds of the spec


def _result_kind(nc: Any) -> str:
    return str(nc.getncattr("study_scene_kind")) if "study_scene_kind" in nc.ncattrs() \
        else "study"


def silent_nans(path: Path) -> list[str]:
    """NaN values of the result not explained by a flag (see :data:`NAN_FLAGS`)."""
    problems = []
    with netCDF4.Dataset(path) as nc:
        nc.set_auto_mask(False)
        rules = NAN_FLAGS[_result_kind(nc)]
        for name, var in nc.variables.items():
            if getattr(var.dtype, "kind", "") != "f":
                continue
            values = np.asarray(var[...])
            nan = np.isnan(values)
            if not nan.any():
                continue
            if name not in rules:
                problems.append(f"{name}: {int(nan.sum())} NaN without a flag")
                continue
            flag_name, allowed = rules[name]
            flag = np.asarray(nc.variables[flag_name][...])
            flag = flag.reshape(flag.shape + (1,) * (values.ndim - flag.ndim))
            explained = np.isin(np.broadcast_to(flag, values.shape), allowed)
            unexplained = int(np.count_nonzero(nan & ~explained))
            if unexplained:
                problems.append(f"{name}: {unexplained} NaN where {flag_name} does not say why")
    return problems


#: Refusals by the physics of a valid-looking spec rather than by one key's value
#: (a plan's command that does not move or turn the disk once calibrated; a swept
#: structure the model refuses, named by its parameter values): a mutated key may
#: cause them without being named.
CONSEQUENCES = re.compile(
    r"\[plan\]: (command '\w+'|the (left|forward) command)|invalid structure at"
    # The whole file past the size a spec may have (a mutation that repeats a table
    # ten thousand times): a property of the file, not of one key.
    r"|spec is \d+ bytes; allowed at most \d+ bytes")

_ALLOWED_WORDS = ("allowed", "required", "expected", "must", "at most", "at least", "needs",
                  "give ", "one of", "save it as", "takes", "only", "settings are", "should")


def _without_warnings(err: str) -> str:
    """stderr without study run's warnings (a suspect but allowed value)."""
    return "".join(line for line in err.splitlines(keepends=True)
                   if not line.startswith("study: warning: "))


def judge_refusal(case: Case, spec: Path, out: str, err: str) -> Outcome:
    err = _without_warnings(err)
    lines = err.splitlines()
    if out.strip():
        return Outcome("noisy refusal", f"stdout {out[:200]!r}")
    if not lines or not lines[0].startswith("study: "):
        return Outcome("bad refusal", f"stderr does not start with 'study: ': {err[:300]!r}")
    if sum(line.startswith("study: ") for line in lines) != 1 or "Traceback" in err:
        return Outcome("bad refusal", f"more than one message: {err[:500]!r}")
    if str(spec) not in err:
        return Outcome("unnamed file", err[:300])
    if case.keys and not CONSEQUENCES.search(err):
        if not any(key in err for key in case.keys if key):
            return Outcome("unnamed key", f"none of {sorted(case.keys)} in: {err[:400]}")
        if not any(word in err for word in _ALLOWED_WORDS):
            return Outcome("no allowed", err[:400])
    return Outcome("refused")


def judge_acceptance(output: Path, out: str, err: str, capfd) -> Outcome:
    if _without_warnings(err).strip():
        return Outcome("noisy acceptance", f"stderr {err[:300]!r}")
    if not output.is_file():
        return Outcome("no result", f"exit 0 without {output}; stdout {out[:200]!r}")
    try:
        with time_limit(LIMIT):
            status = main(["validate", str(output)])
    except BaseException as error:  # any escape is what the fuzz finds
        capfd.readouterr()
        return Outcome("validate crashed", "".join(traceback.format_exception(error))[-1500:])
    _, verdict = capfd.readouterr()
    if status != 0:
        return Outcome("invalid result", verdict[:600])
    nans = silent_nans(output)
    if nans:
        return Outcome("silent NaN", "; ".join(nans))
    return Outcome("accepted")


def run_case(case: Case, folder: Path, capfd, limit: float = LIMIT) -> Outcome:
    folder.mkdir()
    spec = folder / f"case-{case.number:04d}-{case.base}.toml"
    spec.write_bytes(case.data)
    output = folder / "out.nc"
    started = time.perf_counter()
    try:
        work = declared_work(spec) if case.number >= 0 else 0.0
    except CaseTimeout:
        return Outcome("HANG", f"parsing took more than {limit:g} s", limit)
    except BaseException as error:  # any escape is what the fuzz finds
        return Outcome("TRACEBACK", "".join(traceback.format_exception(error))[-2500:])
    if work > WORK:
        return Outcome("large", f"about {work:.3g} s of work: not run")
    capfd.readouterr()
    try:
        with time_limit(limit):
            status = main(["run", str(spec), "-o", str(output), "--no-progress",
                           "--cache", str(folder / "cache")])
    except CaseTimeout:
        capfd.readouterr()
        return Outcome("HANG", f"no end within {limit:g} s; {drain_threads()}", limit)
    except SystemExit as error:
        out, err = capfd.readouterr()
        return Outcome("exit via SystemExit", f"code {error.code}: {err[-600:]}")
    except BaseException as error:  # any escape is what the fuzz finds
        capfd.readouterr()
        text = "".join(traceback.format_exception(error))
        return Outcome("TRACEBACK", text[-2500:], time.perf_counter() - started)
    seconds = time.perf_counter() - started
    out, err = capfd.readouterr()
    if status == 0:
        outcome = judge_acceptance(output, out, err, capfd)
    elif status == 1:
        outcome = judge_refusal(case, spec, out, err)
    else:
        outcome = Outcome(f"exit {status}", err[:600])
    outcome.seconds = seconds
    outcome.work = work
    return outcome


GOOD = ("accepted", "refused", "large")


def test_mutated_specs_run_or_are_refused(tmp_path: Path, capfd) -> None:
    bases = base_specs()
    assert {raw["scene"]["kind"] for raw in bases.values() if "scene" in raw} == {
        "trajectory", "calibration", "plan"}
    started = time.perf_counter()
    # The unmutated tiny workflows run first (compiling what the kernels need); each
    # must be accepted, or the mutations around it would prove little.
    for name, raw in bases.items():
        case = Case(-1, name, to_toml(raw).encode("utf-8"), ["unmutated"], None)
        outcome = run_case(case, tmp_path / f"base-{name}", capfd, WARM_UP_LIMIT)
        assert outcome.kind == "accepted", (name, outcome)
    warm = time.perf_counter() - started

    rng = random.Random(SEED)
    outcomes: Counter = Counter()
    by_base: Counter = Counter()
    failures = []
    slowest: list[tuple[float, str]] = []
    for number in range(CASES):
        case = make_case(number, rng, bases)
        folder = tmp_path / f"case-{number:04d}"
        outcome = run_case(case, folder, capfd)
        outcomes[outcome.kind] += 1
        by_base[case.base, outcome.kind] += 1
        label = f"case {number} ({case.base}: {'; '.join(case.done)})"
        slowest = sorted([*slowest, (outcome.seconds, label)], reverse=True)[:5]
        if LOG:
            with open(LOG, "a", encoding="utf-8") as log:
                log.write(f"{outcome.seconds:7.2f} s {outcome.kind}: {label[:300]}\n")
        if outcome.kind not in GOOD:
            failures.append(f"{outcome.kind}: {label}\n    {outcome.detail}")
        shutil.rmtree(folder, ignore_errors=True)
    total = time.perf_counter() - started

    print(f"\nspec runs: {CASES} cases (seed {SEED}) in {total:.0f} s "
          f"({warm:.0f} s warm-up): {dict(outcomes.most_common())}")
    print("by workflow: " + ", ".join(
        f"{base} {kind} {n}" for (base, kind), n in sorted(by_base.items())))
    print("slowest: " + "; ".join(f"{s:.2f} s {label[:120]}" for s, label in slowest))
    assert not failures, f"{len(failures)} failures of {CASES}:\n" + "\n".join(failures[:40])
    # Both outcomes must be common, or the fuzz would prove little.
    assert outcomes["refused"] >= CASES // 3, outcomes
    assert outcomes["accepted"] >= CASES // 10, outcomes
    record("tests/fuzz/test_spec_runs.py",
           "specs of every workflow kind: one to three mutations each, run through study run",
           cases=CASES, faults=CASES, results_checked=outcomes["accepted"])

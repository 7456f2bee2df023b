"""Cached steady motions of the flight reference (``data/flight_points.json``).

Other tests compare the exact flight solver and the flight integrator against this file
without rerunning the slow reference. Every point is computed twice by
:func:`tests.reference.flight.steady_motion`: at its defaults and refined (``rtol =
1e-13``, twice the steps, a ten times tighter periodicity test); the tolerance written
for each quantity is ten times the difference of the two, at least a floor (velocity
``1e-9 |v| + 1e-12 m s-1``, airborne fraction ``1e-9`` (``2e-9`` with a restitution, for
the chattering cut-off), hop ``1e-9 h + 1e-15 m``). A point whose two runs do not agree
on the status or the period has no tolerance (``null``) and ``"settled": false``.

Kinds of points (the paper's structure, ``f0 = 14.44 Hz, Q = 17.5, alpha = 64 degree,
cs = 0.25``, ``M`` in ``{0.08, 0.5, 0.9, 0.99}``, restitution ``e`` in ``{0, 0.5}``):

* ``stick-slip-then-bouncing``: near resonance (13, 14.5, 16 Hz), 1 and 3 m s-2 above the
  two-way model's lift-off (it slips below lift-off); from rest.
* ``static-then-bouncing``: far below resonance (3 and 5 Hz), where the contact model
  is static up to about lift-off (at M = 0.08 up to 9.7 m s-2 at 3 Hz; at larger M it
  slips over 0.3 to 2.5 m s-2 below lift-off), at 10.5 and 12 m s-2; from rest.
* ``two-starts``: ``M`` in ``{0.9, 0.99}``, the same drive from ``"rest"`` (the exact
  solver's start), ``"still"`` (everything at rest, the drive switched on) and a 3 mm
  drop: where they differ the drive has several stable motions.
* ``large-drive``: 20 and 36 m s-2 at 14.5 Hz (long flights, flights of a whole period,
  subharmonic bouncing).
* ``drop-onto-contact``: a 3 mm drop at drives below lift-off: the landing ends in the
  contact motion (the same as from rest).
* ``chattering``: ``M = 0.5``, ``e = 0.9`` at 12 Hz, 9 m s-2, from rest: about 185
  rebounds a period, each flight ending in a long chattering sequence.

Run ``python -m tests.reference.make_flight_points`` to regenerate the file (about half
an hour on one core); ``--only NAME ...`` recomputes the named points in place.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path
from typing import Any

from tests.reference.flight import CODE_VERSION, steady_motion

__all__ = ["DATA_PATH", "compute", "point_specs", "write_points"]

#: Where the points are cached.
DATA_PATH = Path(__file__).parent / "data" / "flight_points.json"

PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "cs": 0.25, "ck": 0.25, "g": 9.8}
MASS_RATIOS = (0.08, 0.5, 0.9, 0.99)
#: Two-way lift-off amplitude [m s-2] (first LIFT_OFF on a 0.1 m s-2 grid of the exact
#: two-way solver) at the near-resonance frequencies, per M.
LIFT_OFF = {
    0.08: {13.0: 9.3, 14.5: 9.4, 16.0: 10.8},
    0.5: {13.0: 8.2, 14.5: 8.1, 16.0: 7.6},
    0.9: {13.0: 5.8, 14.5: 6.1, 16.0: 6.2},
    0.99: {13.0: 5.0, 14.5: 4.9, 16.0: 5.0},
}
DROP = 3e-3
#: Drive periods followed at most per run.
MAX_PERIODS = 2000
#: The refined run's settings.
REFINED = {"rtol": 1e-13, "steps_per_period": 64, "tol": 1e-11}


def _spec(kind: str, M: float, f: float, a: float, e: float, start: Any) -> dict:
    start_name = start if isinstance(start, str) else f"drop{start[1] * 1e3:g}mm"
    return {
        "name": f"{kind}/M{M:g}/f{f:g}/a{a:g}/e{e:g}/{start_name}",
        "kind": kind,
        "structure": {**PAPER, "M": M, "restitution": e},
        "f": f,
        "a": a,
        "restitution": e,
        "start": start if isinstance(start, str) else list(start),
    }


def point_specs() -> list[dict]:
    """The points, in the order written."""
    out = []
    for M in MASS_RATIOS:
        for f, lift in LIFT_OFF[M].items():
            for above in (1.0, 3.0):
                out.append(_spec("stick-slip-then-bouncing", M, f, round(lift + above, 1),
                                 0.0, "rest"))
            out.append(_spec("stick-slip-then-bouncing", M, f, round(lift + 2.0, 1), 0.5,
                             "rest"))
    for M in MASS_RATIOS:
        for f in (3.0, 5.0):
            for a in (10.5, 12.0):
                out.append(_spec("static-then-bouncing", M, f, a, 0.0, "rest"))
            out.append(_spec("static-then-bouncing", M, f, 12.0, 0.5, "rest"))
    for M in (0.9, 0.99):
        for f, a in ((14.5, 10.0), (14.0, 8.0), (13.0, 9.0), (16.0, 10.0)):
            for start in ("rest", "still", ("drop", DROP)):
                out.append(_spec("two-starts", M, f, a, 0.0, start))
    for start in ("rest", "still", ("drop", DROP)):
        out.append(_spec("two-starts", 0.99, 14.5, 10.0, 0.5, start))
    for M in MASS_RATIOS:
        for a in (20.0, 36.0):
            out.append(_spec("large-drive", M, 14.5, a, 0.0, "rest"))
    for M, f, a in ((0.08, 13.0, 8.5), (0.08, 16.5, 8.5), (0.08, 13.0, 5.0),
                    (0.5, 14.5, 6.0), (0.9, 13.0, 4.0), (0.99, 16.0, 3.0)):
        out.append(_spec("drop-onto-contact", M, f, a, 0.0, ("drop", DROP)))
    # A long chattering sequence (about 185 rebounds a drive period, e = 0.9): the
    # flight integrator's chattering cut-off against the reference's (about two minutes
    # of the reference on one core, hence cached).
    out.append(_spec("chattering", 0.5, 12.0, 9.0, 0.9, "rest"))
    return out


def _run(spec: dict, **options: Any):
    start = spec["start"] if isinstance(spec["start"], str) else tuple(spec["start"])
    return steady_motion(spec["structure"], spec["f"], spec["a"], start=start,
                         max_periods=MAX_PERIODS, **options)


_QUANTITIES = ("velocity", "airborne_fraction", "largest_hop", "impacts_per_period",
               "take_offs_per_period", "slips_per_period")


def _floor(name: str, value: float, e: float) -> float:
    if name == "velocity":
        return 1e-9 * abs(value) + 1e-12
    if name == "airborne_fraction":
        return 2e-9 if e > 0 else 1e-9
    return 1e-9 * abs(value) + 1e-15


def compute(spec: dict, refine: bool = True) -> dict:
    """One point: the reported quantities, and their tolerance when ``refine``.

    Parameters
    ----------
    spec : dict
        An entry of :func:`point_specs` (or of the cached file).
    refine : bool
        Also run the refined settings and derive the tolerances.

    Returns
    -------
    dict
        ``spec`` with ``status``, ``period`` [drive periods], ``velocity`` [m s-1],
        ``airborne_fraction`` [1], ``largest_hop`` [m], ``impacts_per_period``,
        ``take_offs_per_period``, ``slips_per_period`` [1], ``state`` (``delta [m],
        delta' [m s-1], v [m s-1], h [m], h' [m s-1]`` at phase 0 and the contact mode),
        ``periods`` (followed before the orbit), ``seconds`` and, with ``refine``,
        ``tolerance`` (per quantity, absolute, or null) and ``settled``.
    """
    begin = time.perf_counter()
    r = _run(spec)
    seconds = time.perf_counter() - begin
    out = {key: spec[key] for key in ("name", "kind", "structure", "f", "a", "restitution",
                                      "start")}
    out.update({
        "status": r.status,
        "period": r.period,
        **{name: float(getattr(r, name)) for name in _QUANTITIES},
        "state": [float(x) for x in r.state[:5]] + [int(r.state[5])],
        "periods": r.periods,
        "seconds": round(seconds, 2),
    })
    if not refine:
        return out
    fine = _run(spec, **REFINED)
    settled = fine.status == r.status and fine.period == r.period and r.status not in (
        "not-periodic", "friction-paradox")
    tolerance = None
    if settled:
        tolerance = {
            name: max(10 * abs(getattr(fine, name) - getattr(r, name)),
                      _floor(name, getattr(r, name), spec["restitution"]))
            for name in ("velocity", "airborne_fraction", "largest_hop")
        }
    out["tolerance"] = tolerance
    out["settled"] = settled
    return out


def _header() -> dict:
    import scipy

    return {
        "description": (
            "Steady motions of the two-way model with flight and impacts (issue 21) from "
            "tests/reference/flight.py (event-driven solve_ivp, DOP853, rtol 1e-12, own "
            "Darboux-Keller impact law); tolerances are absolute, from a refined rerun"
        ),
        "generator": "tests/reference/make_flight_points.py",
        "code_version": CODE_VERSION,
        "scipy": scipy.__version__,
        "units": {
            "f": "Hz", "a": "m s-2", "velocity": "m s-1", "airborne_fraction": "1",
            "largest_hop": "m", "impacts_per_period": "1", "take_offs_per_period": "1",
            "slips_per_period": "1", "period": "drive periods", "start drop height": "m",
        },
        "notes": [
            "start 'rest': phase 0, v = 0, on the table, mode on its steady stick response "
            "(the exact solver's start); 'still': everything at rest, the drive switched on "
            "at phase 0; ['drop', h]: released at rest h above the table at phase 0, mode at "
            "its flight equilibrium",
            "with a restitution, rebounds slower than 1e-9 a / w land plastically; "
            "impacts_per_period counts the rebounds above that cut-off (it depends on it)",
            "velocity over the measured orbit; status one of static, stick-slip, "
            "continuous, bouncing, not-periodic, friction-paradox",
        ],
    }


def write_points(path: Path = DATA_PATH, only: list[str] | None = None) -> dict:
    """Compute the points (all, or those named, kept in place) and write the file."""
    specs = point_specs()
    done: dict[str, dict] = {}
    if only and path.exists():
        done = {p["name"]: p for p in json.loads(path.read_text())["points"]}
    points = []
    for spec in specs:
        if only and spec["name"] not in only and spec["name"] in done:
            points.append(done[spec["name"]])
            continue
        entry = compute(spec)
        points.append(entry)
        print(f"{entry['name']:<55} {entry['status']:<11} N={entry['period']} "
              f"v={entry['velocity']:+.6e} air={entry['airborne_fraction']:.4f} "
              f"hop={entry['largest_hop'] * 1e3:.4f}mm imp={entry['impacts_per_period']:g} "
              f"{entry['seconds']:.1f}s", flush=True)
        content = {**_header(), "points": points}
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(content, indent=1, allow_nan=True) + "\n")
    content = {**_header(), "points": points}
    path.write_text(json.dumps(content, indent=1, allow_nan=True) + "\n")
    return content


def _main(argv: list[str]) -> int:
    only = argv[argv.index("--only") + 1:] if "--only" in argv else None
    begin = time.perf_counter()
    content = write_points(only=only)
    bad = [p["name"] for p in content["points"] if not p.get("settled")]
    print(f"wrote {DATA_PATH}: {len(content['points'])} points in "
          f"{time.perf_counter() - begin:.0f} s; unsettled: {bad}")
    return 0 if math.isfinite(begin) else 1


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))

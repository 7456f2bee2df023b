"""The canonical form of a study spec: what its numbers depend on, with the defaults
written out, which the spec's fingerprint hashes (:func:`canonical_form`). A setting
added later is named in it only where not its default, so that the fingerprints of specs
written before it stay."""

from __future__ import annotations

from typing import Any

from study.model.contact import DEFAULT_FRICTION, Friction
from study.model.structure import Structure
from study.solvers.integrator import IntegratorSettings
from study.solvers.settings import SolverSettings
from study.studies.spec_types import Axis, MassModel

__all__ = ["canonical_form"]


def canonical_form(study: dict[str, Any], observables: tuple[str, ...],
                   fixed: dict[str, float], mass: MassModel | None, sweep: dict[str, Any],
                   axes: list[Axis], method: str, coupling: str, friction: Friction,
                   solver: SolverSettings, integrator: IntegratorSettings,
                   frontier_tolerance: float, flight: bool = False) -> dict[str, Any]:
    """What the numbers depend on, in a canonical form (hashed); defaults written out,
    so a spec that spells them out is the same study.

    Thirteen arguments: the parts of a spec, each computed and checked by its own step
    of :func:`study.studies.spec.parse_spec`; gathering them into an object would
    only rename them.
    """
    structure_canonical = dict(fixed)
    if "g" not in fixed and "g" not in sweep:
        structure_canonical["g"] = Structure.__dataclass_fields__["g"].default
    if "ck" not in fixed and "ck" not in sweep and "cs" in fixed:
        structure_canonical["ck"] = fixed["cs"]
    canonical = {
        "name": study["name"],
        "observables": list(observables),
        "structure": {k: structure_canonical[k] for k in sorted(structure_canonical)},
        "mass": None if mass is None else {"m0": mass.m0, "m1": mass.m1},
        # A list, not a mapping: the order of the axes is the layout of the result.
        "sweep": [[axis.name, axis.values.tolist()] for axis in axes],
        "solver": {
            "method": method,
            "coupling": coupling,
            **(
                {
                    "max_events": solver.max_events,
                    "max_map_iterations": solver.max_map_iterations,
                }
                if method == "exact"
                else {
                    "tolerance": integrator.tolerance,
                    "steps_per_period": integrator.steps_per_period,
                    "max_periods": integrator.max_periods,
                    "max_orbit_period": integrator.max_orbit_period,
                    "period_tolerance": integrator.resolved_period_tolerance,
                }
            ),
            **({"frontier_tolerance": frontier_tolerance} if "frontier" in observables else {}),
            # Coulomb friction, the default, is left out: specs written before friction
            # laws were named keep their fingerprints.
            **({"friction": friction.canonical()}
               if friction.law != DEFAULT_FRICTION else {}),
            # Likewise flight only when on: specs without it keep their fingerprints.
            **({"flight": True} if flight else {}),
            # And continuation.
            **({"continuation": True} if method == "exact" and solver.continuation
               else {}),
            # And the averaging of irregular motions, where not the default.
            **(solver.averaging_changes() if method == "exact" else {}),
            # And the start, where not the release.
            **(solver.start_changes() if method == "exact" else {}),
        },
    }
    return canonical

"""Split a study into independent chunks and compute one chunk.

A chunk is one structure (one point of the structure axes) and a contiguous block
of drive frequencies, with every drive acceleration. :func:`compute_chunk` is a
pure function of ``(spec, chunk)``: it runs on any dask worker, and its result
is what the store keeps for resuming.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from study.physics import lift_off_acceleration, mode_response, thresholds
from study.solver import SteadyState, steady_state
from study.spec import StudySpec
from study.structure import Structure
from study.transient import integrated_steady_state

__all__ = ["Chunk", "compute_chunk", "plan_chunks", "solve", "variables_for"]


@dataclass(frozen=True)
class Chunk:
    """A block of the study grid.

    Attributes
    ----------
    number : int
        Position in the plan (also the chunk's file name in the store).
    structure_index : tuple of int
        Index along the structure axes.
    f_start, f_stop : int
        Slice of the frequency axis.
    """

    number: int
    structure_index: tuple[int, ...]
    f_start: int
    f_stop: int


def plan_chunks(spec: StudySpec) -> list[Chunk]:
    """Cut the study grid into chunks of about ``spec.chunk_points`` points.

    The plan depends only on the spec, so an interrupted run and its resumption
    agree on what every chunk number means.
    """
    n_f = len(spec.axis("f"))
    a_axis = spec.axis("a")
    per_f = len(a_axis) if (a_axis is not None and spec.needs_solver) else 1
    f_per_chunk = max(1, min(n_f, spec.chunk_points // per_f))
    n_blocks = math.ceil(n_f / f_per_chunk)
    chunks = []
    ranges = [range(len(axis)) for axis in spec.structure_axes]
    for structure_index in itertools.product(*ranges):
        for block in range(n_blocks):
            start = block * f_per_chunk
            chunks.append(
                Chunk(len(chunks), structure_index, start, min(n_f, start + f_per_chunk))
            )
    return chunks


def variables_for(spec: StudySpec) -> dict[str, tuple[bool, np.dtype]]:
    """Data variables computed chunk by chunk: name -> (depends on a, dtype).

    The frontier is not among them: it needs whole frequency rows and is found
    after the chunks are assembled (see :func:`study.analysis.frontier_from_grid`).
    """
    variables: dict[str, tuple[bool, np.dtype]] = {}
    if "resonance" in spec.observables:
        variables["mode_gain"] = (False, np.dtype(np.float64))
        variables["mode_phase"] = (False, np.dtype(np.float64))
    if "thresholds" in spec.observables:
        variables["a_star_plus"] = (False, np.dtype(np.float64))
        variables["a_star_minus"] = (False, np.dtype(np.float64))
    if "lift_off" in spec.observables:
        variables["lift_off_acceleration"] = (False, np.dtype(np.float64))
    if spec.needs_solver:
        variables["velocity"] = (True, np.dtype(np.float64))
        variables["status"] = (True, np.dtype(np.int8))
    if "diagnostics" in spec.observables:
        variables["slips_per_period"] = (True, np.dtype(np.float64))
        variables["forward_slip_fraction"] = (True, np.dtype(np.float64))
        variables["backward_slip_fraction"] = (True, np.dtype(np.float64))
        variables["orbit_period"] = (True, np.dtype(np.int32))
        variables["nonconvergence"] = (True, np.dtype(np.int8))
    if "paper_model" in spec.observables:
        variables["velocity_one_way"] = (True, np.dtype(np.float64))
        variables["status_one_way"] = (True, np.dtype(np.int8))
    return variables


def solve(
    spec: StudySpec, structure: Structure, f: np.ndarray, a: np.ndarray, parallel: bool = False
) -> SteadyState:
    """Steady state at ``(f, a)`` (broadcast) by the spec's method and coupling."""
    if spec.method == "integrator":
        return integrated_steady_state(
            structure, f, a, coupling=spec.coupling, settings=spec.integrator, parallel=parallel
        )
    return steady_state(structure, f, a, spec.solver, parallel=parallel)


def compute_chunk(spec: StudySpec, chunk: Chunk) -> dict[str, np.ndarray]:
    """Compute the requested observables on one chunk.

    Only what was asked for is computed: a thresholds-only study runs no solver.
    The solver runs on one thread here; parallelism comes from running chunks
    side by side.

    Returns
    -------
    dict
        Variable name -> array of shape ``(n_f,)`` or ``(n_f, n_a)`` for the chunk.
    """
    structure = spec.structure_at(chunk.structure_index)
    f = spec.axis("f").values[chunk.f_start : chunk.f_stop]
    out: dict[str, np.ndarray] = {}
    if "resonance" in spec.observables:
        response = structure.omega0**2 * mode_response(structure, f)
        out["mode_gain"] = np.abs(response)
        out["mode_phase"] = -np.angle(response)
    if "thresholds" in spec.observables:
        out["a_star_plus"], out["a_star_minus"] = thresholds(structure, f)
    if "lift_off" in spec.observables:
        out["lift_off_acceleration"] = lift_off_acceleration(structure, f)
    if spec.needs_solver:
        a = spec.axis("a").values
        result = solve(spec, structure, f[:, None], a[None, :])
        out["velocity"] = result.velocity
        out["status"] = result.status
        if "diagnostics" in spec.observables:
            out["slips_per_period"] = result.slips_per_period
            out["forward_slip_fraction"] = result.forward_fraction
            out["backward_slip_fraction"] = result.backward_fraction
            out["orbit_period"] = result.orbit_period
            out["nonconvergence"] = result.reason
    if "paper_model" in spec.observables:
        paper = steady_state(structure, f[:, None], a[None, :], spec.solver, parallel=False)
        out["velocity_one_way"] = paper.velocity
        out["status_one_way"] = paper.status
    return out

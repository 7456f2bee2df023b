"""The size guard of a study (points, output bytes, chunks) and the default chunk size,
checked before anything is computed."""

from __future__ import annotations

import math

import numpy as np

from study.engine.spec_files import (
    SpecError,
)
from study.studies.observables import (
    UNSWEPT_VARIABLES,
    variables_of,
)
from study.studies.spec_types import DRIVE_PARAMETERS, SOLVER_OBSERVABLES
from study.studies.variables import DEFAULT_MAX_ATTRACTORS

__all__ = [
    "CHUNK_POINTS_MAX",
    "CHUNK_POINTS_MIN",
    "MAX_CHUNKS",
    "MAX_CHUNK_BYTES",
    "MAX_OUTPUT_BYTES",
    "MAX_POINTS",
    "check_size",
    "default_chunk_points",
]


#: Grid points per chunk without ``[solver] chunk_points``: at least ...
CHUNK_POINTS_MIN = 20_000
#: ... and at most.
CHUNK_POINTS_MAX = 100_000


def default_chunk_points(points: int) -> int:
    """Points per chunk for a study of ``points`` grid points in all.

    A sixteenth of the study, within [:data:`CHUNK_POINTS_MIN`,
    :data:`CHUNK_POINTS_MAX`]: a small study keeps enough chunks to share among
    threads, and a large one pays the fixed cost of a chunk (a task, a cache block
    file, an HDF5 chunk: 2-3 ms) on fewer chunks (a 1e7-point velocity study: 8.1
    instead of 9.2 s of CPU with 100 000 instead of 20 000 points per chunk).
    """
    return int(min(CHUNK_POINTS_MAX, max(CHUNK_POINTS_MIN, points // 16)))


# ---------------------------------------------------------------------------
# Size guard: refuse a study whose output or memory would be absurd, before any work

#: Grid points of a study at most: 20 times the 1e8-point benchmark study (at about
#: 1e6 points per second and core, 2e9 points already take hours on a workstation).
MAX_POINTS = 2_000_000_000
#: Result file size at most [bytes] (uncompressed values).
MAX_OUTPUT_BYTES = 64 * 2**30
#: Values one chunk (one parallel task) holds at most [bytes]: every worker thread
#: holds one or two chunks, so a 16-thread run stays within a few GiB.
MAX_CHUNK_BYTES = 256 * 2**20
#: Chunks (parallel tasks) of a study at most: the plan, the progress and the kept
#: chunks scale with it.
MAX_CHUNKS = 1_000_000

def _size(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} EiB"  # pragma: no cover


def check_size(lengths: dict[str, int], observables: tuple[str, ...], chunk_points: int,
               path: str, flight: bool = False,
               protocol: tuple[object, object] | None = None,
               max_attractors: int = DEFAULT_MAX_ATTRACTORS) -> None:
    """Refuse a study whose output or memory would be absurd, before any work.

    Parameters
    ----------
    lengths : dict
        Swept parameter -> number of values, in dataset dimension order (``f`` and
        ``a`` last).
    observables : tuple of str
        Requested observables.
    chunk_points : int
        ``[solver] chunk_points``.
    path : str
        The spec file, for messages.
    flight : bool
        ``[solver] flight``: the velocity observable writes its flight variables too.
    protocol : tuple, optional
        ``(along, direction)`` of ``[sweep] protocol`` as given (checked later): a slow
        sweep writes ``jumped`` too; ``direction = "both"`` computes and writes every
        per-point variable twice (but the unswept ones) in twice the chunks; along
        ``f`` one chunk holds every ``f`` and ``a`` of a structure.
    max_attractors : int
        ``[basins] max_attractors``: the attractor slots of each point of the basins
        observable's per-attractor variables.

    Raises
    ------
    SpecError
        Naming the sweep keys (or ``chunk_points``), the size and the limit, when the
        study has more than :data:`MAX_POINTS` points, more than :data:`MAX_OUTPUT_BYTES`
        of output, a chunk larger than :data:`MAX_CHUNK_BYTES` or more than
        :data:`MAX_CHUNKS` chunks.
    """
    needs_solver = any(o in observables for o in SOLVER_OBSERVABLES)
    structures = math.prod(n for name, n in lengths.items() if name not in DRIVE_PARAMETERS)
    n_f = lengths.get("f", 1)
    n_a = lengths.get("a", 1) if needs_solver else 1
    # What each variable holds per point, from its declaration (a phase section's
    # periods too).
    variables = variables_of(observables, flight, protocol is not None)
    per_f_bytes = sum(np.dtype(v.dtype).itemsize for v in variables if v.grid == "row")
    sizes = {"attractor": max_attractors}
    point_bytes = {v.name: np.dtype(v.dtype).itemsize * math.prod(v.trailing(sizes))
                   for v in variables if v.grid in ("point", "section", "attractor")}
    per_point_bytes = sum(point_bytes.values())
    # A slow sweep both ways: every point computed and written once each way, but the
    # values of each point from its start alone (no direction dimension).
    directions = 2 if protocol is not None and protocol[1] == "both" else 1
    written_point_bytes = per_point_bytes + (directions - 1) * sum(
        size for name, size in point_bytes.items() if name not in UNSWEPT_VARIABLES)
    swept = [name for name in lengths if needs_solver or name != "a"]
    keys = " x ".join(swept)
    sizes = " x ".join(str(lengths[name]) for name in swept)
    points = structures * n_f * n_a * directions
    output = structures * n_f * (per_f_bytes + n_a * written_point_bytes)
    if points > MAX_POINTS or output > MAX_OUTPUT_BYTES:
        both = (' x 2 directions ([sweep] protocol direction = "both")'
                if directions == 2 else "")
        raise SpecError(
            f"{path}: [sweep] {keys} = {sizes}{both} = {points:.3g} points "
            f"({_size(output)} of output); allowed at most {MAX_POINTS:.3g} points and "
            f"{_size(MAX_OUTPUT_BYTES)}: sweep fewer values"
        )
    # How study.studies.sweep cuts the grid: whole frequency rows (every a), about
    # chunk_points points per chunk; a slow sweep along f holds every f in one chunk
    # (its runs whole).
    along_f = needs_solver and protocol is not None and protocol[0] == "f"
    if along_f:
        chunk_bytes = n_f * (per_f_bytes + n_a * per_point_bytes)
        if chunk_bytes > MAX_CHUNK_BYTES:
            raise SpecError(
                f'{path}: [sweep] protocol along = "f": one task holds every f and a of a '
                f"structure ({n_f} x {n_a} points), {_size(chunk_bytes)}, more than one "
                f"task may hold ({_size(MAX_CHUNK_BYTES)}); allowed: at most "
                f"{MAX_CHUNK_BYTES // max(per_point_bytes, 1)} points (f x a), or "
                'along = "a"'
            )
    f_per_chunk = n_f if along_f else max(1, min(n_f, chunk_points // n_a))
    chunk_bytes = f_per_chunk * (per_f_bytes + n_a * per_point_bytes)
    if chunk_bytes > MAX_CHUNK_BYTES:
        if f_per_chunk == 1:
            raise SpecError(
                f"{path}: [sweep] a: one frequency row of {n_a} accelerations holds "
                f"{_size(chunk_bytes)}, more than one task may hold "
                f"({_size(MAX_CHUNK_BYTES)}); allowed: at most "
                f"{MAX_CHUNK_BYTES // max(per_point_bytes, 1)} values of a"
            )
        per_chunk_point = chunk_bytes / (f_per_chunk * n_a)
        raise SpecError(
            f"{path}: [solver] chunk_points = {chunk_points} makes tasks of "
            f"{_size(chunk_bytes)}; allowed: at most {int(MAX_CHUNK_BYTES // per_chunk_point)} "
            "points per chunk"
        )
    chunks = structures * math.ceil(n_f / f_per_chunk) * directions
    if chunks > MAX_CHUNKS:
        smallest = math.ceil(points / MAX_CHUNKS)
        raise SpecError(
            f"{path}: [solver] chunk_points = {chunk_points} cuts [sweep] {keys} into "
            f"{chunks:.3g} chunks; allowed at most {MAX_CHUNKS:.3g}: raise chunk_points to "
            f"at least {smallest} or sweep fewer structures"
        )

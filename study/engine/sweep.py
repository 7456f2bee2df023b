"""Cut a study into independent chunks and compute what a chunk is missing.

A chunk is one structure (one point of the structure axes) and a contiguous block
of drive frequencies, with every drive acceleration. A :class:`Task` is the work
one chunk still needs after the kept values were looked up: its closed-form rows
and the rectangles of drive points whose solver observables are missing. A task
carries only its own slice of the grid (never the whole spec), so sending it to a
worker costs the size of the chunk, not of the study; :func:`compute_task` is a
pure function of it and runs on any worker.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.engine.observables import OBSERVABLES, Method, PointWork
from study.model.structure import Structure

__all__ = ["Chunk", "Rectangle", "Task", "compute_task", "missing_rectangles", "plan_chunks"]


@dataclass(frozen=True)
class Chunk:
    """A block of the study grid.

    Attributes
    ----------
    number : int
        Position in the plan.
    structure_index : tuple of int
        Index along the structure axes.
    f_start, f_stop : int
        Slice of the frequency axis.
    direction : int
        Index of the slow sweep's direction (``[sweep] protocol`` with direction
        ``"both"``: 0 up, 1 down); 0 otherwise.
    """

    number: int
    structure_index: tuple[int, ...]
    f_start: int
    f_stop: int
    direction: int = 0

    @property
    def size(self) -> int:
        """Number of frequencies in the chunk."""
        return self.f_stop - self.f_start


def plan_chunks(structure_shape: tuple[int, ...], n_f: int, n_a: int,
                chunk_points: int) -> list[Chunk]:
    """Cut a grid into chunks of about ``chunk_points`` points.

    Parameters
    ----------
    structure_shape : tuple of int
        Lengths of the structure axes.
    n_f, n_a : int
        Lengths of the frequency and acceleration axes (``n_a = 1`` without ``a``).
    chunk_points : int
        Target points per chunk.
    """
    f_per_chunk = max(1, min(n_f, chunk_points // max(n_a, 1)))
    n_blocks = math.ceil(n_f / f_per_chunk)
    chunks = []
    for structure_index in itertools.product(*(range(n) for n in structure_shape)):
        for block in range(n_blocks):
            start = block * f_per_chunk
            chunks.append(Chunk(len(chunks), structure_index, start,
                                min(n_f, start + f_per_chunk)))
    return chunks


@dataclass(frozen=True)
class Rectangle:
    """Drive points ``f[rows] x a[columns]`` of a chunk to compute (indices)."""

    rows: NDArray[np.intp]
    columns: NDArray[np.intp]

    @property
    def points(self) -> int:
        """Number of drive points."""
        return self.rows.size * self.columns.size


def missing_rectangles(missing: NDArray[np.bool_]) -> tuple[Rectangle, ...]:
    """Cover the ``True`` points of a ``(n_f, n_a)`` mask by rectangles, exactly.

    Rows with the same missing columns form one rectangle: a fresh chunk is one
    rectangle, an axis refined or extended is one or two.
    """
    groups: dict[bytes, list[int]] = {}
    for row in np.flatnonzero(missing.any(axis=1)):
        groups.setdefault(missing[row].tobytes(), []).append(int(row))
    return tuple(
        Rectangle(np.asarray(rows, dtype=np.intp), np.flatnonzero(missing[rows[0]]))
        for rows in groups.values()
    )


@dataclass(frozen=True)
class Task:
    """What one chunk still needs computing.

    Attributes
    ----------
    chunk : Chunk
    structure : Structure
    f : numpy.ndarray
        The chunk's drive frequencies [Hz].
    a : numpy.ndarray
        Drive accelerations [m s-2] (empty without an ``a`` axis).
    rows : tuple of str
        Closed-form (row) observables to compute on ``f``.
    points : tuple of str
        Solver observables to compute on each rectangle.
    rectangles : tuple of Rectangle
        Where the solver observables are missing.
    method : Method
    """

    chunk: Chunk
    structure: Structure
    f: NDArray[np.float64]
    a: NDArray[np.float64]
    rows: tuple[str, ...]
    points: tuple[str, ...]
    rectangles: tuple[Rectangle, ...]
    method: Method

    @property
    def point_count(self) -> int:
        """Drive points the solver computes in this task."""
        return sum(r.points for r in self.rectangles)


def compute_task(task: Task) -> tuple[dict[str, NDArray[Any]], list[dict[str, NDArray[Any]]]]:
    """Compute a task on one thread (parallelism comes from tasks side by side).

    Returns
    -------
    rows : dict
        Variable name -> ``(n_f,)`` array for the closed-form observables.
    rectangles : list of dict
        For each rectangle of the task, variable name -> ``(rows, columns)`` array
        of the solver observables.
    """
    rows: dict[str, NDArray[Any]] = {}
    for name in task.rows:
        rows.update(OBSERVABLES[name].compute(task.structure, task.f))
    blocks = []
    for rectangle in task.rectangles:
        work = PointWork(task.structure, task.f[rectangle.rows][:, None],
                         task.a[rectangle.columns][None, :], task.method)
        values: dict[str, NDArray[Any]] = {}
        for name in task.points:
            values.update(OBSERVABLES[name].compute(work))
        blocks.append(values)
    return rows, blocks

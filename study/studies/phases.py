"""The phases of a study after its map, each declared once by its observable.

Some observables are not computed point by point: the frontier is refined from whole
velocity rows, the fold curves are continued over the drive plane. Each such observable
declares a :class:`PostMapPhase`: what one structure's values are computed from and how
much work that is (for the progress), what they depend on (their cache key), how they
are cut into cache blocks (:class:`Block`), how they are computed, and how they are laid
out in the result (dimensions, padding). The runner (:mod:`study.studies.kind`) runs the
study's phases in :data:`study.studies.observables.OBSERVABLES` order after the map, one
mechanism for all: each structure's values are looked up in the cache of kept values,
computed where missing and kept at once, with the phase's own progress; a stop request
(Ctrl-C) ends the phase after the step running, the structures done kept; then the
phase's variables are written beside the map. :func:`study.compute_map` computes the
same values in memory (:func:`computed_phase`).

Adding a phase: an observable (:mod:`study.studies.observables`), its variables
(:mod:`study.studies.variables`), a :class:`PostMapPhase` here and its entry in
:data:`PHASES`.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.engine.cache_format import entry_key
from study.model.structure import Structure
from study.solvers.fold_curves import HOPS, SIDES, fold_curve_work
from study.solvers.frontier import frontier_branches, frontier_work
from study.solvers.sweep_branches import (
    BRANCH_BIFURCATION_SLOTS,
    BRANCH_STEP_SLOTS,
    NO_STEP,
    swept_pieces,
)
from study.studies.layout import pad_branches
from study.studies.observables import CurveWork, Method, Observable, resolve
from study.studies.spec import StudySpec
from study.studies.variables import GRIDS, VARIABLES

__all__ = [
    "PHASES",
    "Block",
    "BranchesPhase",
    "FoldCurvesPhase",
    "FrontierPhase",
    "PhaseInput",
    "PostMapPhase",
    "computed_phase",
    "filed_arrays",
    "phase_blocks",
    "post_map_phases",
    "sha256_of",
    "structure_content",
]


def structure_content(structure: Structure) -> dict[str, float]:
    """A structure's parameters as plain JSON data (in the cache keys of its values)."""
    return {name: float(getattr(structure, name)) for name in Structure.__dataclass_fields__}


def sha256_of(values: NDArray[Any]) -> str:
    """Hex digest of an array's bytes (C order)."""
    return hashlib.sha256(np.ascontiguousarray(values).tobytes()).hexdigest()


@dataclass(frozen=True)
class PhaseInput:
    """What a post-map phase computes one structure's values from.

    Attributes
    ----------
    index : tuple of int
        The structure's index on the study's structure axes.
    structure : Structure
    f, a : numpy.ndarray
        The study's whole drive axes [Hz], [m s-2] (1-D).
    method : Method
        The study's method (with its protocol, if any).
    spec : StudySpec
    map : dict
        The map's values of this structure that the phase reads
        (:attr:`PostMapPhase.reads`), each over the structure's drive grid (with a
        leading ``direction`` in a slow sweep both ways).
    """

    index: tuple[int, ...]
    structure: Structure
    f: NDArray[np.float64]
    a: NDArray[np.float64]
    method: Method
    spec: StudySpec
    map: dict[str, NDArray[Any]] = field(repr=False)


@dataclass(frozen=True)
class Block:
    """Part of one structure's values of a phase, kept in the cache as one block.

    Attributes
    ----------
    part : str or None
        Its name in the cache key (None: the phase's values are one block, and the key
        has no part).
    variables : tuple of str
        The variables the block holds.
    slots, columns : numpy.ndarray
        The block's rows and columns (floats, as the cache's drive points): its values
        are ``(slots, columns)`` arrays.
    transposed : bool
        The phase's values are ``(columns, slots)`` (a frontier's ``(a, branch)``) and
        are kept transposed.
    single : bool
        The phase's values are ``(slots,)``, kept as the one column of the block (whose
        ``columns`` are one value).
    """

    part: str | None
    variables: tuple[str, ...]
    slots: NDArray[np.float64]
    columns: NDArray[np.float64]
    transposed: bool = False
    single: bool = False

    def kept(self, values: NDArray[Any]) -> NDArray[Any]:
        """A variable's values as the block keeps them, ``(slots, columns)``."""
        if self.single:
            values = values[:, None]
        return np.ascontiguousarray(values.T if self.transposed else values)

    def restored(self, block: NDArray[Any]) -> NDArray[Any]:
        """A variable's values from the block's ``(slots, columns)``."""
        if self.single:
            block = block[:, 0]
        return np.ascontiguousarray(block.T if self.transposed else block)

    @property
    def keepable(self) -> bool:
        """Whether the block has columns to keep (a study without accelerations has
        none)."""
        return self.columns.size > 0


class PostMapPhase:
    """A phase of a study after its map: one observable's values, per structure.

    Subclasses set :attr:`name` (the observable's), :attr:`label`, :attr:`unit`,
    :attr:`reuse` and :attr:`reads`, and define :meth:`work`, :meth:`key`,
    :meth:`blocks`, :meth:`compute`; :meth:`sizes` and :meth:`filed` where the values
    of the structures are padded to common sizes in the file.

    Attributes
    ----------
    observable : Observable
        The study's observable (with its flight and protocol variables): what is
        computed and written.
    """

    #: The observable's name in :data:`study.studies.observables.OBSERVABLES`.
    name: str = ""
    #: What the progress and its messages call the phase ("frontier").
    label: str = ""
    #: What :meth:`work` counts ("solve").
    unit: str = "step"
    #: What a reused structure's values had the same, said when they are reused.
    reuse: str = ""
    #: The map's variables it reads per structure (:attr:`PhaseInput.map`).
    reads: tuple[str, ...] = ()

    def __init__(self, observable: Observable) -> None:
        self.observable = observable

    @property
    def variables(self) -> tuple[str, ...]:
        """The variables the phase computes and writes."""
        return self.observable.variables

    def work(self, item: PhaseInput) -> int:
        """The steps :meth:`compute` reports to its progress for this structure."""
        raise NotImplementedError

    def key(self, item: PhaseInput, block: Block) -> dict[str, Any]:
        """What a block of this structure's values depends on beyond the observable,
        the block's variables, the structure and the code (its cache key's other
        content)."""
        raise NotImplementedError

    def blocks(self, item: PhaseInput) -> tuple[Block, ...]:
        """How this structure's values are kept: their blocks, every variable in one."""
        raise NotImplementedError

    def compute(self, item: PhaseInput, progress: Callable[[int], None] | None = None
                ) -> dict[str, NDArray[Any]]:
        """This structure's values, name -> array."""
        raise NotImplementedError

    def sizes(self, found: dict[tuple[int, ...], dict[str, NDArray[Any]]]
              ) -> dict[str, int]:
        """The dimensions the phase adds to the result, sized for the values of every
        structure (the phase's own: not a coordinate's). Default: none."""
        return {}

    def filed(self, values: dict[str, NDArray[Any]], sizes: dict[str, int]
              ) -> dict[str, NDArray[Any]]:
        """One structure's values as written, at :meth:`sizes`. Default: as computed."""
        return {name: values[name] for name in self.variables}


def phase_blocks(phase: PostMapPhase, item: PhaseInput, code: str
                 ) -> list[tuple[Block, str, dict[str, Any]]]:
    """Each block of a structure's values of ``phase``, with its cache key and content
    (the code's hash ``code`` in it)."""
    blocks = phase.blocks(item)
    held = [v for block in blocks for v in block.variables]
    if sorted(held) != sorted(phase.variables):
        # A declaration error, not a user's: a variable added to the observable on a
        # grid the phase's blocks do not cover (or one kept twice).
        missing = sorted(set(phase.variables) - set(held))
        raise RuntimeError(
            f"the {phase.label} phase's cache blocks hold {', '.join(sorted(held))}, not "
            f"its observable's variables (missing: {', '.join(missing) or 'none'}): "
            f"extend {type(phase).__name__}.blocks in study/studies/phases.py")
    found = []
    for block in blocks:
        content: dict[str, Any] = {"observable": phase.name}
        if block.part is not None:
            content["part"] = block.part
        content.update({
            "variables": {v: VARIABLES[v].dtype for v in block.variables},
            "structure": structure_content(item.structure),
            "code_sha256": code,
            **phase.key(item, block),
        })
        found.append((block, entry_key(content), content))
    return found


def filed_arrays(phase: PostMapPhase, found: dict[tuple[int, ...], dict[str, NDArray[Any]]]
                 ) -> tuple[dict[str, int], dict[tuple[int, ...], dict[str, NDArray[Any]]]]:
    """The phase's dimensions (:meth:`PostMapPhase.sizes`) and each structure's values
    as written."""
    sizes = phase.sizes(found)
    return sizes, {index: phase.filed(values, sizes) for index, values in found.items()}


def computed_phase(phase: PostMapPhase, items: dict[tuple[int, ...], PhaseInput],
                   shape: tuple[int, ...]
                   ) -> tuple[dict[str, int], dict[str, NDArray[Any]]]:
    """Every structure's values of ``phase`` computed in memory (no cache, no
    progress), as the runner writes them: the phase's dimensions and name -> array over
    the structure axes ``shape`` and the variable's own dimensions."""
    found = {index: phase.compute(item) for index, item in items.items()}
    sizes, filed = filed_arrays(phase, found)
    arrays = {}
    for name in phase.variables:
        first = next(iter(filed.values()))[name]
        array = np.empty((*shape, *first.shape), dtype=VARIABLES[name].dtype)
        for index, values in filed.items():
            array[index] = values[name]
        arrays[name] = array
    return sizes, arrays


# -- the phases -----------------------------------------------------------------------


class FrontierPhase(PostMapPhase):
    """The frontier f*(a), refined by bisection from each structure's whole velocity
    rows (:func:`study.solvers.frontier.frontier_from_grid`), its branches padded to
    the most of any structure (the ``branch`` dimension).

    Its values follow from the velocity map (the brackets), the solver that refines
    them and the tolerance: kept like points, a structure's frontier is found again by
    a rerun onto any output or with force."""

    name = "frontier"
    label = "frontier"
    unit = "solve"
    reuse = "same map, solver and tolerance"
    reads = ("velocity", "status")

    def work(self, item: PhaseInput) -> int:
        return frontier_work(item.f, item.map["velocity"], item.map["status"],
                             item.spec.frontier_tolerance)

    def blocks(self, item: PhaseInput) -> tuple[Block, ...]:
        # The branches as the rows of a block over the accelerations.
        branches = frontier_branches(item.map["velocity"], item.map["status"])
        return (Block(None, self.variables, np.arange(branches, dtype=np.float64), item.a,
                      transposed=True),)

    def key(self, item: PhaseInput, block: Block) -> dict[str, Any]:
        velocity = np.ascontiguousarray(item.map["velocity"], dtype=np.float64)
        status = np.ascontiguousarray(item.map["status"])
        return {
            "method": item.method.canonical(),
            "tolerance": float(item.spec.frontier_tolerance),
            "f_sha256": sha256_of(item.f),
            "map_sha256": hashlib.sha256(velocity.tobytes() + status.tobytes()
                                         + str(status.dtype).encode()).hexdigest(),
        }

    def compute(self, item: PhaseInput, progress: Callable[[int], None] | None = None
                ) -> dict[str, NDArray[Any]]:
        return self.observable.compute(item.structure, item.f, item.a, item.map["velocity"],
                                       item.map["status"], item.method,
                                       item.spec.frontier_tolerance, progress=progress)

    def sizes(self, found: dict[tuple[int, ...], dict[str, NDArray[Any]]]
              ) -> dict[str, int]:
        return {"branch": max(1, *(values["frontier_frequency"].shape[1]
                                   for values in found.values()))}

    def filed(self, values: dict[str, NDArray[Any]], sizes: dict[str, int]
              ) -> dict[str, NDArray[Any]]:
        return {name: pad_branches(values[name], sizes["branch"], VARIABLES[name].dtype)
                for name in self.variables}


class FoldCurvesPhase(PostMapPhase):
    """The fold curves of the forward and backward hops
    (:func:`study.solvers.fold_curves.fold_curves`: slow sweeps along the study's f,
    each hop's fold continued over its a, and the forward hop's period doubling), over
    ``(hop, a)``, ``(hop, curve_end)`` and ``(a,)``.

    They follow from the structure, the solver (not the protocol: they sweep on their
    own) and the f and a axes, not from the map: a rerun onto another output reuses
    them, another f or a axis computes them again."""

    name = "fold_curves"
    label = "fold curves"
    unit = "step"
    reuse = "same structure, solver and axes"

    def work(self, item: PhaseInput) -> int:
        return fold_curve_work(item.a)

    def blocks(self, item: PhaseInput) -> tuple[Block, ...]:
        # The hops the rows of each block: one block per grid of the variables; the
        # doubling's, over a alone, kept as one column of the accelerations.
        def held(part: str) -> tuple[str, ...]:
            return tuple(v for v in self.variables if VARIABLES[v].grid == part)

        slots = np.arange(len(HOPS), dtype=np.float64)
        columns = {"curve": item.a, "curve_end": np.arange(len(SIDES), dtype=np.float64)}
        blocks = [Block(part, held(part), slots, along) for part, along in columns.items()]
        if held("doubling"):
            blocks.append(Block("doubling", held("doubling"), item.a, np.zeros(1),
                                single=True))
        return tuple(blocks)

    def key(self, item: PhaseInput, block: Block) -> dict[str, Any]:
        return {"method": replace(item.method, protocol=None).canonical(),
                "f_sha256": sha256_of(item.f), "a_sha256": sha256_of(item.a)}

    def compute(self, item: PhaseInput, progress: Callable[[int], None] | None = None
                ) -> dict[str, NDArray[Any]]:
        return self.observable.compute(CurveWork(item.structure, item.f, item.a,
                                                 item.method), progress=progress)


#: What a slot a branch (or a structure) does not fill holds, where not NaN or 0.
_BRANCH_PADDING = {"branch_sweep": -1, "branch_stable": NO_STEP,
                   "branch_bifurcation_step": -1}
#: The cache block of each grid of the branches: its columns (None: one value a branch).
_BRANCH_COLUMNS = {"branch": None, "branch_step": BRANCH_STEP_SLOTS,
                   "branch_bifurcation": BRANCH_BIFURCATION_SLOTS}


class BranchesPhase(PostMapPhase):
    """The branches the study's slow sweeps ride
    (:func:`study.solvers.sweep_branches.swept_branches`), one per piece of each run on
    one motion, over ``(branch,)``, ``(branch, step)`` and ``(branch, bifurcation)``,
    each padded to the most of any structure.

    The pieces are read off the map (where the sweeps jumped, where the status or the
    orbit's period changes); the values follow from the structure, the method with its
    protocol and the f and a axes (the map is theirs), so a rerun onto another output
    reuses them. Kept in slots of the most steps and bifurcations a branch can have."""

    name = "branches"
    label = "branches"
    unit = "branch"
    reuse = "same structure, solver, protocol and axes"
    reads = ("jumped", "status", "orbit_period")

    def pieces(self, item: PhaseInput) -> int:
        """The branches of the structure: the pieces of its sweeps' runs."""
        along, direction = item.method.protocol  # type: ignore[misc]
        ways = ("up", "down") if direction == "both" else (direction,)
        count = 0
        for k, way in enumerate(ways):
            lead = (k,) if len(ways) > 1 else ()
            count += len(swept_pieces(item.f, item.a, along, way,
                                      item.map["jumped"][lead].astype(bool),
                                      item.map["status"][lead],
                                      item.map["orbit_period"][lead]))
        return count

    def work(self, item: PhaseInput) -> int:
        return self.pieces(item)

    def blocks(self, item: PhaseInput) -> tuple[Block, ...]:
        slots = np.arange(self.pieces(item), dtype=np.float64)
        return tuple(
            Block(part, tuple(v for v in self.variables if VARIABLES[v].grid == part), slots,
                  np.zeros(1) if width is None else np.arange(width, dtype=np.float64),
                  single=width is None)
            for part, width in _BRANCH_COLUMNS.items())

    def key(self, item: PhaseInput, block: Block) -> dict[str, Any]:
        return {"method": item.method.canonical(), "f_sha256": sha256_of(item.f),
                "a_sha256": sha256_of(item.a)}

    def compute(self, item: PhaseInput, progress: Callable[[int], None] | None = None
                ) -> dict[str, NDArray[Any]]:
        found = self.observable.compute(CurveWork(item.structure, item.f, item.a,
                                                  item.method), progress=progress)
        if found["branch_sweep"].size != self.pieces(item):
            raise RuntimeError("branches: the sweeps solved again differ from the map's "
                               "(another number of pieces)")
        return found

    def sizes(self, found: dict[tuple[int, ...], dict[str, NDArray[Any]]]
              ) -> dict[str, int]:
        values = list(found.values())
        return {"branch": max(1, *(v["branch_sweep"].size for v in values)),
                "step": max(1, *(int(v["branch_steps"].max(initial=0)) for v in values)),
                "bifurcation": max(1, *(int(min(v["branch_bifurcations"].max(initial=0),
                                                BRANCH_BIFURCATION_SLOTS))
                                        for v in values))}

    def filed(self, values: dict[str, NDArray[Any]], sizes: dict[str, int]
              ) -> dict[str, NDArray[Any]]:
        filed = {}
        for name in self.variables:
            declared = VARIABLES[name]
            dims = GRIDS[declared.grid]
            dtype = np.dtype(declared.dtype)
            empty = _BRANCH_PADDING.get(name, np.nan if dtype.kind == "f" else 0)
            array = np.full(tuple(sizes[d] for d in dims), empty, dtype=dtype)
            given = values[name][tuple(slice(0, sizes[d]) for d in dims)]
            array[tuple(slice(0, n) for n in given.shape)] = given
            filed[name] = array
        return filed


#: The post-map phase of each observable that has one, by the observable's name.
PHASES: dict[str, type[PostMapPhase]] = {
    FrontierPhase.name: FrontierPhase,
    FoldCurvesPhase.name: FoldCurvesPhase,
    BranchesPhase.name: BranchesPhase,
}


def post_map_phases(spec: StudySpec) -> tuple[PostMapPhase, ...]:
    """The study's phases after its map, in the order of its observables
    (:data:`study.studies.observables.OBSERVABLES`)."""
    return tuple(PHASES[o.name](o)
                 for o in resolve(spec.observables, spec.flight, spec.protocol is not None)
                 if o.name in PHASES)

"""The design search: the structure parameters with the largest smallest target margin.

**Objective**: maximise the smallest target margin (:mod:`study.analyses.design_margins`)
over the free parameters within their bounds (a max-min design: the worst target is as
robust as it can be). **Search**: one free parameter, a scan of ``scan_points`` values
across the bounds, then a bounded Brent refinement between the best value's neighbours;
several, :func:`scipy.optimize.differential_evolution` (fixed seed, the start values in
the first population, no gradient polish), then a bounded Nelder-Mead refinement. Every
trial point is a valid structure inside the bounds: bounds are checked against each
parameter's range when the spec is read, ``ck <= cs`` is kept (with both free, the
search runs on ``cs >= ck_lo`` and ``u`` in [0, 1], ``ck = ck_lo + u (min(ck_hi, cs) -
ck_lo)``) and the plates' mass ratios sum to at most 1 at every point of the bounds.

When the best point leaves a target unmet the design is **infeasible**; every target is
then searched alone, and the report names the targets that no point within the bounds
meets, or, if each can be met alone, the one that fails at the best compromise.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from study.analyses.design_margins import MIN_MARGIN, Evaluation, evaluate
from study.analyses.design_spec import DesignSpec

__all__ = [
    "DesignResult",
    "design",
]

# ---------------------------------------------------------------------------
# The search: a vector of internal coordinates, always a valid structure


@dataclass
class _Space:
    """Internal coordinates: the free parameters, except that with ``cs`` and ``ck``
    both free ``ck = ck_lo + u (min(ck_hi, cs) - ck_lo)`` with ``u`` in [0, 1] (and
    ``cs >= ck_lo``): every point is inside both boxes with ``ck <= cs``."""

    spec: DesignSpec
    names: list[str] = field(init=False)
    ratio: bool = field(init=False)  # ck searched as u (class doc)
    lower: NDArray[np.float64] = field(init=False)
    upper: NDArray[np.float64] = field(init=False)
    evaluations: int = 0

    def __post_init__(self) -> None:
        spec = self.spec
        self.names = list(spec.free)
        self.ratio = "cs" in spec.free and "ck" in spec.free
        lower = np.array([spec.free[n][0] for n in self.names])
        upper = np.array([spec.free[n][1] for n in self.names])
        ck = spec.start.get("ck")
        if "cs" in spec.free and not self.ratio and ck is not None:
            j = self.names.index("cs")
            lower[j] = max(lower[j], ck)
        if "ck" in spec.free and not self.ratio:
            j = self.names.index("ck")
            upper[j] = min(upper[j], float(spec.start["cs"]))
        if self.ratio:
            j, k = self.names.index("ck"), self.names.index("cs")
            lower[k] = max(lower[k], spec.free["ck"][0])
            lower[j], upper[j] = 0.0, 1.0
        self.lower, self.upper = lower, upper

    def _ck_span(self, cs: float) -> tuple[float, float]:
        low, high = self.spec.free["ck"]
        return low, max(min(high, cs) - low, 0.0)

    def start(self) -> NDArray[np.float64]:
        p = self.spec.start
        x = np.array([float(p[n] if p[n] is not None else p["cs"]) for n in self.names])
        if self.ratio:
            low, span = self._ck_span(float(p["cs"]))
            x[self.names.index("ck")] = (float(p["ck"]) - low) / span if span > 0 else 0.0
        return np.clip(x, self.lower, self.upper)

    def params(self, x: NDArray[np.float64]) -> dict[str, float | None]:
        p = dict(self.spec.start)
        for n, value in zip(self.names, x, strict=True):
            p[n] = float(value)
        if self.ratio:
            low, span = self._ck_span(float(p["cs"]))
            p["ck"] = min(low + float(p["ck"]) * span, float(p["cs"]))
        return p

    def physical(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        p = self.params(x)
        return np.array([p[n] if p[n] is not None else p["cs"] for n in self.names],
                        dtype=float)

    def score(self, x: NDArray[np.float64], which: list[int] | None = None) -> float:
        self.evaluations += 1
        x = np.clip(np.asarray(x, dtype=float), self.lower, self.upper)
        return evaluate(self.spec, self.params(x), which).score


def _search(space: _Space, which: list[int] | None, iterations: int
            ) -> tuple[NDArray[np.float64], float, NDArray[np.float64], NDArray[np.float64]]:
    """The best internal point, its score, and the 1-D scan (empty for several)."""
    from scipy.optimize import differential_evolution, minimize, minimize_scalar

    spec = space.spec
    lo, hi = space.lower, space.upper
    if len(space.names) == 1:
        grid = np.linspace(lo[0], hi[0], spec.scan_points)
        scores = np.array([space.score(np.array([v]), which) for v in grid])
        i = int(np.argmax(scores))
        left, right = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        best_x, best = np.array([grid[i]]), float(scores[i])
        refined = minimize_scalar(lambda v: -space.score(np.array([v]), which),
                                  bounds=(left, right), method="bounded",
                                  options={"xatol": 1e-6 * (hi[0] - lo[0])})
        if -refined.fun > best:
            best_x, best = np.array([float(refined.x)]), float(-refined.fun)
        return best_x, best, grid, scores
    bounds = list(zip(lo, hi, strict=True))
    found = differential_evolution(
        lambda x: -space.score(x, which), bounds, rng=spec.seed, maxiter=iterations,
        popsize=spec.population, tol=1e-8, polish=False, x0=space.start())
    best_x, best = np.asarray(found.x, dtype=float), float(-found.fun)
    refined = minimize(lambda x: -space.score(x, which), best_x, method="Nelder-Mead",
                       bounds=bounds, options={"maxfev": 100 * len(bounds),
                                               "xatol": 1e-8, "fatol": 1e-10})
    if -refined.fun > best:
        best_x, best = np.clip(np.asarray(refined.x, dtype=float), lo, hi), float(-refined.fun)
    return best_x, best, np.empty(0), np.empty(0)


@dataclass(frozen=True)
class DesignResult:
    """The best design and its margins.

    Attributes
    ----------
    names : list of str
        Free parameters.
    best, lower, upper, start : numpy.ndarray
        Best values and the search's bounds, in each parameter's units (``lower`` and
        ``upper`` are the effective bounds: ``ck <= cs`` can narrow the spec's).
    params : dict
        Every parameter at the best point (``ck`` None: tied to ``cs``).
    evaluation : Evaluation
        Every target at the best point.
    score : float
        The smallest target margin there.
    feasible : bool
        Whether every target is met.
    alone : numpy.ndarray
        Infeasible designs: each target's best margin searched alone (NaN otherwise).
    failing : list of str
        Labels of the targets the report blames (empty when feasible).
    message : str
        The report.
    scan_values, scan_scores : numpy.ndarray
        One free parameter: the scan of the objective (empty otherwise).
    evaluations : int
    wall_seconds : float
    """

    names: list[str]
    best: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    start: NDArray[np.float64]
    params: dict[str, float | None]
    evaluation: Evaluation
    score: float
    feasible: bool
    alone: NDArray[np.float64]
    failing: list[str]
    message: str
    scan_values: NDArray[np.float64]
    scan_scores: NDArray[np.float64]
    evaluations: int
    wall_seconds: float


def design(spec: DesignSpec, progress: Callable[[str], None] | None = None) -> DesignResult:
    """Search the free parameters of ``spec`` for the largest smallest target margin
    (module doc); never raises on an infeasible design, which the result reports."""
    started = time.perf_counter()
    space = _Space(spec)
    x, score, scan_values, scan_scores = _search(space, None, spec.max_iterations)
    params = space.params(x)
    evaluation = evaluate(spec, params)
    score = evaluation.score
    feasible = bool(np.all(evaluation.met))
    alone = np.full(len(spec.targets), np.nan)
    failing: list[str] = []
    if feasible:
        k = int(np.argmin(evaluation.margin))
        message = (f"feasible: every target is met; the smallest margin is {score:.4g} "
                   f"({evaluation.limiting[k]} margin of '{spec.targets[k].label}')")
    else:
        for i, target in enumerate(spec.targets):
            if progress is not None:
                progress(f"searching target '{target.label}' alone")
            alone[i] = _search(space, [i], max(10, spec.max_iterations // 2))[1]
        hopeless = [i for i in range(alone.size) if not alone[i] > MIN_MARGIN]
        if hopeless:
            failing = [spec.targets[i].label for i in hopeless]
            parts = "; ".join(
                f"'{spec.targets[i].label}' (best margin alone "
                f"{alone[i] if abs(alone[i]) > MIN_MARGIN else 0.0:.3g}; at the best "
                f"compromise its {evaluation.limiting[i]} margin is "
                f"{evaluation.margin[i]:.3g})" for i in hopeless)
            message = ("infeasible: no point within the bounds meets every target; "
                       f"not met anywhere within the bounds: {parts}")
        else:
            k = int(np.argmin(evaluation.margin))
            failing = [spec.targets[k].label]
            message = ("infeasible: each target can be met alone but not all together; at "
                       f"the best compromise '{spec.targets[k].label}' fails (its "
                       f"{evaluation.limiting[k]} margin is {evaluation.margin[k]:.3g})")
    return DesignResult(
        names=space.names, best=space.physical(x), lower=_effective(space, "lower"),
        upper=_effective(space, "upper"), start=space.physical(space.start()),
        params=params, evaluation=evaluation, score=score, feasible=feasible, alone=alone,
        failing=failing, message=message,
        scan_values=np.array([space.physical(np.array([v]))[0] for v in scan_values]),
        scan_scores=scan_scores, evaluations=space.evaluations,
        wall_seconds=time.perf_counter() - started)


def _effective(space: _Space, which: str) -> NDArray[np.float64]:
    values = np.array(getattr(space, which), dtype=float)
    if space.ratio:  # report ck's bounds as the spec gave them, not u's
        j = space.names.index("ck")
        values[j] = space.spec.free["ck"][0 if which == "lower" else 1]
    return values

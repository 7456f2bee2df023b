"""The exact two-way solver against the time integrator on seeded points of the whole
parameter space (the quick version of ``benchmarks/two_way_agreement.py``).

Points are drawn by the benchmark's sampler; kept are the first ten the exact solver
finds moving whose orbit attracts by e within 50 drive periods (Floquet multiplier
<= exp(-1/50); the integrator's cost is waiting for that approach). Both methods must
give the same status and velocities within the integrator's accuracy at tolerance
1e-11 (<= 1e-8 a / w; observed <= 1e-9).
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from study.model.status import Status

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "two_way_agreement.py"
_SPEC = importlib.util.spec_from_file_location("two_way_agreement", _PATH)
bench = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(bench)

INTEGRATOR_TOLERANCE = 1e-8  # of a / w


def _points(count: int = 10, seed: int = 3) -> list:
    from study.solvers.exact import steady_state

    rng = np.random.default_rng(seed)
    found = []
    while len(found) < count:
        s, f, a = bench.sample(rng)
        r = steady_state(s, f, a, coupling="two-way")
        if (Status(int(r.status)) in (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING)
                and float(r.floquet_multiplier) <= math.exp(-1.0 / 50.0)):
            found.append((s, f, a))
    return found


@pytest.mark.parametrize("point", _points(), ids=lambda p: f"Q{p[0].Q:.3g}-f{p[1]:.4g}")
def test_exact_two_way_agrees_with_the_integrator(point):
    row = bench.compare(*point, max_periods=4000)
    assert row["status_exact"] == row["status_int"], (point, bench.explain(row))
    assert row["err_scale"] <= INTEGRATOR_TOLERANCE, (point, row["v_exact"], row["v_int"])


def test_benchmark_report_is_written_from_rows():
    rows = [bench.compare(*p) for p in _points(2, seed=5)]
    text = bench.report(rows, 5, 0.0)
    assert "Status agreement: 2 / 2" in text
    assert "UNEXPLAINED" not in text

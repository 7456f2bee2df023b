"""The frontier is kept like points: a rerun onto another output, or forced, reuses
the refined frontier of every structure whose map, solver and tolerance are the same,
bit for bit, and refines again only what changed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

import study
from study.studies import observables

SPEC = """
[study]
name = "kept-frontier"
observables = ["velocity", "frontier"]
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
cs = 0.25
[sweep]
M = {{ values = [0.08, 0.2] }}
f = {{ start = 13.5, stop = 16.0, num = 11 }}
a = {{ values = [5.0, 7.0, 9.0] }}
[solver]
frontier_tolerance = {tolerance}
"""


def _spec(tmp_path: Path, tolerance: float) -> Path:
    path = tmp_path / f"kept-{tolerance:g}.toml"
    path.write_text(SPEC.format(tolerance=tolerance))
    return path


def _refinements(monkeypatch) -> list[int]:
    """Count the frontier refinements a run computes (one per structure)."""
    calls: list[int] = []
    original = observables.frontier_from_grid

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(observables, "frontier_from_grid", counted)
    return calls


def test_a_rerun_onto_another_output_or_forced_reuses_the_frontier(tmp_path, monkeypatch,
                                                                   capsys):
    cache = tmp_path / "cache"
    spec = _spec(tmp_path, 1e-6)
    calls = _refinements(monkeypatch)
    study.run(spec, tmp_path / "first.nc", cache=cache, workers=1)
    assert len(calls) == 2  # one per structure
    study.run(spec, tmp_path / "second.nc", cache=cache, workers=1)
    study.run(spec, tmp_path / "second.nc", cache=cache, workers=1, force=True,
              progress=True)
    assert len(calls) == 2  # nothing refined again
    assert "frontier of 2 of 2 structures reused" in capsys.readouterr().err
    with xr.open_dataset(tmp_path / "first.nc") as a, \
            xr.open_dataset(tmp_path / "second.nc") as b:
        assert np.isfinite(a.frontier_frequency.values).sum() >= 2
        for name in ("frontier_frequency", "frontier_kind", "frontier_direction",
                     "frontier_bracket"):
            assert np.array_equal(a[name].values, b[name].values,
                                  equal_nan=a[name].dtype.kind == "f"), name


def test_another_tolerance_refines_again(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    calls = _refinements(monkeypatch)
    study.run(_spec(tmp_path, 1e-6), tmp_path / "coarse.nc", cache=cache, workers=1)
    study.run(_spec(tmp_path, 1e-9), tmp_path / "fine.nc", cache=cache, workers=1)
    assert len(calls) == 4
    with xr.open_dataset(tmp_path / "coarse.nc") as coarse, \
            xr.open_dataset(tmp_path / "fine.nc") as fine:
        finite = np.isfinite(fine.frontier_frequency.values)
        assert (fine.frontier_bracket.values[finite] <= 1e-9).all()
        assert (coarse.frontier_bracket.values[finite] > 1e-9).any()
        np.testing.assert_allclose(fine.frontier_frequency.values[finite],
                                   coarse.frontier_frequency.values[finite], rtol=0,
                                   atol=1e-6)

"""Two-way coupling: the integrator against the independent reference, the coupling study,
its analysis and its figure."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

from study import Structure
from study.analyses.coupling import coupling_effect
from study.cli import main
from study.engine.runner import run_study
from study.engine.store import open_result
from study.model.status import Status
from study.solvers.integrator import IntegratorSettings, integrated_steady_state
from tests.reference.integrator import reference_velocity

PAPER = dict(f0=14.44, Q=17.5, alpha=64.0, cs=0.25)
REFERENCE_STATUS = {"static": 0, "stick_slip": 1, "continuous_sliding": 2, "lift_off": 3,
                    "not_converged": 4, "friction_paradox": 5}


@pytest.mark.parametrize(
    ("M", "ck", "f", "a"),
    [
        (0.08, 0.25, 13.0, 8.5),   # P: two-way 7 % below one-way
        (0.08, 0.25, 14.6, 7.0),   # PN: two-way reverses the direction
        (0.08, 0.15, 16.5, 8.5),   # N with ck < cs
        (0.3, 0.25, 14.6, 7.0),    # one-way slides continuously, two-way lifts off
        (0.15, 0.25, 15.5, 6.0),
    ],
)
def test_two_way_mean_velocity_matches_the_independent_reference(M, ck, f, a):
    # The reference solves the 2x2 system of the coupled accelerations numerically at each
    # right-hand side (solve_ivp DOP853, rtol 1e-12); the kernel uses an eliminated form.
    structure = Structure(M=M, ck=ck, **PAPER)
    run = integrated_steady_state(structure, f, a, coupling="two-way",
                                  settings=IntegratorSettings(tolerance=1e-11))
    v_ref, status_ref, _ = reference_velocity(PAPER["f0"], PAPER["Q"], PAPER["alpha"], M,
                                              PAPER["cs"], f, a, ck=ck, coupling="two-way")
    assert int(run.status) == REFERENCE_STATUS[status_ref]
    if np.isfinite(v_ref):
        assert_allclose(run.velocity, v_ref, rtol=1e-7, atol=1e-12)
    else:
        assert np.isnan(run.velocity)


def _synthetic() -> xr.Dataset:
    # Four one-way moving points per M; the two-way values are set by hand.
    v1 = np.array([[[1.0, 1.0, -2.0, 4.0, 0.0]], [[1.0, 1.0, 1.0, 1.0, 1.0]]])
    s1 = np.array([[[1, 1, 1, 1, 0]], [[1, 1, 1, 1, 1]]], dtype=np.int8)
    v2 = np.array([[[1.05, 1.2, 2.0, np.nan, 0.0]], [[1.0, 1.0, 1.0, 1.0, np.nan]]])
    s2 = np.array([[[1, 1, 1, 3, 0]], [[1, 1, 1, 1, 5]]], dtype=np.int8)
    dims = ("M", "f", "a")
    return xr.Dataset(
        {"velocity": (dims, v2), "status": (dims, s2), "velocity_one_way": (dims, v1),
         "status_one_way": (dims, s1)},
        coords={"M": [0.1, 0.9], "f": [14.0], "a": np.arange(5.0)},
    )


def test_coupling_effect_counts_by_hand():
    effect = coupling_effect(_synthetic())
    # M = 0.1: moving one-way points 4; changed > 10 %: 1.2 and the reversal (2 of 4);
    # reversed 1; lifted 1; median of (0.05, 0.2, 2.0) = 0.2.
    assert_allclose(effect["changed"].values, [2 / 4, 0.0], rtol=1e-15)
    assert_allclose(effect["reversed"].values, [1 / 4, 0.0], rtol=1e-15)
    assert_allclose(effect["lifted"].values, [1 / 4, 0.0], rtol=1e-15)
    assert_allclose(effect["paradox"].values, [0.0, 1 / 5], rtol=1e-15)
    assert_allclose(effect["median_change"].values, [0.2, 0.0], rtol=1e-15)
    assert effect["moving_points"].values.tolist() == [4, 5]


def test_coupling_effect_needs_the_paper_model():
    with pytest.raises(ValueError, match="paper_model"):
        coupling_effect(_synthetic().drop_vars("velocity_one_way"))


SPEC = """\
[study]
name = "coupling"
observables = ["lift_off", "velocity", "paper_model"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
cs = 0.25

[sweep]
M = { values = [0.02, 0.3] }
f = { start = 12.0, stop = 16.0, num = 5 }
a = { start = 6.0, stop = 10.0, num = 3 }

[solver]
method = "integrator"   # the exact two-way solver's studies: tests/unit/test_figures_two_way.py
coupling = "two-way"
tolerance = 1e-9
"""


@pytest.fixture(scope="module")
def coupling_file(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("coupling")
    (folder / "coupling.toml").write_text(SPEC)
    run_study(folder / "coupling.toml", folder / "coupling.nc", progress=False, workers=1)
    return folder / "coupling.nc"


def test_coupling_study_stores_both_models(coupling_file):
    dataset = open_result(coupling_file)
    assert dataset.attrs["study_coupling"] == "two-way"
    from study.solvers.exact import steady_state

    for i, M in enumerate(dataset["M"].values):
        structure = Structure(M=float(M), **PAPER)
        f = dataset["f"].values[:, None]
        a = dataset["a"].values[None, :]
        one = steady_state(structure, f, a)
        assert np.array_equal(dataset["status_one_way"].isel(M=i).values, one.status)
        assert_allclose(dataset["velocity_one_way"].isel(M=i).values, one.velocity,
                        rtol=0, atol=0)
    assert dataset["velocity_one_way"].attrs["units"] == "m s-1"
    assert set(np.unique(dataset["status"].values)) <= {s.value for s in Status}


def test_coupling_figure_is_drawn_and_refuses_a_one_way_file(coupling_file, tmp_path, capsys):
    stem = tmp_path / "coupling"
    assert main(["figure", "coupling", str(coupling_file), "-o", str(stem)]) == 0
    assert stem.with_suffix(".png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    one_way = tmp_path / "one-way.toml"
    one_way.write_text(SPEC.replace(", \"paper_model\"", "").split("[solver]")[0])
    run_study(one_way, tmp_path / "one-way.nc", progress=False, workers=1)
    assert main(["figure", "coupling", str(tmp_path / "one-way.nc"), "-o", str(stem)]) == 1
    assert "velocity_one_way" in capsys.readouterr().err

"""The irregular observable's 95 % interval of the averaged velocity (issue 47):
``averaged_velocity_low`` and ``averaged_velocity_high`` are the averaged velocity -+
the two-sided 95 % normal quantile (scipy's, computed apart) times its standard error,
NaN where there is no averaged velocity, declared once with their units; the interval
is the one the solver's own stopping rule uses (its half-width within the velocity
tolerance of a / (2 pi f) at every irregular point). A file without them (written
before they were declared, or upgraded from one) stays valid; a file whose interval
misses its velocity is refused."""

from __future__ import annotations

import math
import shutil

import netCDF4
import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.stats import norm

import study
from study.engine.runner import run_study
from study.engine.validation import seal, validate_file
from study.engine.validation.reading import ResultError
from study.model.status import Status
from study.model.units import METRE_PER_SECOND
from study.studies.observables import OBSERVABLES, velocity_interval
from study.studies.variables import VARIABLES
from tests.support.sealed_results import rewrite

#: The known irregular points of tests/unit/test_irregular_motion.py (M = 0.99, flight)
#: on one grid: chaotic at (5.625 Hz, 11.6 m s-2), quasi-periodic at (8.333, 11.9), a
#: bouncing orbit at (13.0, 12.0).
STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
F = [5.625, 8.333, 13.0]
A = [11.6, 11.9, 12.0]
#: The two-sided 95 % quantile of the normal distribution, from scipy.
Z = norm.ppf(0.975)

SPEC = """\
[study]
name = "interval"
observables = ["velocity", "irregular"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.99
cs = 0.25

[sweep]
f = { values = [5.625, 8.333, 13.0] }
a = { values = [11.6, 11.9, 12.0] }

[solver]
coupling = "two-way"
flight = true
"""


@pytest.fixture(scope="module")
def mapped():
    return study.compute_map(STRUCTURE, F, A, observables=["velocity", "irregular"],
                             coupling="two-way", flight=True, workers=1)


def test_the_interval_is_declared_once_with_its_units():
    irregular = OBSERVABLES["irregular"].variables
    for name in ("averaged_velocity_low", "averaged_velocity_high"):
        assert name in irregular
        declared = VARIABLES[name]
        assert (declared.units, declared.grid, declared.dtype) == (METRE_PER_SECOND, "point",
                                                                  "float64")
        assert "95 % confidence interval of the averaged velocity" in declared.long_name
        assert f"{Z:.7g} velocity_error" in declared.comment


def test_the_ends_are_the_mean_and_the_normal_quantile_times_its_error(mapped):
    mean = mapped["averaged_velocity"].values
    error = mapped["velocity_error"].values
    low = mapped["averaged_velocity_low"].values
    high = mapped["averaged_velocity_high"].values
    status = mapped["status"].values
    assert mapped["averaged_velocity_low"].attrs["units"] == "m s-1"
    irregular = np.isin(status, [Status.CHAOTIC, Status.QUASI_PERIODIC])
    # The known points: chaotic and quasi-periodic on the diagonal, an orbit at 13 Hz.
    assert status[0, 0] == Status.CHAOTIC and status[1, 1] == Status.QUASI_PERIODIC
    assert status[2, 2] == Status.BOUNCING
    averaged = np.isfinite(mean)
    assert np.array_equal(averaged, irregular | (status == Status.NOT_CONVERGED))
    assert_allclose(low[averaged], mean[averaged] - Z * error[averaged], rtol=1e-15, atol=0)
    assert_allclose(high[averaged], mean[averaged] + Z * error[averaged], rtol=1e-15, atol=0)
    assert np.all(error[averaged] > 0) and np.all(low[averaged] < mean[averaged])
    assert np.all(mean[averaged] < high[averaged])
    # No averaged velocity (an orbit, exact; a static point): no interval.
    assert np.isnan(low[~averaged]).all() and np.isnan(high[~averaged]).all()
    assert not averaged[2, 2]


def test_the_interval_is_the_one_the_averaging_stops_on(mapped):
    """The solver averages an irregular motion until its 95 % half-width is within
    velocity_tolerance (1e-3 by default) of a / (2 pi f): the interval written is that
    one (a t quantile of fewer batches, or another confidence, would be wider)."""
    status = mapped["status"].values
    f = mapped["f"].values[:, None]
    a = mapped["a"].values[None, :]
    half = 0.5 * (mapped["averaged_velocity_high"].values
                  - mapped["averaged_velocity_low"].values)
    irregular = np.isin(status, [Status.CHAOTIC, Status.QUASI_PERIODIC])
    assert irregular.sum() >= 2
    scale = np.broadcast_to(a / (2.0 * math.pi * f), status.shape)
    assert np.all(half[irregular] <= 1e-3 * scale[irregular] * (1 + 1e-12))


def test_velocity_interval_of_arrays():
    low, high = velocity_interval([0.01, np.nan, 0.02], [1e-4, 1e-4, np.nan])
    assert_allclose(low[0], 0.01 - Z * 1e-4, rtol=1e-15)
    assert_allclose(high[0], 0.01 + Z * 1e-4, rtol=1e-15)
    assert np.isnan(low[1:]).all() and np.isnan(high[1:]).all()


def test_a_file_holds_it_and_validation_checks_it(tmp_path):
    spec = tmp_path / "interval.toml"
    spec.write_text(SPEC)
    output = tmp_path / "interval.nc"
    run_study(spec, output, progress=False, workers=1)
    assert validate_file(output) == "study result"
    with netCDF4.Dataset(output) as nc:
        for name in ("averaged_velocity_low", "averaged_velocity_high"):
            assert nc[name].getncattr("units") == "m s-1"
    # Without the interval (a file written before it was declared): still valid.
    older = rewrite(output, tmp_path / "older.nc",
                    drop=("averaged_velocity_low", "averaged_velocity_high"))
    seal(older)
    assert validate_file(older) == "study result"
    # An interval that misses its velocity is refused.
    wrong = tmp_path / "wrong.nc"
    shutil.copy(output, wrong)
    with netCDF4.Dataset(wrong, "a") as nc:
        mean = np.asarray(nc["averaged_velocity"][:])
        nc["averaged_velocity_low"][:] = mean + 1.0
    with pytest.raises(ResultError, match="averaged_velocity_low and averaged_velocity_high "
                       "are NaN exactly where averaged_velocity is, and hold it elsewhere"):
        seal(wrong)

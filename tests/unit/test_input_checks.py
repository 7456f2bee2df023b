"""Inputs that are surely mistakes are refused (TypeError naming the argument) or warned
about (a tilt that looks like radians), and every sensible input still works."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import study
from study.model.inputs import RADIAN_LIKE_TILT, InputTypeError, tilt_looks_like_radians
from study.model.structure import tilt_warnings
from study.studies.spec import parse_spec

PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25}
STRUCTURE = study.Structure(**PAPER)


@pytest.mark.parametrize("name", ["f0", "Q", "alpha", "M", "cs", "ck", "g"])
@pytest.mark.parametrize("bad", ["30", "17.5", b"30", True, False, np.bool_(True), 1 + 0j,
                                 None, [17.5], np.array([17.5, 18.0]),
                                 np.datetime64("2020-01-01")])
def test_a_structure_parameter_of_another_type_is_a_type_error(name, bad) -> None:
    if name == "ck" and bad is None:
        pytest.skip("ck=None means ck defaults to cs")
    with pytest.raises(TypeError, match=f"parameter '{name}' must be a real number") as err:
        study.Structure(**{**PAPER, name: bad})
    assert isinstance(err.value, ValueError)  # as every bad parameter, catchable as such


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, np.float64("nan")])
def test_non_finite_parameters_are_refused(bad) -> None:
    with pytest.raises(ValueError, match="'Q' must be finite"):
        study.Structure(**{**PAPER, "Q": bad})


@pytest.mark.parametrize("good", [17, 17.5, np.float32(17.5), np.int64(17), np.array(17.5)])
def test_every_real_number_type_is_accepted(good) -> None:
    assert study.Structure(**{**PAPER, "Q": good}).Q == float(good)
    assert type(study.Structure(**{**PAPER, "Q": good}).Q) is float


@pytest.mark.parametrize("alpha", [0.785, 1.117, -0.5, 0.05, 1.5707])
def test_a_tilt_that_looks_like_radians_warns(alpha) -> None:
    with pytest.warns(study.SuspectInputWarning, match="looks like an angle in radians") as w:
        s = study.Structure(**{**PAPER, "alpha": alpha})
    assert s.alpha == alpha  # built as given, in degree
    assert f"{math.degrees(alpha):.6g}" in str(w[0].message)  # what to give instead
    assert w[0].filename == __file__  # points at the caller
    assert issubclass(study.SuspectInputWarning, study.StudyWarning)
    assert issubclass(study.StudyWarning, UserWarning)


def test_the_radians_warning_states_its_range_in_degree_throughout() -> None:
    """The window's ends are degree values (0.05 and 1.571 degree), and what they are
    in radians (2.865 and 90 degree) is said as such: no "pi/2 degree" (issue 47)."""
    with pytest.warns(study.SuspectInputWarning) as caught:
        study.Structure(**{**PAPER, "alpha": 1.117})
    with pytest.warns(study.SuspectInputWarning) as swept:
        study.compute_map(STRUCTURE, f=[14.0], a=[0.0], observables=["thresholds"],
                          sweep={"alpha": [0.5, 1.0]})
    low, high = RADIAN_LIKE_TILT
    for message in (str(caught[0].message), str(swept[0].message)):
        assert f"a tilt of {low:g} to {high:.4g} degree" in message
        assert (f"the numbers of {math.degrees(low):.4g} to {math.degrees(high):.4g} degree "
                "written in radians") in message
        assert "pi" not in message


@pytest.mark.parametrize("alpha", [0.0, 1e-6, 0.01, 0.0499, math.pi / 2, 2.0, 64.0, -89.9])
def test_other_tilts_do_not_warn(alpha) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        study.Structure(**{**PAPER, "alpha": alpha})
    assert not tilt_looks_like_radians(alpha)


def test_the_window_is_the_documented_one() -> None:
    low, high = RADIAN_LIKE_TILT
    assert (low, high) == (0.05, math.pi / 2)
    assert tilt_looks_like_radians(low) and not tilt_looks_like_radians(high)
    assert tilt_looks_like_radians(-low) and not tilt_looks_like_radians(np.nextafter(low, 0))


def test_files_and_searches_build_small_tilts_quietly() -> None:
    """A spec given as text (parse_spec, as compute_map gives its own) builds a 1-degree
    tilt silently; a spec file warns of it (load_spec: tests/unit/test_spec_mistakes.py)."""
    text = ('[study]\nname = "flat"\nobservables = ["thresholds"]\n[structure]\n'
            "f0 = 14.44\nQ = 17.5\nalpha = 1.0\nM = 0.08\ncs = 0.25\n"
            "[sweep]\nf = { start = 12.0, stop = 17.0, num = 3 }\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        spec = parse_spec(text)
        assert spec.structure_at(()).alpha == 1.0
        with tilt_warnings(False):
            study.Structure(**{**PAPER, "alpha": 0.785})
    with pytest.warns(study.SuspectInputWarning):  # and back on after the block
        study.Structure(**{**PAPER, "alpha": 0.785})


# -- drive arrays -------------------------------------------------------------------------

ARRAY_FUNCTIONS = {
    "steady_velocity": lambda f, a: study.steady_velocity(STRUCTURE, f, a),
    "steady_state": lambda f, a: study.steady_state(STRUCTURE, f, a),
    "steady_state two-way": lambda f, a: study.steady_state(STRUCTURE, f, a,
                                                            coupling="two-way"),
    "thresholds": lambda f, a: study.thresholds(STRUCTURE, f),
    "lift_off_acceleration": lambda f, a: study.lift_off_acceleration(STRUCTURE, f),
    "force_amplitudes": lambda f, a: study.force_amplitudes(STRUCTURE, f, a),
    "compute_map": lambda f, a: study.compute_map(STRUCTURE, f, a),
}
NEEDS_A = ("steady_velocity", "steady_state", "steady_state two-way", "force_amplitudes",
           "compute_map")
BAD_VALUES = {
    "strings": ["14", "15"],
    "a string": "14",
    "booleans": [True, False],
    "complex numbers": np.array([14.0 + 0j]),
    "dates": np.array(["2020-01-01"], dtype="datetime64[D]"),
    "None inside": [14.0, None],
}


@pytest.mark.parametrize("function", ARRAY_FUNCTIONS)
@pytest.mark.parametrize("bad", BAD_VALUES)
def test_a_drive_frequency_of_another_type_is_a_type_error(function, bad) -> None:
    with pytest.raises(InputTypeError, match=r"(drive frequency )?f must be real numbers"):
        ARRAY_FUNCTIONS[function](BAD_VALUES[bad], [5.0])


@pytest.mark.parametrize("function", NEEDS_A)
@pytest.mark.parametrize("bad", BAD_VALUES)
def test_a_drive_acceleration_of_another_type_is_a_type_error(function, bad) -> None:
    with pytest.raises(InputTypeError, match=r"(drive acceleration )?a must be real numbers"):
        ARRAY_FUNCTIONS[function]([14.0], BAD_VALUES[bad])


@pytest.mark.parametrize("function", ARRAY_FUNCTIONS)
def test_integer_and_float_arrays_are_accepted(function) -> None:
    """Integer drives are numbers: the same results as the floats they equal."""
    ints = ARRAY_FUNCTIONS[function](np.array([14, 15]), np.array([5, 8]))
    floats = ARRAY_FUNCTIONS[function](np.array([14.0, 15.0]), np.array([5.0, 8.0]))
    if function == "compute_map":
        assert ints.identical(floats)
        return
    for x, y in zip(np.atleast_1d(ints) if not isinstance(ints, tuple) else ints,
                    np.atleast_1d(floats) if not isinstance(floats, tuple) else floats,
                    strict=True):
        if hasattr(x, "velocity"):
            x, y = x.velocity, y.velocity
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -1.0, 0.0])
def test_out_of_range_frequencies_stay_value_errors(bad) -> None:
    with pytest.raises(ValueError, match="drive frequency f must be finite and > 0"):
        study.steady_velocity(STRUCTURE, [14.0, bad], 5.0)

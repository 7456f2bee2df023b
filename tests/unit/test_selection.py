"""``--sel`` selections: nearest, exact, ranges, fixed and auxiliary coordinates, and
errors naming the file, the key and the available values."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from study.analyses.selection import Selection, SelectionError, available, parse_selection, select


@pytest.fixture
def result() -> xr.Dataset:
    """A study-shaped dataset: Q and m_add swept (M along m_add), f, a; alpha fixed."""
    Q = np.array([15.0, 30.0])
    m_add = np.array([0.0, 1.7e-3, 3.8e-3])
    f = np.linspace(10.0, 20.0, 41)
    a = np.linspace(0.0, 12.0, 5)
    shape = (Q.size, m_add.size, f.size, a.size)
    velocity = np.arange(np.prod(shape), dtype=float).reshape(shape)
    return xr.Dataset(
        {"velocity": (("Q", "m_add", "f", "a"), velocity, {"units": "m s-1"}),
         "a_star_plus": (("Q", "m_add", "f"), velocity[..., 0], {"units": "m s-2"})},
        coords={"Q": ("Q", Q, {"units": "1"}), "m_add": ("m_add", m_add, {"units": "kg"}),
                "M": ("m_add", 6.56e-4 / (8.2e-3 + m_add), {"units": "1"}),
                "f": ("f", f, {"units": "Hz"}), "a": ("a", a, {"units": "m s-2"}),
                "alpha": ((), 64.0, {"units": "degree"})},
    )


def test_parse_the_three_forms() -> None:
    assert parse_selection(["Q=30", "f==14.25", "a=6:", "M = 0.1"]) == [
        Selection("Q", "nearest", "30"), Selection("f", "exact", "14.25"),
        Selection("a", "range", "6:"), Selection("M", "nearest", "0.1")]
    assert str(Selection("f", "exact", "14.25")) == "f==14.25"


@pytest.mark.parametrize("text", ["Q", "=3", "Q=", "Q==", "Q==1:2", "1Q=3", "Q=3 R=4"])
def test_malformed_selections_are_refused_with_the_grammar(text: str) -> None:
    with pytest.raises(SelectionError, match=r"expected KEY=VALUE|a range takes one|not a "):
        select(xr.Dataset(coords={"Q": [1.0, 2.0]}), [text])


def test_a_key_twice_is_refused() -> None:
    with pytest.raises(SelectionError, match="Q is selected twice"):
        parse_selection(["Q=1", "Q==2"])


def test_nearest_drops_the_dimension_and_keeps_the_value(result: xr.Dataset) -> None:
    chosen = select(result, ["Q=29", "f=14.3"], source="map.nc")
    assert chosen["velocity"].dims == ("m_add", "a")
    assert float(chosen["Q"]) == 30.0 and float(chosen["f"]) == 14.25
    np.testing.assert_array_equal(chosen["velocity"],
                                  result["velocity"].sel(Q=30.0, f=14.25))
    assert chosen.attrs["study_selection"] == "Q=30 (asked 29), f=14.25 Hz (asked 14.3)"


def test_exact_finds_linspace_values_and_refuses_absent_ones(result: xr.Dataset) -> None:
    assert float(select(result, ["f==14.25"])["f"]) == 14.25
    assert float(select(result, ["f==14.250000000000002"])["f"]) == 14.25
    with pytest.raises(SelectionError) as err:
        select(result, ["Q==20"], source="map.nc")
    assert str(err.value) == ("map.nc: --sel Q==20: Q has no value 20 exactly; available: "
                              "15, 30 (or Q=20 for the nearest)")
    with pytest.raises(SelectionError, match=r"f has no value 14.3 exactly; available: 41 "
                       r"values, 10, 10.25, \.\.\. 20"):
        select(result, ["f==14.3"], source="map.nc")


def test_nearest_refuses_values_outside_the_axis(result: xr.Dataset) -> None:
    assert float(select(result, ["Q=37"])["Q"]) == 30.0  # within half a spacing
    with pytest.raises(SelectionError, match=r"map.nc: --sel Q=38: 38 is outside the "
                       r"values of Q \(15, 30\)"):
        select(result, ["Q=38"], source="map.nc")


def test_unknown_key_lists_every_coordinate(result: xr.Dataset) -> None:
    with pytest.raises(SelectionError) as err:
        select(result, ["cs=0.3"], source="map.nc")
    text = str(err.value)
    assert text.startswith("map.nc: --sel cs=0.3: no coordinate 'cs' in this file; available: ")
    for part in ("Q [1]: 15, 30", "m_add [kg]: 0, 0.0017, 0.0038", "f [Hz]: 41 values, 10,",
                 "M (along m_add): 0.08, ", "alpha: 64 (fixed)"):
        assert part in text
    assert available(result) == text.split("available: ", 1)[1]


def test_fixed_parameters_are_checked_not_selected(result: xr.Dataset) -> None:
    same = select(result, ["alpha=64"])
    assert same.sizes == result.sizes and same.attrs["study_selection"] == "alpha=64 degree"
    with pytest.raises(SelectionError, match="alpha has the single value 64 in this file"):
        select(result, ["alpha=45"], source="map.nc")


def test_auxiliary_coordinate_selects_its_dimension(result: xr.Dataset) -> None:
    chosen = select(result, ["M=0.066"])
    assert "m_add" not in chosen.dims
    assert float(chosen["m_add"]) == pytest.approx(1.7e-3)
    assert float(chosen["M"]) == pytest.approx(6.56e-4 / 9.9e-3)


def test_range_keeps_the_dimension(result: xr.Dataset) -> None:
    chosen = select(result, ["a=6:", "f=10:11"])
    assert chosen["a"].values.tolist() == [6.0, 9.0, 12.0]
    assert chosen["f"].values.tolist() == [10.0, 10.25, 10.5, 10.75, 11.0]
    with pytest.raises(SelectionError, match="no a in 13:14; available: 0, 3, 6, 9, 12"):
        select(result, ["a=13:14"])


def test_labels_and_dimensions_without_coordinates() -> None:
    scene = xr.Dataset(
        {"plate_f0": ("plate", [14.44, 7.7]),
         "miss": (("strategy", "waypoint"), np.arange(6.0).reshape(3, 2))},
        coords={"strategy_name": ("strategy", ["calibration", "open_loop", "closed_loop"])})
    chosen = select(scene, ["strategy_name=open_loop", "plate=1"])
    assert chosen["miss"].values.tolist() == [2.0, 3.0]
    assert float(chosen["plate_f0"]) == 7.7
    with pytest.raises(SelectionError, match=r"strategy_name has no value 'blind'; "
                       "available: calibration, open_loop, closed_loop"):
        select(scene, ["strategy_name=blind"], source="plan.nc")
    with pytest.raises(SelectionError, match="plate=5: 5 is outside the values of plate"):
        select(scene, ["plate=5"])


def test_a_list_selects_each_nearest_and_keeps_the_dimension(result: xr.Dataset) -> None:
    chosen = select(result, ["f=13,14.5,16.1"], source="map.nc")
    assert chosen["velocity"].dims == result["velocity"].dims
    assert chosen["f"].values.tolist() == [13.0, 14.5, 16.0]
    # each value is the one a single selection finds
    for asked, got in zip((13, 14.5, 16.1), chosen["f"].values, strict=True):
        assert float(select(result, [f"f={asked}"])["f"]) == got
    np.testing.assert_array_equal(chosen["velocity"],
                                  result["velocity"].sel(f=[13.0, 14.5, 16.0]))
    assert chosen.attrs["study_selection"] == "f=13,14.5,16 Hz (asked 13,14.5,16.1)"
    # in the file's order, whatever the order asked
    assert select(result, ["f=16,13"])["f"].values.tolist() == [13.0, 16.0]
    assert parse_selection(["f=13, 14.5"]) == [Selection("f", "nearest", "13,14.5")]


def test_an_exact_list_refuses_a_value_the_file_lacks(result: xr.Dataset) -> None:
    chosen = select(result, ["f==13,14.25"])
    assert chosen["f"].values.tolist() == [13.0, 14.25]
    assert chosen.attrs["study_selection"] == "f=13,14.25 Hz"
    with pytest.raises(SelectionError, match=r"map.nc: --sel f==13,14.3: f has no value "
                       r"14.3 exactly; available: 41 values"):
        select(result, ["f==13,14.3"], source="map.nc")


def test_a_list_follows_the_single_value_rules(result: xr.Dataset) -> None:
    with pytest.raises(SelectionError, match=r"--sel Q=15,38: 38 is outside the values "
                       r"of Q \(15, 30\)"):
        select(result, ["Q=15,38"], source="map.nc")
    with pytest.raises(SelectionError, match=r"--sel f=14.3,14.35: 14.3 and 14.35 both "
                       r"select f=14.25"):
        select(result, ["f=14.3,14.35"])
    chosen = select(result, ["M=0.08,0.066"])  # an auxiliary coordinate
    assert chosen["m_add"].values.tolist() == [0.0, 1.7e-3]
    scene = xr.Dataset(coords={"strategy_name": ("strategy", ["calibration", "open_loop",
                                                               "closed_loop"])})
    assert select(scene, ["strategy_name=closed_loop,calibration"])[
        "strategy_name"].values.tolist() == ["calibration", "closed_loop"]


@pytest.mark.parametrize(("text", "message"), [
    ("f=13,,14", "an empty value in the list"),
    ("f=13,", "an empty value in the list"),
    ("f=13,13", "13 listed twice"),
    ("f=10:12,14", "a list takes values, not ranges"),
    ("f=13,x", "'x' is not a number"),
])
def test_malformed_lists_are_refused(result: xr.Dataset, text: str, message: str) -> None:
    with pytest.raises(SelectionError, match=message):
        select(result, [text])


def test_the_record_carries_units(result: xr.Dataset) -> None:
    assert select(result, ["a=6:"]).attrs["study_selection"] == "a=6 to 12 m s-2 (3 values)"
    assert select(result, ["m_add=0.0017"]).attrs["study_selection"] == "m_add=0.0017 kg"
    assert select(result, ["Q=30"]).attrs["study_selection"] == "Q=30"  # units 1

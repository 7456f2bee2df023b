"""The measurement CSV format: the minimal file, the declared columns and schema, and
refusals that name the file, the line and the column."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import study
from study.measurements import (
    COLUMNS,
    QUANTITIES,
    MeasurementError,
    export_measurement_schema,
    parse_measurements,
    read_measurements,
)

MINIMAL = """quantity,f,a,value,sigma
threshold,13.0,,6.25,0.05
threshold,16.5,,6.6,0.05
velocity,13.0,8.5,0.0022,0.0001
"""


def test_the_minimal_file_reads_as_is(tmp_path: Path) -> None:
    path = tmp_path / "measured.csv"
    path.write_text(MINIMAL)
    data = read_measurements(path)
    assert data.sizes["measurement"] == 3
    assert list(data["quantity"].values) == ["threshold", "threshold", "velocity"]
    np.testing.assert_array_equal(data["f"].values, [13.0, 16.5, 13.0])
    assert np.isnan(data["a"].values[:2]).all() and data["a"].values[2] == 8.5
    assert list(data["value_units"].values) == ["m s-2", "m s-2", "m s-1"]
    assert list(data["direction"].values) == ["unknown", "unknown", ""]
    assert list(data["line"].values) == [2, 3, 4]
    assert data["f"].attrs["units"] == "Hz" and data["a"].attrs["units"] == "m s-2"
    assert data["m_add"].attrs["units"] == "kg"


def test_comments_blank_lines_optional_columns_and_several_files(tmp_path: Path) -> None:
    one = tmp_path / "one.csv"
    one.write_text("# ring-down of 2026-11-20\n\nquantity,value,sigma,note\n"
                   "ringdown_f0,14.41,0.02,tap test\nringdown_Q,17.9,0.5,\n")
    two = tmp_path / "two.csv"
    two.write_text("quantity,f,value,sigma,direction,m_add\n"
                   "threshold,14.0,4.1,0.1,forward,0.0017\n"
                   "threshold,15.0,4.9,0.1,backward,\n")
    data = read_measurements([one, two])
    assert data.sizes["measurement"] == 4
    assert list(data["line"].values) == [4, 5, 2, 3]
    assert list(data["direction"].values) == ["", "", "forward", "backward"]
    assert data["m_add"].values[2] == 0.0017 and np.isnan(data["m_add"].values[3])
    assert list(data["source"].values) == [str(one), str(one), str(two), str(two)]


def test_the_schema_file_is_the_export_of_the_declarations() -> None:
    folder = Path(study.__file__).parent / "schemas"
    on_disk = (folder / "study-measurements-v1.schema.json").read_text(encoding="utf-8")
    assert on_disk == export_measurement_schema(), "run `make schemas`"
    schema = json.loads(on_disk)
    assert list(schema["properties"]) == list(COLUMNS)
    assert schema["properties"]["quantity"]["enum"] == list(QUANTITIES)
    for q in QUANTITIES.values():  # the units of each quantity are documented
        assert f"{q.name} [{q.units}]" in schema["description"]


def refusal(text: str, name: str = "lab.csv") -> str:
    with pytest.raises(MeasurementError) as err:
        parse_measurements(text, name)
    return str(err.value)


@pytest.mark.parametrize("text, expected", [
    ("quantity,f,a,value,sigma\nthreshold,abc,,6.2,0.05\n",
     "lab.csv, line 2, column 'f': 'abc' is not a finite number"),
    ("quantity,f,a,value,sigma\nthreshold,13,,nan,0.05\n",
     "lab.csv, line 2, column 'value': 'nan' is not a finite number"),
    ("quantity,f,a,value,sigma\nthresh,13,,6.2,0.05\n",
     "lab.csv, line 2, column 'quantity': 'thresh' is not allowed; allowed: threshold, "
     "velocity, ringdown_f0, ringdown_Q"),
    ("quantity,f,a,sigma\nthreshold,13,,0.05\n",
     "lab.csv, line 1: missing required column 'value'"),
    ("quantity,f,a,value,sigma\nthreshold,13,,6.2,-0.05\n",
     "lab.csv, line 2, column 'sigma': -0.05 is out of range; allowed: sigma > 0"),
    ("quantity,f,a,value,sigma\nvelocity,13,0,0.001,0.0001\n",
     "lab.csv, line 2, column 'a': 0.0 is out of range; allowed: a > 0"),
    ("quantity,f,a,value,sigma\nvelocity,13,,0.001,0.0001\n",
     "lab.csv, line 2, column 'a': blank; a 'velocity' row needs f, a"),
    ("quantity,f,a,value,sigma\nthreshold,13,5,6.2,0.05\n",
     "lab.csv, line 2, column 'a': must be blank for quantity 'threshold'"),
    ("quantity,f,a,value,sigma\nthreshold,13,,-6.2,0.05\n",
     "lab.csv, line 2, column 'value': -6.2 is out of range; allowed: value > 0 for "
     "quantity 'threshold'"),
    ("quantity,f,value,direction\nthreshold,13,6.2,sideways\n",
     "lab.csv, line 2, column 'direction': 'sideways' is not allowed; allowed: forward, "
     "backward, unknown"),
    ("quantity,f,value,sigmaa\nthreshold,13,6.2,0.1\n",
     "lab.csv, line 1: unknown column 'sigmaa'; allowed: quantity, f, a, value, sigma"),
    ("quantity,f,value\nthreshold,13,6.2,0.1\n",
     "lab.csv, line 2: 4 cells, the header has 3"),
    ("quantity,f,value,M\nthreshold,13,6.2,1.5\n",
     "lab.csv, line 2, column 'M': 1.5 is out of range; allowed: M > 0.0 and <= 1.0"),
    ("quantity,value\n", "lab.csv: no measurements"),
    ("", "lab.csv: no header row"),
])
def test_refusals_name_file_line_and_column(text: str, expected: str) -> None:
    assert expected in refusal(text)


def test_every_problem_is_listed_with_its_own_line() -> None:
    message = refusal("quantity,f,a,value,sigma\n# comment\nthreshold,x,,6,0.1\n"
                      "velocity,13,,0.1,0.1\n")
    assert "line 3, column 'f'" in message and "line 4, column 'a'" in message


def test_unreadable_and_non_utf8_files_are_named(tmp_path: Path) -> None:
    with pytest.raises(MeasurementError, match=r"missing\.csv: cannot read"):
        read_measurements(tmp_path / "missing.csv")
    bad = tmp_path / "bad.csv"
    bad.write_bytes(b"quantity,value\nthreshold\xff,1\n")
    with pytest.raises(MeasurementError, match=r"bad.csv, line 2: not UTF-8"):
        read_measurements(bad)

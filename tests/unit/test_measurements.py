"""The measurement CSV format: the minimal file, the declared columns and schema, and
refusals that name the file, the line and the column."""

from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import study
from study.analyses import measurements
from study.analyses.measurements import (
    COLUMNS,
    MAX_FIELD_CHARS,
    MAX_LINE_CHARS,
    QUANTITIES,
    MeasurementError,
    export_measurement_schema,
    parse_measurements,
    read_measurements,
)
from tests.unit.test_cache_health import deadline

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


# ---------------------------------------------------------------------------
# Numbers read strictly; sigma a normal float (issue 19, item 6)

HEADER = "quantity,f,a,value,sigma\n"


@pytest.mark.parametrize("cell", [
    "6_25", "0x10", "0o17", "inf", "-inf", "Infinity", "nan", "NaN", "1e999", "-1e999",
    "6.25 x", "6.25x", "x6.25", "\uff16.25", "\u0666.25", "1.2.3", "e5", "1e", "+-1", "--1", ".",
    "6,25", "6.25 7", "1_000.5", "0b1", "6.25\x00", "6.25\x0b7",
])
def test_a_number_float_would_take_or_not_is_refused_naming_the_cell(cell: str) -> None:
    text = HEADER + f'threshold,13,,"{cell}",0.05\n'
    message = refusal(text)
    assert f"lab.csv, line 2, column 'value': {cell.strip(' ')!r}" in message
    assert "not a finite number" in message and "Traceback" not in message


@pytest.mark.parametrize("cell, expected", [
    ("6.25", 6.25), (" 6.25 ", 6.25), ("+6.25", 6.25), ("625e-2", 6.25), ("6.25E0", 6.25),
    ("6.", 6.0), (".5", 0.5), ("0006.25", 6.25), ("6.250000000000000000001", 6.25),
])
def test_plain_decimal_numbers_read_as_python_reads_the_literal(cell: str, expected: float
                                                                ) -> None:
    data = parse_measurements(HEADER + f"threshold,13,,{cell},0.05\n", "lab.csv")
    assert data["value"].values[0] == expected


def test_a_subnormal_sigma_is_refused_and_the_smallest_normal_one_read() -> None:
    message = refusal(HEADER + "threshold,13,,6.25,1e-320\n")
    assert "line 2, column 'sigma': '1e-320' is below the smallest normal float64" in message
    tiny = sys.float_info.min
    data = parse_measurements(HEADER + f"threshold,13,,6.25,{tiny!r}\n", "lab.csv")
    assert data["sigma"].values[0] == tiny


# ---------------------------------------------------------------------------
# Layout: one row per line, limits on lines, cells and rows

def test_a_quoted_cell_spanning_lines_is_one_error_naming_the_lines() -> None:
    message = refusal(HEADER + 'threshold,13,,"6.25\n7",0.05\nthreshold,14,,6,0.05\n')
    assert "lab.csv, lines 2-3: a quoted cell spans lines" in message


def test_an_unclosed_quote_is_one_error_naming_its_line() -> None:
    message = refusal(HEADER + "threshold,13,,6.25,0.05\nthreshold,14,,\"6,0.05\n")
    assert "lab.csv, line 3: not CSV (an unclosed quote)" in message


def test_a_quoted_comma_in_a_note_and_spaces_after_commas_are_read() -> None:
    text = 'quantity, f, value, note\nthreshold, 13, 6.25, "plate 2, taped"\n'
    data = parse_measurements(text, "lab.csv")
    assert data["value"].values[0] == 6.25 and data["f"].values[0] == 13.0


def test_a_huge_line_and_a_long_cell_are_refused_naming_line_and_limit() -> None:
    message = refusal(HEADER + "threshold,13,," + "1" * 200_000 + ",0.05\n")
    assert f"lab.csv, line 2: 200019 characters; a line of a measurement file holds at most " \
           f"{MAX_LINE_CHARS}" in message
    long_note = "quantity,f,value,note\nthreshold,13,6.25," + "n" * (MAX_FIELD_CHARS + 1)
    assert (f"lab.csv, line 2, column 'note': {MAX_FIELD_CHARS + 1} characters; a cell holds "
            f"at most {MAX_FIELD_CHARS}") in refusal(long_note)
    data = parse_measurements(long_note[:-1], "lab.csv")  # at the limit: read
    assert len(data["value"]) == 1


def test_more_rows_than_the_limit_are_refused(monkeypatch) -> None:
    monkeypatch.setattr(measurements, "MAX_ROWS", 3)
    rows = "threshold,13,,6.25,0.05\n"
    assert parse_measurements(HEADER + 3 * rows, "lab.csv").sizes["measurement"] == 3
    assert "lab.csv, line 5: more than 3 rows" in refusal(HEADER + 4 * rows)


def test_line_numbers_count_comments_blank_lines_and_crlf_endings() -> None:
    text = "# lab book p. 3\r\n\r\n" + HEADER.replace("\n", "\r\n") + \
        "threshold,13,,6.25,0.05\r\n# retake\r\nthreshold,14,,6.5,0.05\r\n"
    data = parse_measurements(text, "lab.csv")
    assert list(data["line"].values) == [4, 6]
    np.testing.assert_array_equal(data["value"].values, [6.25, 6.5])


def test_many_bad_rows_list_thirty_and_count_the_rest() -> None:
    message = refusal(HEADER + 100 * "threshold,13,5,6.25,0.05\n")
    assert message.count("must be blank") == 30
    assert message.endswith("... and 70 more")


# ---------------------------------------------------------------------------
# Files: only regular files, no link out of their folder, bounded size

@pytest.fixture
def good_file(tmp_path: Path) -> Path:
    path = tmp_path / "lab" / "measured.csv"
    path.parent.mkdir()
    path.write_text(MINIMAL)
    return path


def read_refusal(path: Path) -> str:
    with deadline(20), pytest.raises(MeasurementError) as err:
        read_measurements(path)
    return str(err.value)


def test_dev_zero_a_fifo_and_a_folder_are_refused_before_a_byte_is_read(tmp_path: Path
                                                                        ) -> None:
    assert read_refusal(Path("/dev/zero")) == (
        "/dev/zero: a character device, not a regular file; a measurement file is a CSV "
        "text file")
    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)
    assert read_refusal(fifo) == f"{fifo}: a FIFO, not a regular file; a measurement file " \
                                 "is a CSV text file"
    assert "a folder, not a regular file" in read_refusal(tmp_path)


def test_a_link_out_of_its_folder_is_refused_and_one_inside_is_read(good_file: Path,
                                                                    tmp_path: Path) -> None:
    outside = tmp_path / "elsewhere.csv"
    outside.write_text(MINIMAL)
    link = good_file.parent / "linked.csv"
    link.symlink_to(outside)
    assert read_refusal(link).startswith(f"{link}: a symbolic link out of its folder")
    to_zero = good_file.parent / "zero.csv"
    to_zero.symlink_to("/dev/zero")
    assert "a symbolic link out of its folder" in read_refusal(to_zero)
    inside = good_file.parent / "same.csv"
    inside.symlink_to(good_file.name)
    assert read_measurements(inside).sizes["measurement"] == 3


def test_a_file_beyond_the_size_limit_is_refused_unread(good_file: Path, monkeypatch) -> None:
    monkeypatch.setattr(measurements, "MAX_BYTES", 40)
    assert read_refusal(good_file) == (
        f"{good_file}: {len(MINIMAL)} bytes; a measurement file is at most 40 bytes")


def test_reading_changes_no_file(good_file: Path) -> None:
    before = good_file.read_bytes(), good_file.stat().st_mtime_ns
    read_measurements(good_file)
    assert (good_file.read_bytes(), good_file.stat().st_mtime_ns) == before


# ---------------------------------------------------------------------------
# The column-wise checks agree with the schema, row by row (an independent check:
# jsonschema reads the exported schema; the reader checks columns with numpy).

_CELLS = {
    "quantity": st.sampled_from([*QUANTITIES, "thresh", "Threshold", ""]),
    "direction": st.sampled_from(["forward", "backward", "unknown", "sideways", ""]),
    "note": st.sampled_from(["", "tap test", "x"]),
}
_NUMBERS = st.sampled_from(["", "0", "-0", "1", "-1", "0.5", "1.0", "1.5", "13", "6.25",
                            "1e-300", "-3", "2.5e-308", "1e300"])


@st.composite
def rows(draw) -> dict[str, str]:
    names = draw(st.lists(st.sampled_from(list(COLUMNS)), unique=True, min_size=0))
    names = ["quantity", "value", *[n for n in names if n not in ("quantity", "value")]]
    return {n: draw(_CELLS[n] if n in _CELLS else _NUMBERS) for n in names}


@settings(max_examples=400, deadline=None, derandomize=True)
@given(rows())
def test_a_row_is_read_exactly_when_the_schema_accepts_it(row: dict[str, str]) -> None:
    import jsonschema

    text = ",".join(row) + "\n" + ",".join(row.values()) + "\n"
    as_schema_sees_it = {name: float(cell) if COLUMNS[name].number else cell
                         for name, cell in row.items() if cell}
    valid = jsonschema.Draft202012Validator(
        json.loads(export_measurement_schema())).is_valid(as_schema_sees_it)
    valid = valid and not ("m_add" in as_schema_sees_it and "M" in as_schema_sees_it)
    try:
        data = parse_measurements(text, "row.csv")
    except MeasurementError as err:
        assert not valid, str(err)
        assert "row.csv, line 2" in str(err)
        return
    assert valid, row
    for name, cell in row.items():
        if COLUMNS[name].number:
            expected = float(cell) if cell else np.nan
            np.testing.assert_equal(data[name].values[0], expected, err_msg=name)


def test_the_figure_request_reads_measurements_as_the_figure_does(tmp_path: Path) -> None:
    """`study figure --if-changed --measurements /dev/zero` hashed the device without
    bound, and waited forever on a FIFO."""
    import xarray as xr

    from study.figures import figure_request

    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)
    good = tmp_path / "good.csv"
    good.write_text(MINIMAL)
    with deadline(60):
        request = json.loads(figure_request("thresholds", xr.Dataset(),
                                            measurements=["/dev/zero", fifo, good]))
    digests = [digest for _, digest in request["measurements"]]
    assert digests[:2] == [None, None]
    assert digests[2] == hashlib.sha256(MINIMAL.encode()).hexdigest()

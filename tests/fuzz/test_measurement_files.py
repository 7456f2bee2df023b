"""Seeded fuzz of measurement files (study.analyses.measurements.read_measurements).

Two generators (hypothesis, derandomized: the same cases on every run):

* random bytes, and random text over the characters that matter to CSV (commas,
  quotes, line ends, ``#``, digits, signs, exponents, underscores);
* valid-looking files (a header of real columns, rows of real quantities and plain
  numbers) with cells corrupted: numbers ``float`` would take and the format refuses
  (``6_25``, ``0x10``, ``inf``, ``1e999``), a subnormal sigma, stray or unclosed
  quotes, line breaks inside quotes, NUL and control characters, Unicode digits,
  cells at and beyond the length limit, missing and extra cells, CRLF, a BOM and
  comment lines.

Every case is written to a file and read under a time limit. Allowed outcomes: a
dataset whose numbers are finite (NaN only where blank), whose sigma are positive
normal floats and whose rows name lines of the file in order; or one
:class:`MeasurementError` whose message starts with the file's name and names only
lines the file has. Anything else fails the tier: another exception (a traceback),
a hang, or a changed file. ``make fuzz`` runs it; a slice runs in ``make test``
(tests/unit/test_measurement_fuzz_slice.py).
"""

from __future__ import annotations

import re
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from study.analyses.measurements import (
    COLUMNS,
    MAX_FIELD_CHARS,
    QUANTITIES,
    MeasurementError,
    read_measurements,
)
from tests.fuzz.test_spec_runs import time_limit
from tests.support.reliability import record

#: Cases of each generator in ``make fuzz``.
CASES = 1500
#: Time limit of one case [s] (a case takes milliseconds).
LIMIT = 20.0

OUTCOMES: Counter = Counter()


def fuzz_settings(cases: int) -> settings:
    """Derandomized (seeded by the test's name), no example database, no deadline."""
    return settings(max_examples=cases, derandomize=True, database=None, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow,
                                           HealthCheck.data_too_large])


def judge(path: Path, data: bytes) -> str:
    """Write ``data`` to ``path``, read it, and check the outcome (see module doc)."""
    path.write_bytes(data)
    try:
        with time_limit(LIMIT):
            dataset = read_measurements(path)
    except MeasurementError as err:
        message = str(err)
        assert message.startswith(str(path)), message[:300]
        assert "Traceback" not in message
        lines = data.count(b"\n") + 1
        for number in re.findall(r"\blines? (\d+)", message):
            assert 1 <= int(number) <= lines, (number, lines, message[:300])
        outcome = "refused"
    else:
        n = dataset.sizes["measurement"]
        assert n >= 1
        assert set(dataset["quantity"].values) <= set(QUANTITIES)
        for name, column in COLUMNS.items():
            if column.number:
                values = dataset[name].values
                assert not np.isinf(values).any(), name
        sigma = dataset["sigma"].values
        given_sigma = sigma[~np.isnan(sigma)]
        assert (given_sigma >= sys.float_info.min).all(), given_sigma
        line = dataset["line"].values
        assert (np.diff(line) > 0).all() and line[0] >= 1
        assert line[-1] <= data.count(b"\n") + 1
        outcome = "accepted"
    assert path.read_bytes() == data, "the file changed"
    OUTCOMES[outcome] += 1
    return outcome


# ---------------------------------------------------------------------------
# Generators

CSV_CHARACTERS = st.sampled_from([*',,,,""\n\n\r#. 0123456789eE+-_x\t\x00', "threshold",
                                  "velocity", "quantity", "value", "sigma"])
RANDOM_TEXT = st.lists(CSV_CHARACTERS, max_size=200).map("".join)

#: Cells that float() takes or half-takes and the format refuses, or that break CSV.
BAD_CELLS = (
    "6_25", "1_000", "0x10", "0o7", "inf", "-inf", "Infinity", "nan", "NaN", "1e999",
    "-1e999", "1e-320", "4.9e-324", "-0", "0", "-1", "", " ", '"', '""', '"6.25',
    '6.25"', '"6.25"x', "6.25\n7", '"6.25\n7"', "6.25\r7", "\x00", "6.25\x00",
    "\uff16.25", "\u0666", "6,25", "#", "# comment", "threshold", "unknown", "1.2.3",
    "e5", "1e", "--1", "\u2028", "\x0b", "\ufeff6.25", "1" * MAX_FIELD_CHARS,
    "1" * (MAX_FIELD_CHARS + 1), "x" * 20000, "2.2250738585072014e-308",
    "1.7976931348623157e308", "1e308", "-1e-300",
)
GOOD_NUMBERS = st.one_of(
    st.floats(min_value=1e-6, max_value=1e6).map(repr),
    st.sampled_from(["13", "6.25", "0.05", "1e-4", "8.5", ".5", "5.", "+1.5", "0.08"]))


@st.composite
def corrupted_files(draw) -> bytes:
    columns = ["quantity", "f", "a", "value", "sigma",
               *draw(st.lists(st.sampled_from(["direction", "m_add", "M", "note"]),
                              unique=True))]
    rows = []
    for _ in range(draw(st.integers(1, 12))):
        quantity = draw(st.sampled_from(list(QUANTITIES)))
        needs = set(QUANTITIES[quantity].required)
        cells = []
        for name in columns:
            if name == "quantity":
                cells.append(quantity)
            elif name in ("f", "a"):
                cells.append(draw(GOOD_NUMBERS) if name in needs else "")
            elif name in ("value", "sigma"):
                cells.append(draw(GOOD_NUMBERS))
            elif name == "direction":
                cells.append("forward" if quantity == "threshold" else "")
            else:
                cells.append("")
        rows.append(cells)
    for _ in range(draw(st.integers(0, 4))):  # corrupt cells
        row = draw(st.integers(0, len(rows) - 1))
        column = draw(st.integers(0, len(columns) - 1))
        rows[row][column] = draw(st.one_of(st.sampled_from(BAD_CELLS),
                                           st.text(max_size=12)))
    if draw(st.integers(0, 3)) == 0:  # a missing or an extra cell
        row = draw(st.sampled_from(rows))
        row.append("1") if draw(st.booleans()) else row.pop()
    end = draw(st.sampled_from(["\n", "\r\n", "\n\n", "\n# note\n"]))
    text = ",".join(columns) + end + end.join(",".join(cells) for cells in rows)
    text += draw(st.sampled_from(["", "\n", "\r\n"]))
    if draw(st.booleans()):
        text = "# lab book\n" + text
    data = text.encode("utf-8", "surrogatepass")
    if draw(st.integers(0, 9)) == 0:
        data = b"\xef\xbb\xbf" + data
    if draw(st.integers(0, 9)) == 0:
        data = data[:draw(st.integers(0, len(data)))]
    return data


# ---------------------------------------------------------------------------
# The tier


@pytest.mark.fuzz
@fuzz_settings(CASES)
@given(data=st.one_of(st.binary(max_size=400), RANDOM_TEXT.map(str.encode)))
def test_random_bytes_are_read_or_refused_in_one_message(data: bytes, tmp_path: Path
                                                         ) -> None:
    judge(tmp_path / "random.csv", data)


@pytest.mark.fuzz
@fuzz_settings(CASES)
@given(data=corrupted_files())
def test_corrupted_cells_are_refused_naming_the_file_and_line(data: bytes, tmp_path: Path
                                                              ) -> None:
    judge(tmp_path / "corrupted.csv", data)


@pytest.mark.fuzz
def test_both_outcomes_are_common_and_recorded() -> None:
    """Runs after the two generators (file order): a tier that only ever refused, or
    only ever accepted, would prove little."""
    tried = OUTCOMES["refused"] + OUTCOMES["accepted"]
    if tried < 2 * CASES:
        pytest.skip("the generators did not run in this session")
    assert OUTCOMES["refused"] >= CASES // 2 and OUTCOMES["accepted"] >= CASES // 20, OUTCOMES
    record("tests/fuzz/test_measurement_files.py",
           "measurement files: random bytes and corrupted cells, read or refused in one "
           "message", cases=tried, faults=tried)

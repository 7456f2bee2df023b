"""A seeded slice of the measurement-file fuzz tier (tests/fuzz/test_measurement_files.py)
in the unit tier: the same generators and judge, a hundred cases each (a second)."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from tests.fuzz.test_measurement_files import (
    RANDOM_TEXT,
    corrupted_files,
    fuzz_settings,
    judge,
)

SLICE = 100


@fuzz_settings(SLICE)
@given(data=st.one_of(st.binary(max_size=400), RANDOM_TEXT.map(str.encode)))
def test_random_bytes_slice(data: bytes, tmp_path: Path) -> None:
    judge(tmp_path / "random.csv", data)


@fuzz_settings(SLICE)
@given(data=corrupted_files())
def test_corrupted_cells_slice(data: bytes, tmp_path: Path) -> None:
    judge(tmp_path / "corrupted.csv", data)

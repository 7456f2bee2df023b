"""The bit-for-bit comparison of result folders that refactors are checked with."""

from __future__ import annotations

import numpy as np
import xarray as xr

from tests.support.compare_results import differences, main


def write(path, velocity, units="m s-1"):
    xr.Dataset({"velocity": (("f",), np.asarray(velocity, dtype=np.float64),
                             {"units": units})},
               coords={"f": ("f", [13.0, 14.0], {"units": "Hz"})}).to_netcdf(path)


def test_identical_files_compare_equal_and_exit_zero(tmp_path, capsys):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    write(tmp_path / "a" / "x.nc", [0.1, np.nan])
    write(tmp_path / "b" / "x.nc", [0.1, np.nan])
    assert main([str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    assert "1 of 1 files identical" in capsys.readouterr().out


def test_one_ulp_a_signed_zero_and_units_are_differences(tmp_path):
    write(tmp_path / "a.nc", [0.1, 0.0])
    write(tmp_path / "ulp.nc", [np.nextafter(0.1, 1.0), 0.0])
    write(tmp_path / "zero.nc", [0.1, -0.0])
    write(tmp_path / "units.nc", [0.1, 0.0], units="mm s-1")
    assert differences(tmp_path / "a.nc", tmp_path / "ulp.nc") == ["velocity: values differ"]
    assert differences(tmp_path / "a.nc", tmp_path / "zero.nc") == ["velocity: values differ"]
    assert differences(tmp_path / "a.nc", tmp_path / "units.nc") == [
        "velocity: units 'm s-1' before, 'mm s-1' after"]


def test_a_missing_file_fails(tmp_path, capsys):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    write(tmp_path / "a" / "x.nc", [0.1, 0.2])
    assert main([str(tmp_path / "a"), str(tmp_path / "b")]) == 1
    assert "MISSING   x.nc" in capsys.readouterr().out

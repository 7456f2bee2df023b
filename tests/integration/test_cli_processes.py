"""The ``study`` command as processes: the installed console script, and a reader of its
output that goes away (the in-process command line is tests/unit/test_cli.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tests.unit.test_cli import good_file, output, spec, workspace  # noqa: F401 (fixtures)


def test_console_script_is_installed(good_file: Path, tmp_path: Path) -> None:  # noqa: F811
    script = Path(sys.executable).with_name("study")
    assert script.is_file()
    bad = tmp_path / "bad.nc"
    bad.write_text("not a netCDF file\n")
    done = subprocess.run(
        [str(script), "validate", str(good_file), str(bad)],
        capture_output=True, text=True, timeout=120, check=False,
    )
    assert done.returncode == 1, done.stderr
    assert f"{good_file}: valid study result" in done.stdout
    assert f"{bad}: not a readable netCDF file" in done.stderr


def test_a_reader_that_goes_away_is_no_traceback(good_file: Path) -> None:  # noqa: F811
    """`study info FILE | head -c 1`: the pipe closes before everything is written."""
    import subprocess
    import sys

    reader = subprocess.Popen(["head", "-c", "1"], stdin=subprocess.PIPE,
                              stdout=subprocess.DEVNULL)
    # One summary fits in the pipe's buffer: write it until the pipe must break.
    script = ("import sys\nfrom study.cli import main\n"
              "for _ in range(2000):\n    status = main(['info', sys.argv[1]])\n"
              "    if status == 141:\n        break\n"
              "sys.exit(status)\n")
    writer = subprocess.run([sys.executable, "-c", script, str(good_file)],
                            stdout=reader.stdin, stderr=subprocess.PIPE, text=True,
                            timeout=300, check=False)
    reader.stdin.close()
    reader.wait(timeout=60)
    assert "Traceback" not in writer.stderr, writer.stderr
    assert writer.returncode == 141, writer.stderr

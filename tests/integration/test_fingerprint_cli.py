"""A result's staleness through the command line, in processes on a scratch copy of the
package: ``study list`` follows edits of computing modules only (the fingerprints
themselves are tests/unit/test_fingerprint.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from tests.unit.test_fingerprint import copy_package

TINY = """\
[study]
name = "tiny"
title = "Thresholds only, for the fingerprint test"
observables = ["thresholds"]

[structure]
f0 = 14.44   # Hz
Q = 17.5
alpha = 64.0 # degree
M = 0.08
cs = 0.25

[sweep]
f = { start = 10.0, stop = 20.0, num = 5 }  # Hz
"""


def test_study_list_follows_computing_edits_only(tmp_path: Path):
    root = copy_package(tmp_path / "copy")
    workflows, results = tmp_path / "workflows", tmp_path / "results"
    workflows.mkdir()
    results.mkdir()
    (workflows / "tiny.toml").write_text(TINY)
    env = {**os.environ, "PYTHONPATH": str(root.parent)}

    def study(*argv: str) -> str:
        done = subprocess.run([sys.executable, "-m", "study.cli", *argv], cwd=tmp_path,
                              env=env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        return done.stdout

    def state() -> str:
        return study("list", "--workflows", str(workflows), "--results", str(results))

    study("run", str(workflows / "tiny.toml"), "-o", str(results / "tiny.nc"),
          "--workers", "1", "--no-progress")
    assert ": up to date" in state()
    forces = root / "model" / "forces.py"
    original = forces.read_bytes()
    forces.write_bytes(original + b"\n# edited\n")
    assert ": out of date" in state()
    forces.write_bytes(original)
    (root / "figures" / "common.py").write_bytes(
        (root / "figures" / "common.py").read_bytes() + b"\n# edited\n")
    assert ": up to date" in state()

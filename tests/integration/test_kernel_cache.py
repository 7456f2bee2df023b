"""Numba's on-disk cache of the kernels follows edits of any kernel file.

Numba stamps a cached function with its own source file only; a kernel that calls a
kernel of another file would keep the callee's old machine code after the callee's
file changed. ``study.kernels`` stamps every kernel's cache entry with a hash of all
kernel sources: here a caller in one file and a callee in another, both
``cache=True``, are run in fresh processes before and after an edit of the callee only.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from tests.unit.test_fingerprint import copy_package

CALLEE = """\
from numba import njit


@njit(cache=True)
def offset(x):
    return x + {value}
"""

CALLER = """\
from numba import njit

from study.kernels.zz_callee import offset


@njit(cache=True)
def doubled_offset(x):
    return 2.0 * offset(x)
"""

PROBE = "from study.kernels.zz_caller import doubled_offset; print(doubled_offset(1.0))"


def run_probe(root: Path) -> float:
    env = {**os.environ, "PYTHONPATH": str(root)}
    env.pop("NUMBA_CACHE_DIR", None)
    done = subprocess.run([sys.executable, "-c", PROBE], cwd=root, env=env,
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    return float(done.stdout)


def test_an_edit_of_a_callee_file_recompiles_its_cached_callers(tmp_path):
    kernels = copy_package(tmp_path) / "kernels"
    (kernels / "zz_callee.py").write_text(CALLEE.format(value="1.0"))
    (kernels / "zz_caller.py").write_text(CALLER)
    assert run_probe(tmp_path) == 4.0
    assert run_probe(tmp_path) == 4.0          # from the cache
    assert any((kernels / "__pycache__").glob("zz_caller.*.nbi"))
    (kernels / "zz_callee.py").write_text(CALLEE.format(value="2.0"))
    assert run_probe(tmp_path) == 6.0          # the caller's cached code was not reused

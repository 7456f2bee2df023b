"""Broadcast drives reach the kernels as copies, also on a kernel's first call.

numba types the arguments of a kernel's first call in a process in Python, which reads
the writeability of a broadcast view of numpy's and gets its FutureWarning (an error
where warnings are). ``steady_velocity`` and ``steady_state`` copy broadcast drives; a
fresh interpreter under ``-W error`` whose first calls of each kernel (one-way velocity,
one-way steady state, two-way lift-off decisions and orbit) get broadcast drives checks
it, and that the values are the scalar call's.
"""

from __future__ import annotations

import subprocess
import sys

#: A fresh interpreter whose first call of each kernel gets broadcast drives.
FIRST_CALLS_BROADCAST = """
import warnings
warnings.simplefilter("error")
import numpy as np
import study
from study.model.paper import paper_structure
s = paper_structure()
for coupling in ("one-way", "two-way"):
    v, status = study.steady_velocity(s, np.array([14.5]), 8.0, coupling=coupling)
    state = study.steady_state(s, 14.5, np.array([[8.0, 8.0]]), coupling=coupling)
    one = study.steady_state(s, 14.5, 8.0, coupling=coupling)
    assert v.shape == (1,) and state.velocity.shape == (1, 2)
    assert v[0] == one.velocity and np.all(state.velocity == one.velocity)
    assert study.steady_state(s, np.array([]), 8.0, coupling=coupling).velocity.shape == (0,)
"""


def test_broadcast_drives_reach_numba_as_copies():
    # numba types the arguments of a kernel's first call in Python, which reads the
    # writeability of a broadcast view: numpy's FutureWarning (an error here).
    result = subprocess.run([sys.executable, "-c", FIRST_CALLS_BROADCAST],
                            capture_output=True, text=True, check=False, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]

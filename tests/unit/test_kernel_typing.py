"""Calls between kernels are typed by type, not by constant value (study/kernels/__init__).

Numba compiles a callee again for every constant a caller passes it (a literal type
per value); the package's kernels are typed by their arguments' types instead, so a
flag passed as ``True`` in one caller and ``False`` in another shares one compiled
specialisation. Calls into numba code of any other package keep numba's own typing.
"""

from __future__ import annotations

import numba
import numpy as np
from numba.core import types

import study.kernels  # noqa: F401  (installs the typing of calls between kernels)

#: A callee and a caller that passes it both constants.
SOURCE = """
@numba.njit
def callee(x, flag):
    return x + 1.0 if flag else x - 1.0


@numba.njit
def caller(x):
    return callee(x, True) + callee(x, False)
"""


def _pair(module: str):
    """The callee and the caller of SOURCE, defined as if in ``module``."""
    namespace = {"__name__": module, "numba": numba}
    exec(compile(SOURCE, f"<{module}>", "exec"), namespace)
    return namespace["callee"], namespace["caller"]


def test_a_kernel_called_with_both_constants_is_compiled_once_for_bool():
    callee, caller = _pair("study.kernels.probe")
    assert caller(np.float64(2.0)) == 4.0  # (2 + 1) + (2 - 1): the flags act at runtime
    assert callee.signatures == [(types.float64, types.boolean)]


def test_numba_code_of_other_packages_keeps_its_literal_typing():
    callee, caller = _pair("elsewhere.probe")
    assert caller(np.float64(2.0)) == 4.0
    assert sorted(map(str, callee.signatures)) == [
        "(float64, Literal[bool](False))", "(float64, Literal[bool](True))"]

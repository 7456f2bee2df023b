"""Which cases of a parametrized test run in the default tier (``make test``).

The default tier covers every module and capability with its headline checks, within 6
minutes on a fresh clone of a 2-core machine (issue 46); the slow tier
(``make test-slow``, run by CI) runs everything else. A family of cases keeps its first
case, or the first case of each group, in the default tier; the other cases are marked
``slow``, so none is dropped and each keeps its id.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

import pytest

#: The type of ``pytest.param(...)`` (pytest does not export it by a public name).
ParameterSet = type(pytest.param())


def headline(cases: Iterable[Any], *, per: Callable[..., Any] | None = None,
             keep: int = 1) -> list[ParameterSet]:
    """The cases of a ``parametrize``: the first ``keep`` (of each group ``per(*values)``
    when given) in the default tier, the others marked ``slow``.

    Parameters
    ----------
    cases : iterable
        The cases as ``parametrize`` takes them: a value per case for one argument name,
        a tuple of values for several, or ``pytest.param`` objects (their own marks and
        id are kept). A tuple is unpacked: pass ``pytest.param(value)`` for a single
        argument whose value is a tuple.
    per : callable, optional
        A case's group from its values; the first ``keep`` cases of each group stay in
        the default tier (e.g. one case per figure of a figure-by-dimension family).
    keep : int
        How many cases of each group stay in the default tier.
    """
    seen: dict[Any, int] = {}
    out = []
    for case in cases:
        if not isinstance(case, ParameterSet):
            case = pytest.param(*case) if isinstance(case, tuple) else pytest.param(case)
        if any(getattr(mark, "name", None) == "slow" for mark in case.marks):
            out.append(case)  # slow already: it keeps no place in the default tier
            continue
        group = per(*case.values) if per is not None else None
        seen[group] = seen.get(group, 0) + 1
        if seen[group] > keep:
            case = pytest.param(*case.values, id=case.id,
                                marks=(*case.marks, pytest.mark.slow))
        out.append(case)
    return out

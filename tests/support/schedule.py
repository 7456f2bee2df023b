"""The order in which pytest-xdist hands out test modules: the longest first.

``make fuzz`` runs its modules a whole module per worker (``--dist loadfile``, in
collection order with ``--no-loadscope-reorder``): a long module handed out last keeps
one worker busy after the other has finished. :data:`LONGEST_FIRST` moves the longest
modules to the front of the collection (the others keep their order, and so does every
module's own order of tests), so that they start at once on separate workers.
"""

from __future__ import annotations

import pytest

#: Test modules moved to the front of the collection, longest first (measured on 2
#: cores, December 2026: the mutated specs 80-90 s, the corrupted result files 58-62 s;
#: the other fuzz modules 15-28 s each).
LONGEST_FIRST = ("tests/fuzz/test_spec_runs.py", "tests/fuzz/test_corrupted_results.py")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Move the items of :data:`LONGEST_FIRST` to the front, in its order (stable)."""
    rank = {module: place for place, module in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.nodeid.split("::")[0], len(rank)))

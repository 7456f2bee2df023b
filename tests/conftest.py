"""Shared fixtures: the paper's structure (Fig. 1-2). Plugins: numba's compilations
counted in each test process and said at the end (:mod:`tests.support.numba_compiles`);
before pytest-xdist's workers start, the kernels most tests use compiled once into
numba's on-disk cache or loaded from it (:mod:`tests.support.warm_kernels`), so that
the workers do not each compile them again; the longest modules first in the
collection, so that pytest-xdist starts them at once (:mod:`tests.support.schedule`)."""

from __future__ import annotations

import signal
import sys
import threading

import pytest

import study
from study.model.paper import paper_structure as papers_structure
from tests.support.numba_compiles import (  # noqa: F401 (hooks)
    pytest_configure,
    pytest_sessionfinish,
    pytest_terminal_summary,
    pytest_testnodedown,
    pytest_unconfigure,
)
from tests.support.schedule import pytest_collection_modifyitems  # noqa: F401 (a hook)
from tests.support.warm_kernels import pytest_sessionstart  # noqa: F401 (a hook)


@pytest.fixture(scope="session")
def paper_structure() -> study.Structure:
    """The structure of the paper's Fig. 1-2 (:data:`study.model.paper.PAPER_STRUCTURE`)."""
    return papers_structure()


@pytest.fixture(autouse=True)
def _close_figures():
    """Every figure a test drew is closed after it (as matplotlib's own tests do): a
    worker that runs many figure tests would otherwise pass pyplot's 20 open figures
    and its warning, an error under ``filterwarnings = error``, fails the next test."""
    yield
    pyplot = sys.modules.get("matplotlib.pyplot")
    if pyplot is not None:
        pyplot.close("all")


@pytest.fixture
def python_sigint():
    """SIGINT with Python's own handler (a test runner's worker may ignore it), in the
    main thread (pytest-xdist runs tests there), where signal handlers run: for the
    tests of what Ctrl-C keeps."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers run in the main thread only")
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)

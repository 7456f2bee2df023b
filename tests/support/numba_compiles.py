"""Count numba's compilations in each test process; say them at the end of the run.

The kernels are ``cache=True``: a kernel compiled once, by any process, is loaded from
numba's on-disk cache by the next (``study/kernels/__pycache__`` of the source tree, or
``NUMBA_CACHE_DIR``). A test run that compiles in its workers what an earlier run or the
warm-up (:mod:`tests.support.warm_kernels`) already compiled would show it here: the
summary at the end of ``pytest`` names, for each process, how many kernels it compiled,
the seconds it spent compiling and the kernels that took longest.

numba announces each compilation as a ``numba:compile`` event (a kernel loaded from the
cache raises none); nested compilations (a kernel compiling the kernels it calls) are
counted once, at the outermost.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

import pytest
from numba.core import event

#: How many of a process's longest compilations the summary names.
LONGEST = 5


@dataclass
class Compiles:
    """The outermost compilations of one process: count, seconds and the longest."""

    count: int = 0
    seconds: float = 0.0
    longest: list[tuple[float, str]] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {"count": self.count, "seconds": self.seconds, "longest": self.longest}


class CompileCounter(event.Listener):
    """A ``numba:compile`` listener adding up this process's outermost compilations."""

    def __init__(self) -> None:
        self.compiles = Compiles()
        self._depth = 0
        self._began = 0.0
        self._lock = threading.Lock()

    def on_start(self, ev: event.Event) -> None:
        with self._lock:
            self._depth += 1
            if self._depth == 1:
                self._began = time.perf_counter()

    def on_end(self, ev: event.Event) -> None:
        with self._lock:
            self._depth -= 1
            if self._depth:
                return
            seconds = time.perf_counter() - self._began
            dispatcher = (ev.data or {}).get("dispatcher")
            name = getattr(getattr(dispatcher, "py_func", None), "__qualname__", "?")
            module = getattr(getattr(dispatcher, "py_func", None), "__module__", "")
            c = self.compiles
            c.count += 1
            c.seconds += seconds
            c.longest = sorted([*c.longest, (seconds, f"{module}.{name}")],
                               reverse=True)[:LONGEST]


COUNTER = pytest.StashKey[CompileCounter]()
WORKERS = pytest.StashKey[dict]()


def pytest_configure(config: pytest.Config) -> None:
    counter = CompileCounter()
    event.register("numba:compile", counter)
    config.stash[COUNTER] = counter
    config.stash[WORKERS] = {}


def pytest_unconfigure(config: pytest.Config) -> None:
    counter = config.stash.get(COUNTER, None)
    if counter is not None:
        event.unregister("numba:compile", counter)


def pytest_sessionfinish(session: pytest.Session) -> None:
    workeroutput = getattr(session.config, "workeroutput", None)
    if workeroutput is not None:  # an xdist worker: the controller says it
        workeroutput["numba_compiles"] = session.config.stash[COUNTER].compiles.as_dict()


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error) -> None:
    output = getattr(node, "workeroutput", {}).get("numba_compiles")
    if output is not None:
        node.config.stash[WORKERS][node.gateway.id] = output


def pytest_terminal_summary(terminalreporter, config: pytest.Config) -> None:
    if getattr(config, "workeroutput", None) is not None:
        return
    processes = {"this process": config.stash[COUNTER].compiles.as_dict(),
                 **dict(sorted(config.stash[WORKERS].items()))}
    lines = []
    for name, c in processes.items():
        if not c["count"] and name == "this process" and len(processes) > 1:
            continue
        longest = ", ".join(f"{what.rsplit('.', 1)[-1]} {s:.0f} s"
                            for s, what in c["longest"][:3])
        lines.append(f"{name}: {c['count']} compiled in {c['seconds']:.0f} s"
                     + (f" (longest: {longest})" if longest else ""))
    terminalreporter.write_sep("-", "numba compilations (0 when every kernel came "
                                    "from the on-disk cache)")
    for line in lines:
        terminalreporter.write_line(line)

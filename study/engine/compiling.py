"""Say so while numba compiles the solver kernels.

The kernels are compiled on their first call after an install or a change of their
code (minutes on a busy machine), then loaded from numba's cache on disk (seconds).
A run that compiles would otherwise sit at 0 % with nothing to say why. numba
announces every compilation as a ``numba:compile`` event (:mod:`numba.core.event`; a
kernel loaded from its cache raises none): while :func:`compile_notices` is active, the
first one says a line and the progress shows "compiling" until the compiler is done.
Compilations on the workers of a dask cluster happen in other processes and are not
seen here.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

from numba.core import event

from study.engine.progress import Progress

__all__ = ["COMPILING", "CompileWatch", "compile_notices"]

#: What the progress shows while the kernels compile.
COMPILING = "compiling the solver kernels"


class CompileWatch(event.Listener):
    """Follows numba's compilations for one :class:`~study.engine.progress.Progress`.

    Attributes
    ----------
    seconds : float
        Wall time spent compiling so far [s] (nested compilations counted once).
    compilations : int
        Outermost compilations seen.
    """

    def __init__(self, progress: Progress) -> None:
        self.progress = progress
        self.seconds = 0.0
        self.compilations = 0
        self._depth = 0
        self._began = 0.0
        self._lock = threading.Lock()

    def on_start(self, event: event.Event) -> None:
        with self._lock:
            self._depth += 1
            if self._depth > 1:
                return
            self._began = time.perf_counter()
            first = self.compilations == 0
            self.compilations += 1
        if first:
            self.progress.say(f"{COMPILING} (the first run after an install or a change of "
                              "the code; numba caches them on disk for the next runs)...")
        self.progress.set_phase(COMPILING)

    def on_end(self, event: event.Event) -> None:
        with self._lock:
            self._depth -= 1
            if self._depth > 0:
                return
            self.seconds += time.perf_counter() - self._began
        self.progress.set_phase(None)


@contextmanager
def compile_notices(progress: Progress) -> Iterator[CompileWatch]:
    """Show numba's compilations on ``progress`` while the block runs; at the end, one
    line says how long they took (if any happened)."""
    watch = CompileWatch(progress)
    event.register("numba:compile", watch)
    try:
        yield watch
    finally:
        event.unregister("numba:compile", watch)
        progress.set_phase(None)
        if watch.compilations:
            progress.say(f"compiled the solver kernels in {watch.seconds:.0f} s "
                         "(cached on disk: the next runs load them in seconds)")

"""Ctrl-C during a run: finish what is running, keep it, and say what was kept.

Python turns SIGINT into a :class:`KeyboardInterrupt` raised wherever the main thread
happens to be, while the worker threads go on computing (numba kernels cannot be
stopped), and the interpreter then waits for them before it exits: work finished on a
thread but not yet kept was lost, and a long chunk held the exit for as long as it ran.
While :func:`stop_requests` is active, a first SIGINT only sets an event: the runner
stops handing out work, waits for the units running (about a second each), keeps their
values and raises :class:`RunInterrupted`, which says what was kept. A second SIGINT
raises :class:`KeyboardInterrupt` at once (the units still running are then dropped,
and ``study run`` exits without waiting for them: :func:`computing_threads`).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from study.engine.executors import THREAD_PREFIX

__all__ = ["RunInterrupted", "computing_threads", "stop_requests"]

# How often the thread that says a run is stopping looks at the request [s].
_TELL_POLL = 0.1


class RunInterrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C (SIGINT); the message says what was kept.

    A :class:`KeyboardInterrupt`, so that whatever catches one (a notebook, the CLI)
    treats it as one.

    Attributes
    ----------
    kept, points : int
        Drive points kept for the next run (computed in this run or found kept), and the
        study's points in all.
    computed : int
        Of ``kept``, those computed in this run.
    """

    def __init__(self, message: str, kept: int = 0, points: int = 0, computed: int = 0):
        super().__init__(message)
        self.kept = kept
        self.points = points
        self.computed = computed


@contextmanager
def stop_requests(on_request: Callable[[], None] | None = None
                  ) -> Iterator[threading.Event]:
    """An event that a first SIGINT sets instead of raising, while the block runs.

    Only in the main thread and where SIGINT has Python's default handler (a program
    that handles SIGINT itself, or ignores it, keeps its own way); elsewhere the event is
    never set by a signal. A second SIGINT raises :class:`KeyboardInterrupt`. The
    previous handler is restored at the end.

    Parameters
    ----------
    on_request : callable, optional
        Called once, on a thread of its own (never inside the signal handler, which may
        interrupt the main thread holding a lock), when the event is first set: to say
        that the run is stopping.
    """
    requested = threading.Event()
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield requested
        return

    def on_interrupt(number, frame) -> None:
        if requested.is_set():
            raise KeyboardInterrupt
        requested.set()

    ended = threading.Event()

    def tell() -> None:
        while not ended.is_set():
            if requested.wait(_TELL_POLL):
                if not ended.is_set():
                    on_request()
                return

    teller = None
    if on_request is not None:
        teller = threading.Thread(target=tell, name="study-stopping", daemon=True)
        teller.start()
    previous = signal.signal(signal.SIGINT, on_interrupt)
    try:
        yield requested
    finally:
        signal.signal(signal.SIGINT, previous)
        ended.set()
        if teller is not None:
            teller.join()


def computing_threads() -> list[threading.Thread]:
    """The local executor's threads still alive (computing after a second interrupt):
    the interpreter waits for them before it exits."""
    return [thread for thread in threading.enumerate()
            if thread.name.startswith(f"{THREAD_PREFIX}_") and thread.is_alive()]

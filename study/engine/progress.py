"""Progress of a run, with rate and time left (tqdm), on a terminal or in a log.

On a terminal tqdm draws its bar. When stderr is not a terminal (``make > log``,
CI), a plain line is printed at least every 10 % of the work or every 30 s,
whichever comes first, so a long run is never silent. While :meth:`Progress.running`
is active, a heartbeat keeps the elapsed time moving between updates (a scene that
integrates for a minute, or a first chunk that compiles the solver). A phase that makes
no progress of its own says what it is (:meth:`Progress.set_phase`: "compiling the
solver kernels", :mod:`study.engine.compiling`) in place of the time left, and a line
(:meth:`Progress.say`) when it begins. Everything goes to stderr; with progress off
(``--no-progress``) nothing is written.

The time left is shown only once it means something (:class:`TimeLeft`): after
:data:`ETA_MIN_FRACTION` of the work and :data:`ETA_MIN_SECONDS`, estimated from the
throughput of computed work since the first update, so neither the compile time of the
first chunk nor reused values that cost nothing count as a rate.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TextIO

from tqdm import tqdm

__all__ = ["ETA_MIN_FRACTION", "ETA_MIN_SECONDS", "Progress", "TimeLeft"]

#: A log line at least this often [s] ...
LOG_INTERVAL = 30.0
#: ... and at least every this fraction of the work.
LOG_FRACTION = 0.1
#: No time left is shown before this fraction of the work is done ...
ETA_MIN_FRACTION = 0.1
#: ... nor before this long [s] since the start.
ETA_MIN_SECONDS = 5.0
#: The bar's heartbeat on a terminal [s].
TERMINAL_INTERVAL = 1.0


def _count(value: float) -> str:
    """A count as people write it: 7, 2.5, 1.00k."""
    if value >= 1000:
        return tqdm.format_sizeof(value)
    return f"{value:.0f}" if float(value).is_integer() else f"{value:.3g}"


class TimeLeft:
    """When the time left of a run is worth showing, and how long it is.

    The first update ends the first piece of work, which carries the solver's compile
    time: it sets the baseline, and the rate is the work computed after it over the
    time since it. Reused work (values kept from an earlier run) counts as done but
    not towards the rate.

    Parameters
    ----------
    total : float
        Work of the run (points, drive seconds, runs).
    start : float
        The clock's reading at the start [s].
    """

    def __init__(self, total: float, start: float) -> None:
        self.total = float(total)
        self.start = start
        self.done = 0.0
        self.computed = 0.0
        self._baseline: tuple[float, float] | None = None

    def add(self, now: float, work: float, computed: float | None = None) -> None:
        """``work`` more done at clock reading ``now``, ``computed`` of it computed
        (default: all of it)."""
        self.done += work
        self.computed += work if computed is None else computed
        if self._baseline is None:
            self._baseline = (now, self.computed)

    def rate(self, now: float) -> float | None:
        """Computed work per second since the first update; None before there is one."""
        if self._baseline is None:
            return None
        then, computed = self._baseline
        if now <= then or self.computed <= computed:
            return None
        return (self.computed - computed) / (now - then)

    def seconds(self, now: float) -> float | None:
        """Seconds left, or None while not yet meaningful (too little work done, too
        little time passed, or no rate after the first update)."""
        if self.total <= 0 or self.done >= self.total:
            return 0.0
        if self.done < ETA_MIN_FRACTION * self.total or now - self.start < ETA_MIN_SECONDS:
            return None
        rate = self.rate(now)
        return None if rate is None else (self.total - self.done) / rate


class Progress:
    """Count work done out of ``total``.

    Parameters
    ----------
    total : float
        Work to do in this run (points by default).
    label : str
        Shown before the counts (the study's name).
    enabled : bool or None
        ``True``/``False`` forces it on/off; ``None``: on, as a bar on a terminal and
        as log lines otherwise.
    stream : file, optional
        Where to write (default ``sys.stderr``).
    unit : str
        What the work is counted in (``"pt"``: drive points).
    clock : callable, optional
        Seconds, monotonic (default :func:`time.perf_counter`; tests give a fake one).
    finished : str
        What is shown once the work is all done: ``"done"``, or what comes next where
        this is one phase of a run (``"map done; frontier next"``), so that "done" is
        said only when the result is.
    """

    def __init__(self, total: float, label: str, enabled: bool | None = None,
                 stream: TextIO | None = None, unit: str = "pt",
                 clock: Callable[[], float] = time.perf_counter,
                 finished: str = "done") -> None:
        self.finished = finished
        self.stream = sys.stderr if stream is None else stream
        self.total = max(total, 0)
        self.label = label
        self.unit = unit
        self.clock = clock
        self.enabled = (enabled is not False) and self.total > 0
        #: Lines (:meth:`say`) are shown unless progress is off.
        self.quiet = enabled is False
        terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self.bar: tqdm | None = None
        if self.enabled and terminal:
            # The bar's own time left would count the compile time: ours replaces it.
            self.bar = tqdm(total=self.total, desc=label, unit=unit, unit_scale=True,
                            file=self.stream, dynamic_ncols=True, leave=True,
                            bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} {unit} "
                                       "[{elapsed}{postfix}]")
        self.done = 0
        self.start = clock()
        self.time_left = TimeLeft(self.total, self.start)
        self._last_time = self.start
        self._last_fraction = 0.0
        self._phase: str | None = None
        self._lock = threading.Lock()

    def set_phase(self, phase: str | None) -> None:
        """Show ``phase`` (what the work is doing while it makes no progress of its own:
        ``"compiling the solver kernels"``) in place of the time left until it is set to
        None; the bar shows it at once, a log line at the next heartbeat."""
        with self._lock:
            if phase == self._phase:
                return
            self._phase = phase
            if self.enabled and self.bar is not None:
                self.bar.set_postfix_str(self._left(self.clock()), refresh=True)

    def update(self, work: float, computed: float | None = None) -> None:
        """``work`` more is done, ``computed`` of it computed in this run (default: all;
        the rest was reused and does not count towards the rate)."""
        with self._lock:
            now = self.clock()
            self.done += work
            self.time_left.add(now, work, computed)
            if not self.enabled:
                return
            if self.bar is not None:
                self.bar.set_postfix_str(self._left(now), refresh=False)
                self.bar.update(work)
                return
            fraction = self.done / self.total
            if (fraction - self._last_fraction >= LOG_FRACTION - 1e-12
                    or now - self._last_time >= LOG_INTERVAL or self.done >= self.total):
                self._last_fraction = fraction
                self._write(now)

    def say(self, line: str) -> None:
        """Show one line of what the work is doing (``study: LINE``), above the bar if one
        is drawn; nothing when progress is off."""
        if self.quiet:
            return
        if self.bar is not None:
            self.bar.write(f"study: {line}", file=self.stream)
        else:
            print(f"study: {line}", file=self.stream, flush=True)

    def line(self, now: float | None = None) -> str:
        """The log line: share done, counts, elapsed, rate and time left (if known)."""
        now = self.clock() if now is None else now
        fraction = self.done / self.total if self.total else 1.0
        rate = self.time_left.rate(now)
        if rate is None and self.done >= self.total and now > self.start:
            rate = self.done / (now - self.start)  # one update: the whole run's rate
        rate_text = "?" if rate is None else tqdm.format_sizeof(rate)
        return (f"{self.label}: {100 * fraction:3.0f}% {_count(self.done)}/"
                f"{_count(self.total)} {self.unit}, "
                f"{tqdm.format_interval(now - self.start)} elapsed, {rate_text} {self.unit}/s, "
                f"{self._left(now)}")

    def _left(self, now: float) -> str:
        if self.done >= self.total:
            return self.finished
        if self._phase is not None:
            return self._phase
        seconds = self.time_left.seconds(now)
        if seconds is None:
            return "time left: estimating"
        return f"about {tqdm.format_interval(seconds)} left"

    def _write(self, now: float) -> None:
        self._last_time = now
        self.stream.write(self.line(now) + "\n")
        self.stream.flush()

    def beat(self) -> None:
        """Show the elapsed time now: the bar refreshes; a log line is written when
        :data:`LOG_INTERVAL` has passed since the last."""
        with self._lock:
            if not self.enabled:
                return
            now = self.clock()
            if self.bar is not None:
                self.bar.set_postfix_str(self._left(now), refresh=False)
                self.bar.refresh()
            elif now - self._last_time >= LOG_INTERVAL:
                self._write(now)

    @contextmanager
    def running(self) -> Iterator[Progress]:
        """A heartbeat (:meth:`beat`) in a background thread while the work runs: every
        second on a terminal, every :data:`LOG_INTERVAL` in a log."""
        if not self.enabled:
            yield self
            return
        stop = threading.Event()
        interval = TERMINAL_INTERVAL if self.bar is not None else LOG_INTERVAL

        def heartbeat() -> None:
            while not stop.wait(interval):
                self.beat()

        thread = threading.Thread(target=heartbeat, name="study-progress", daemon=True)
        thread.start()
        try:
            yield self
        finally:
            stop.set()
            thread.join()

    def close(self) -> None:
        """End the bar (a no-op for log lines)."""
        with self._lock:
            if self.bar is not None:
                self.bar.close()
                self.bar = None

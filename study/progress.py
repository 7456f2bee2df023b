"""Progress of a run, with rate and time left (tqdm), on a terminal or in a log.

On a terminal tqdm draws its bar. When stderr is not a terminal (``make > log``,
CI), a plain line is printed at least every 10 % of the work or every 30 s,
whichever comes first, so a long run is never silent.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from tqdm import tqdm

__all__ = ["Progress"]

#: A log line at least this often [s] ...
LOG_INTERVAL = 30.0
#: ... and at least every this fraction of the work.
LOG_FRACTION = 0.1


class Progress:
    """Count points done out of ``total``.

    Parameters
    ----------
    total : int
        Points to compute in this run.
    label : str
        Shown before the counts (the study's name).
    enabled : bool or None
        ``True``/``False`` forces it on/off; ``None``: on, as a bar on a terminal and
        as log lines otherwise.
    stream : file, optional
        Where to write (default ``sys.stderr``).
    """

    def __init__(self, total: int, label: str, enabled: bool | None = None,
                 stream: TextIO | None = None) -> None:
        self.stream = sys.stderr if stream is None else stream
        self.total = max(int(total), 0)
        self.label = label
        self.enabled = (enabled is not False) and self.total > 0
        terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self.bar: tqdm | None = None
        if self.enabled and terminal:
            self.bar = tqdm(total=self.total, desc=label, unit="pt", unit_scale=True,
                            file=self.stream, dynamic_ncols=True, leave=True)
        self.done = 0
        self.start = time.perf_counter()
        self._last_time = self.start
        self._last_fraction = 0.0

    def update(self, points: int) -> None:
        """``points`` more are done."""
        self.done += points
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(points)
            return
        now = time.perf_counter()
        fraction = self.done / self.total
        if (fraction - self._last_fraction >= LOG_FRACTION - 1e-12
                or now - self._last_time >= LOG_INTERVAL or self.done >= self.total):
            self._last_time, self._last_fraction = now, fraction
            line = tqdm.format_meter(self.done, self.total, now - self.start,
                                     prefix=self.label, unit="pt", unit_scale=True,
                                     ncols=100, ascii=True)
            self.stream.write(line + "\n")
            self.stream.flush()

    def close(self) -> None:
        """End the bar (a no-op for log lines)."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None

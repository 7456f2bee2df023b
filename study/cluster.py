"""Where tasks run: threads of this process (placeholder until the dask executor lands)."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

__all__ = ["ClusterError", "Executor", "executor"]


class ClusterError(RuntimeError):
    """The cluster cannot run the study; one clear message."""


@dataclass
class Executor:
    """Runs tasks and yields their results as they complete."""

    name: str
    threads: int
    dashboard: str | None
    pool: ThreadPoolExecutor

    def run_unordered(self, function: Callable[[Any], Any], items: Iterable[Any], *,
                      label: str) -> Iterator[tuple[Any, Any]]:
        """Yield ``(item, function(item))`` as they complete; at most a few tasks per
        thread are in flight, so memory is bounded whatever the number of items."""
        window = 2 * self.threads + 2
        source = iter(items)
        running: dict[Future[Any], Any] = {}
        try:
            while True:
                while len(running) < window:
                    item = next(source, None)
                    if item is None:
                        break
                    running[self.pool.submit(function, item)] = item
                if not running:
                    return
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                for future in done:
                    yield running.pop(future), future.result()
        finally:
            for future in running:
                future.cancel()


@contextmanager
def executor(scheduler: str | None, threads: int | None, code_sha256: str,
             *, timeout: float = 30.0) -> Iterator[Executor]:
    """Threads of this process (``scheduler`` None)."""
    count = threads or os.cpu_count() or 1
    with ThreadPoolExecutor(max_workers=count) as pool:
        yield Executor("local", count, None, pool)

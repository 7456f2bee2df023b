"""Where chunks are computed: local threads, or the workers of a dask scheduler.

The runner hands a function and a list of items to an :class:`Executor` and
receives ``(item, result)`` pairs as they complete; once its ``stop`` event is set
(Ctrl-C, :mod:`study.engine.interrupts`) no item is started any more, and the items
running are still collected, so that their results are kept. Two kinds exist:

* local (no scheduler): a thread pool in this process. The numba kernels release
  the GIL, so threads run side by side; nothing is pickled, no port is opened
  and no dashboard is started.
* remote (a scheduler address): the workers of a running dask.distributed
  cluster. Before any work, every worker must import ``study`` and report the
  same code hash as this process; every task checks it again where it runs (a
  worker can join later). A worker that fails either check ends the run with a
  :class:`ClusterError` naming it, so results of different code are never mixed
  and a worker without ``study`` never leaves the run hanging.

The functions that run on the workers are built inside :func:`_worker_probe`
and :func:`_task_runner`: cloudpickle sends such local functions by value, so
a worker can load them even when it cannot import ``study``, and report why.
The task itself (function and item) travels as opaque bytes, unpickled only
inside that wrapper: neither the scheduler nor a worker needs ``study`` to
receive it, and a task that cannot be loaded is reported, not retried forever.
"""

from __future__ import annotations

import os
import threading
import time
import uuid
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["TASK_TIMEOUT", "THREAD_PREFIX", "ClusterError", "Executor", "check_address",
           "executor"]

#: The names of the local executor's threads begin with this (``study_0``, ...).
THREAD_PREFIX = "study"

#: Marks the end of the items (items themselves may be None).
_END = object()

# Digits of a code hash shown in messages: enough to tell two versions apart.
_SHOWN = 12

# Ask again how many threads the cluster has at most this often [s].
_REFRESH = 1.0

#: Default seconds a scheduler's workers may go without finishing a task while tasks
#: are in flight before the run ends (a frozen worker; see :func:`executor`).
TASK_TIMEOUT = 600.0

#: Seconds by which a worker's last heartbeat may trail the newest before a stalled run
#: names it as silent (heartbeats come about every second on a small cluster).
SILENT_HEARTBEAT = 2.0

# Sleep while no task has finished [s]: from the shortest, doubling up to the
# longest, so that quick tasks are collected at once and an idle wait costs nothing.
_POLL = (0.001, 0.02)

# How often a local run waiting for its threads looks at its stop event [s].
_STOP_POLL = 0.1


class ClusterError(RuntimeError):
    """The cluster cannot run this study: unreachable, empty, or running other code."""


class Executor(ABC):
    """Runs a function over items and yields the results as they complete.

    Attributes
    ----------
    name : str
        ``"local"`` or the scheduler address.
    threads : int
        Threads computing side by side (at the start of the run, for a cluster).
    dashboard : str or None
        Link to the scheduler's dashboard, if it has one.
    """

    name: str
    threads: int
    dashboard: str | None

    @abstractmethod
    def run_unordered(self, function: Callable[[Any], Any], items: Iterable[Any], *,
                      label: str, stop: threading.Event | None = None
                      ) -> Iterator[tuple[Any, Any]]:
        """Compute ``function(item)`` for every item; yield ``(item, result)`` pairs.

        Pairs come in the order the computations finish. At most a few items per
        thread are in flight, so finished results never pile up. When the
        consumer stops early (an exception, ``break`` or ``close()``), the work
        not yet started is cancelled.

        Parameters
        ----------
        function : callable
            Called with one item; on a cluster it must be picklable.
        items : iterable
            The work, one item per call.
        label : str
            Names the tasks (on the dashboard of a cluster).
        stop : threading.Event, optional
            Once set, no more items are drawn, the items not yet started are cancelled
            (locally; a cluster's in flight are all collected) and the pairs of those
            running are still yielded: then the iteration ends.

        Raises
        ------
        ClusterError
            A worker runs other code, cannot import ``study`` or load the task,
            or the cluster lost every worker.
        """


@contextmanager
def executor(scheduler: str | None, threads: int | None, code_sha256: str, *,
             timeout: float = 30.0, connect_timeout: float | None = None,
             task_timeout: float = TASK_TIMEOUT) -> Iterator[Executor]:
    """An executor for one run: local threads, or the workers of a dask scheduler.

    Parameters
    ----------
    scheduler : str or None
        Address of a dask.distributed scheduler (``tcp://host:port``); None for
        threads in this process.
    threads : int or None
        Threads of the local executor (default: one per core); ignored for a
        scheduler, whose workers decide.
    code_sha256 : str
        The code hash of this process: every worker must report the same.
    timeout : float
        Seconds to wait for a first worker, and without any worker during the run.
    connect_timeout : float, optional
        Seconds to wait for the scheduler to answer; default the shorter of ``timeout``
        and 10 s (an address that does not answer is most often a typo, and the
        message names it).
    task_timeout : float
        Seconds the scheduler's workers may go without finishing any task (or handing
        back a finished one) while tasks are in flight: then a worker is taken to be
        frozen and the run ends with a :class:`ClusterError` naming the workers
        holding the tasks. Finished work is kept; the next run resumes.

    Yields
    ------
    Executor

    Raises
    ------
    ClusterError
        The scheduler cannot be reached, has no worker within ``timeout``, or a
        worker cannot import ``study`` or runs code with another hash.
    """
    if scheduler is None:
        with _LocalExecutor(threads or os.cpu_count() or 1) as local:
            yield local
    else:
        check_address(scheduler)
        if connect_timeout is None:
            connect_timeout = min(timeout, 10.0)
        with _DaskExecutor(scheduler, code_sha256, timeout, connect_timeout,
                           task_timeout) as remote:
            yield remote


def check_address(address: str) -> str:
    """Refuse, before any connection is tried, a scheduler address that is none.

    Raises
    ------
    ClusterError
        Naming the address and the form expected (``tcp://HOST:PORT``).
    """
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(str(address), strict=False)
        if scheme in ("tcp", "tls"):
            host, _ = parse_host_port(location)
            if not host:
                raise ValueError("no host")
    except (ValueError, TypeError) as err:
        raise ClusterError(
            f"--scheduler {address!r} is not a dask scheduler address ({err}); expected "
            "tcp://HOST:PORT, e.g. tcp://127.0.0.1:8786") from None
    return address


class _LocalExecutor(Executor):
    """Threads in this process."""

    def __init__(self, threads: int) -> None:
        from concurrent.futures import ThreadPoolExecutor

        self.name = "local"
        self.threads = threads
        self.dashboard = None
        self._pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix=THREAD_PREFIX)

    def __enter__(self) -> _LocalExecutor:
        return self

    def __exit__(self, kind, error, traceback) -> None:
        # After an error, return at once: chunks already running cannot be stopped,
        # and the interpreter waits for them before it exits anyway.
        self._pool.shutdown(wait=error is None, cancel_futures=True)

    def run_unordered(self, function, items, *, label, stop=None):
        from concurrent.futures import FIRST_COMPLETED, wait

        # Items are drawn from the iterable only as slots free up: a generator of
        # items is never materialised, so memory holds a bounded number of them.
        source = iter(items)
        window = 2 * self.threads
        running: dict[Any, Any] = {}
        exhausted = False
        try:
            while True:
                if stop is not None and stop.is_set():
                    exhausted = True
                    for future in [f for f in running if f.cancel()]:
                        del running[future]
                while not exhausted and len(running) < window:
                    item = next(source, _END)
                    if item is _END:
                        exhausted = True
                    else:
                        running[self._pool.submit(function, item)] = item
                if not running:
                    return
                # A wait without timeout would not wake for the stop event: a signal
                # handler runs, but the wait resumes until a task finishes.
                finished, _ = wait(running, timeout=None if stop is None else _STOP_POLL,
                                   return_when=FIRST_COMPLETED)
                for future in finished:
                    item = running.pop(future)
                    yield item, future.result()
        finally:
            for future in running:
                future.cancel()


def _worker_probe() -> Callable[[], tuple[str, str]]:
    """The check every worker runs first; defined here so that it is sent by value."""

    def probe() -> tuple[str, str]:
        try:
            from study.engine.provenance import code_sha256

            return "ok", code_sha256()
        except Exception as err:  # any failure to import study is the answer
            return "no-study", f"{type(err).__name__}: {err}"

    return probe


def _task_runner() -> Callable[[str, bytes], tuple]:
    """The wrapper every task runs in; defined here so that it is sent by value.

    It returns ``("ok", result)``, or a tagged reason not to trust the worker
    (the client turns those into a :class:`ClusterError`). Errors of the task
    itself are raised as they are, like in a local run.
    """

    def run_task(expected: str, payload: bytes) -> tuple:
        import pickle

        try:
            from distributed import get_worker

            address = get_worker().address
        except Exception:  # not on a worker (never in a run): still check the code
            address = "unknown worker"
        try:
            from study.engine.provenance import code_sha256

            found = code_sha256()
        except Exception as err:
            return "no-study", address, f"{type(err).__name__}: {err}"
        if found != expected:
            return "other-code", address, found
        try:
            function, item = pickle.loads(payload)
        except Exception as err:
            return "unloadable", address, f"{type(err).__name__}: {err}"
        return "ok", function(item)

    return run_task


def _install_hint() -> str:
    return ("install the same study (same version and source) on every worker, "
            "e.g. start them from the same checkout or environment as the client")


class _DaskExecutor(Executor):
    """The workers of a running dask.distributed scheduler."""

    def __init__(self, address: str, code_sha256: str, timeout: float,
                 connect_timeout: float, task_timeout: float) -> None:
        self.name = address
        self.code_sha256 = code_sha256
        self.timeout = timeout
        self.connect_timeout = connect_timeout
        self.task_timeout = task_timeout
        self.client: Any = None
        self.threads = 0
        self.dashboard = None

    def __enter__(self) -> _DaskExecutor:
        from distributed import Client

        try:
            self.client = Client(self.name, timeout=self.connect_timeout,
                                 set_as_default=False)
        except Exception as err:  # OSError, TimeoutError, ValueError for a bad address
            raise ClusterError(
                f"cannot reach the dask scheduler at {self.name} within "
                f"{self.connect_timeout:g} s "
                f"({type(err).__name__}: {err}); is it running, and is the address right?"
            ) from None
        try:
            self._check_workers()
            self.dashboard = self._dashboard_link()
        except BaseException:
            self.client.close()
            raise
        return self

    def __exit__(self, kind, error, traceback) -> None:
        self.client.close()

    def _nthreads(self) -> dict[str, int]:
        try:
            return self.client.nthreads()
        except Exception as err:
            raise ClusterError(
                f"lost the dask scheduler at {self.name} ({type(err).__name__}: {err})"
            ) from None

    def _check_workers(self) -> None:
        """Every worker imports study and runs this code; else a ClusterError."""
        try:
            self.client.wait_for_workers(1, timeout=self.timeout)
        except TimeoutError:
            raise ClusterError(
                f"the dask scheduler at {self.name} has no worker after "
                f"{self.timeout:g} s; start workers with: dask worker {self.name}"
            ) from None
        answers = self.client.run(_worker_probe(), on_error="return")
        broken, other = {}, {}
        for worker, answer in sorted(answers.items()):
            if isinstance(answer, BaseException):
                broken[worker] = f"{type(answer).__name__}: {answer}"
            elif answer[0] != "ok":
                broken[worker] = answer[1]
            elif answer[1] != self.code_sha256:
                other[worker] = answer[1]
        if broken:
            listing = "; ".join(f"{worker}: {why}" for worker, why in broken.items())
            raise ClusterError(
                f"{len(broken)} of {len(answers)} workers of {self.name} cannot import "
                f"study ({listing}); {_install_hint()}"
            )
        if other:
            listing = ", ".join(f"{worker} has {found[:_SHOWN]}"
                                for worker, found in other.items())
            raise ClusterError(
                f"{len(other)} of {len(answers)} workers of {self.name} run other study "
                f"code than this client (code hash {self.code_sha256[:_SHOWN]} here; "
                f"{listing}); their results would be mixed with this code's: "
                f"{_install_hint()}"
            )
        self.threads = sum(self._nthreads().values())

    def _dashboard_link(self) -> str | None:
        from distributed.comm import get_address_host
        from distributed.utils import format_dashboard_link

        info = self.client.scheduler_info(n_workers=0)
        port = info.get("services", {}).get("dashboard")
        if port is None:
            return None
        try:
            link = format_dashboard_link(get_address_host(self.name), port)
        except KeyError:  # the link template names an unset environment variable
            return None
        # The scheduler serves /health and /metrics on that port even with
        # --no-dashboard: only a page that answers is a dashboard worth printing.
        import urllib.request

        direct = urllib.request.build_opener(urllib.request.ProxyHandler({}))
        try:
            with direct.open(link, timeout=min(self.timeout, 5.0)) as answer:
                return link if answer.status == 200 else None
        except OSError:  # URLError and HTTPError (404 without a dashboard) among them
            return None

    def _refused(self, outcome: tuple) -> ClusterError:
        """The error for a task that a worker refused to run."""
        reason, worker, detail = outcome
        if reason == "other-code":
            return ClusterError(
                f"worker {worker} of {self.name} runs other study code than this client "
                f"(code hash {self.code_sha256[:_SHOWN]} here, {detail[:_SHOWN]} there; "
                f"it joined after the start of the run); stopped so that results are "
                f"not mixed: {_install_hint()}"
            )
        if reason == "no-study":
            return ClusterError(
                f"worker {worker} of {self.name} cannot import study ({detail}; it "
                f"joined after the start of the run): {_install_hint()}"
            )
        return ClusterError(
            f"worker {worker} of {self.name} cannot load the task ({detail}): the "
            "function and its arguments must be importable on every worker"
        )

    def _watch(self, alone_since: float | None) -> tuple[int, float | None]:
        """The threads of the cluster now, and since when it has had no worker.

        Raises a ClusterError once it has had none for longer than ``timeout``.
        """
        threads = sum(self._nthreads().values())
        if threads:
            return threads, None
        now = time.monotonic()
        alone_since = now if alone_since is None else alone_since
        if now - alone_since > self.timeout:
            raise ClusterError(
                f"the dask scheduler at {self.name} has had no worker for "
                f"{self.timeout:g} s; the run stopped (finished work is kept)"
            )
        return threads, alone_since

    def _result(self, future) -> Any:
        """The value of a finished task, or the ClusterError that ends the run."""
        from distributed import CancelledError, KilledWorker

        alone_since = None
        waiting_since = time.monotonic()
        while True:
            try:
                # A finished result may sit on a worker that just died: dask computes
                # it again, and this waits, checking that some worker is left.
                outcome = future.result(timeout=max(self.timeout / 10, _REFRESH))
                break
            except TimeoutError:
                _, alone_since = self._watch(alone_since)
                if time.monotonic() - waiting_since > self.task_timeout:
                    raise self._stalled([future]) from None
            except KilledWorker as err:
                raise ClusterError(
                    f"workers of {self.name} died while computing one task again and "
                    f"again ({err}); is the task too large for their memory?"
                ) from None
            except CancelledError as err:
                raise ClusterError(
                    f"the dask scheduler at {self.name} dropped a task ({err}); "
                    "was it restarted?"
                ) from None
        if outcome[0] != "ok":
            raise self._refused(outcome)
        return outcome[1]

    def _stalled(self, futures: list[Any]) -> ClusterError:
        """The error that ends a run whose tasks stopped finishing: which workers hold
        them, as far as the scheduler knows."""
        keys = {future.key for future in futures}
        try:
            holders = sorted(worker for worker, held in self.client.processing().items()
                             if keys & set(held))
        except Exception:  # the scheduler itself may be the one not answering
            holders = []
        where = (f"tasks wait on {', '.join(holders)}" if holders
                 else "the scheduler does not say where they wait")
        silent = self._silent_workers()
        if silent and not set(silent) <= set(holders):
            # A frozen worker stops its heartbeats before the scheduler knows what it
            # holds (a task sent to it may not be listed as processing there yet).
            where += (f"; no heartbeat for over {SILENT_HEARTBEAT:g} s from "
                      f"{', '.join(silent)}")
        return ClusterError(
            f"no task finished on the workers of {self.name} for {self.task_timeout:g} s "
            f"({len(keys)} in flight; {where}): is a worker frozen or overloaded? The run "
            "stopped; finished work is kept and the next run resumes (--task-timeout "
            "sets the wait)")

    def _silent_workers(self) -> list[str]:
        """Workers whose last heartbeat is over ``SILENT_HEARTBEAT`` older than the
        newest (times of the scheduler's clock alone: no skew with this machine's)."""
        try:
            workers = self.client.scheduler_info()["workers"]
            seen = {address: float(worker["last_seen"])
                    for address, worker in workers.items() if "last_seen" in worker}
        except Exception:  # the scheduler itself may be the one not answering
            return []
        if len(seen) < 2:
            return []
        newest = max(seen.values())
        return sorted(address for address, when in seen.items()
                      if newest - when > SILENT_HEARTBEAT)

    def run_unordered(self, function, items, *, label, stop=None):
        import cloudpickle
        from distributed import as_completed

        source = iter(items)
        exhausted = False
        task = _task_runner()
        batch = uuid.uuid4().hex[:8]  # keys unique among runs sharing the scheduler
        tracker = as_completed(loop=self.client.loop)
        running: dict[Any, Any] = {}
        following = 0
        window = 2 * max(self.threads, 1)
        checked = time.monotonic()
        last_finished = checked
        alone_since = None
        pause = _POLL[0]
        try:
            while True:
                if stop is not None and stop.is_set():
                    exhausted = True  # what is in flight is still collected
                while not exhausted and len(running) < window:
                    item = next(source, _END)
                    if item is _END:
                        exhausted = True
                        break
                    payload = cloudpickle.dumps((function, item))
                    future = self.client.submit(task, self.code_sha256, payload,
                                                key=f"{label}-{following}-{batch}",
                                                pure=False)
                    running[future] = item
                    tracker.add(future)
                    following += 1
                if not running:
                    return
                finished = tracker.next_batch(block=False)
                if not finished:
                    now = time.monotonic()
                    if now - checked > _REFRESH:
                        # Workers come and go: follow their threads, and never wait
                        # forever on a cluster that has none left.
                        checked = now
                        threads, alone_since = self._watch(alone_since)
                        window = 2 * max(threads, 1)
                        if now - last_finished > self.task_timeout:
                            raise self._stalled(list(running))
                    time.sleep(pause)
                    pause = min(2 * pause, _POLL[1])
                    continue
                alone_since, pause = None, _POLL[0]
                last_finished = time.monotonic()
                for future in finished:
                    item = running.pop(future)
                    # Dropping the future (here and in finished) lets the worker
                    # drop its copy of the result.
                    yield item, self._result(future)
        finally:
            if running:
                self.client.cancel(list(running))

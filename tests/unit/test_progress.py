"""Progress lines and when the time left is shown: a fake clock, never real time."""

from __future__ import annotations

import io

import pytest

from study.engine.progress import ETA_MIN_FRACTION, ETA_MIN_SECONDS, Progress, TimeLeft


class Clock:
    """Seconds that move only when a test says so."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_no_time_left_before_enough_work_and_time() -> None:
    """The issue's run: the first chunk takes 30 s (compiling), then 10 chunks of 100
    points take 3.8 s each. The time left is unknown until 10 % of the work and 5 s have
    passed, then it is the rest over the throughput after the first chunk."""
    clock = Clock()
    left = TimeLeft(1100, clock())
    clock.now += 30.0
    left.add(clock(), 100)  # the first chunk, with the compile time
    assert left.done / left.total < ETA_MIN_FRACTION
    assert left.seconds(clock()) is None  # 9 % done: not yet
    clock.now += 3.8
    left.add(clock(), 100)
    # 18 % and 34 s: from the throughput since the first chunk, 100 pt in 3.8 s
    assert left.seconds(clock()) == pytest.approx(900 / (100 / 3.8), rel=1e-12)
    # not the 16 minutes a rate including the compile time would say
    assert left.seconds(clock()) < 0.5 * 900 / (200 / 33.8)


def test_no_time_left_before_the_minimum_time() -> None:
    clock = Clock()
    left = TimeLeft(100, clock())
    clock.now += 0.5
    left.add(clock(), 30)
    clock.now += 0.5
    left.add(clock(), 30)
    assert clock() - left.start < ETA_MIN_SECONDS
    assert left.seconds(clock()) is None
    clock.now += ETA_MIN_SECONDS
    assert left.seconds(clock()) == pytest.approx(40 / (30 / (0.5 + ETA_MIN_SECONDS)))


def test_reused_work_is_done_but_no_rate() -> None:
    """Kept values come back instantly: they must not make the run look fast."""
    clock = Clock()
    left = TimeLeft(1000, clock())
    clock.now += 1.0
    left.add(clock(), 500, computed=0)   # reused
    clock.now += 0.01
    left.add(clock(), 100, computed=0)   # reused
    clock.now += 10.0
    assert left.seconds(clock()) is None  # no computed work after the first update
    left.add(clock(), 100, computed=100)
    assert left.seconds(clock()) == pytest.approx(300 / (100 / 10.01))


def test_log_lines_say_estimating_then_the_time_left() -> None:
    clock = Clock()
    stream = io.StringIO()
    progress = Progress(1000, "coupling", None, stream=stream, clock=clock)
    clock.now += 40.0
    progress.update(100)
    clock.now += 4.0
    progress.update(100)
    clock.now += 4.0
    progress.update(800)
    lines = stream.getvalue().splitlines()
    assert lines[0] == ("coupling:  10% 100/1.00k pt, 00:40 elapsed, ? pt/s, "
                        "time left: estimating")
    assert lines[1] == "coupling:  20% 200/1.00k pt, 00:44 elapsed, 25.0 pt/s, about 00:32 left"
    assert lines[-1].startswith("coupling: 100% 1.00k/1.00k pt") and lines[-1].endswith("done")


def test_a_heartbeat_writes_a_line_when_the_log_interval_passed() -> None:
    """A scene computing for a minute between updates still says it is running."""
    clock = Clock()
    stream = io.StringIO()
    progress = Progress(60.0, "steering", None, stream=stream, unit="s", clock=clock)
    progress.beat()
    assert stream.getvalue() == ""  # nothing new to say yet
    clock.now += 31.0
    progress.beat()
    assert stream.getvalue() == ("steering:   0% 0/60 s, 00:31 elapsed, ? s/s, "
                                 "time left: estimating\n")
    with progress.running():  # the heartbeat thread starts and stops cleanly
        progress.update(60.0)
    progress.close()
    assert stream.getvalue().splitlines()[-1].endswith("done")


def test_off_means_silent() -> None:
    stream = io.StringIO()
    progress = Progress(10, "x", False, stream=stream)
    with progress.running():
        progress.update(10)
    progress.beat()
    assert stream.getvalue() == ""


def test_a_phase_says_what_comes_next_not_done() -> None:
    stream = io.StringIO()
    shown = Progress(4, "own", enabled=True, stream=stream,
                     finished="map done; frontier next")
    shown.update(4)
    assert stream.getvalue().rstrip().endswith("map done; frontier next")
    assert " done\n" not in stream.getvalue().replace("map done", "")


def test_frontier_work_counts_every_solve_of_the_bisection() -> None:
    """The frontier phase's total is what the bisection then solves, exactly."""
    import numpy as np

    from study.model.paper import paper_structure
    from study.solvers.exact import steady_velocity
    from study.solvers.frontier import frontier_from_grid, frontier_work

    f = np.linspace(13.5, 16.0, 11)
    a = np.array([5.0, 7.0, 9.0])
    velocity, status = steady_velocity(paper_structure(), f[:, None], a)
    solved: list[int] = []
    found = frontier_from_grid(paper_structure(), f, a, velocity, status, tolerance=1e-6,
                               progress=solved.append)
    expected = frontier_work(f, velocity, status, 1e-6)
    assert np.isfinite(found.frequency).sum() >= 2  # brackets to bisect
    assert sum(solved) == expected > 0
    # No progress callback, the same frontier, bit for bit.
    again = frontier_from_grid(paper_structure(), f, a, velocity, status, tolerance=1e-6)
    assert np.array_equal(again.frequency, found.frequency, equal_nan=True)


def test_a_fit_says_each_phase() -> None:
    from pathlib import Path

    from study.analyses.fit_search import fit
    from study.analyses.fit_spec import load_fit_spec

    spec = load_fit_spec(Path(__file__).resolve().parents[1] / "golden" / "specs" / "fit.toml")
    lines: list[str] = []
    result = fit(spec, progress=lines.append)
    assert lines[0].startswith("least squares: 2 parameters to 7 measurements")
    assert lines[1] == (f"least squares done after {lines[1].split()[4]} model evaluations; "
                        "uncertainties and chi^2 profiles next")
    assert 0 < int(lines[1].split()[4]) <= result.evaluations

"""Work units: a chunk's missing points are cut only where no value depends on the cut,
each unit's values are kept as it comes back, progress moves within a chunk, a stop
request (Ctrl-C) keeps every point computed and says so, and numba's compilations are
shown. The values are checked against the solvers called once on the whole grid."""

from __future__ import annotations

import io
import itertools
import re
import signal
from pathlib import Path

import numpy as np
import pytest

import study
import study.studies.kind as study_kind
from study.engine.compiling import COMPILING, compile_notices
from study.engine.interrupts import RunInterrupted, stop_requests
from study.engine.progress import Progress
from study.engine.runner import run_study
from study.engine.store import open_result
from study.solvers.basins import basins
from study.solvers.exact import steady_state
from study.solvers.protocol import slow_sweep
from study.solvers.settings import SolverSettings
from study.studies.observables import Method
from study.studies.sweep import GRAINS, Rectangle, UnitSizer, cut_unit, unit_grain

BASE = dict(f0=14.44, Q=17.5, alpha=64.0, M=0.3, cs=0.25)
STRUCTURE = study.Structure(**BASE)


def spec_text(name: str, observables: str = '"velocity"', solver: str = "",
              sweep: str = "", extra: str = "", f_num: int = 6, a_num: int = 5,
              chunk_points: int = 10_000) -> str:
    structure = "\n".join(f"{k} = {v!r}" for k, v in BASE.items())
    return (f'[study]\nname = "{name}"\nobservables = [{observables}]\n'
            f"[structure]\n{structure}\n"
            f"[sweep]\n{sweep}\nf = {{ start = 12.0, stop = 17.0, num = {f_num} }}\n"
            f"a = {{ start = 4.0, stop = 10.0, num = {a_num} }}\n"
            f'[solver]\ncoupling = "two-way"\nchunk_points = {chunk_points}\n{solver}\n'
            f"{extra}")


def write(folder: Path, name: str, **kwargs) -> Path:
    path = folder / f"{name}.toml"
    path.write_text(spec_text(name, **kwargs))
    return path


class _Sizes:
    """A sizer handing out the given unit sizes in turn (the real one sizes by time)."""

    sizes = (1,)

    def __init__(self, *args, **kwargs) -> None:
        self._next = itertools.cycle(self.sizes)

    def points(self) -> int:
        return next(self._next)

    def measured(self, points: int, seconds: float) -> None:
        pass


@pytest.fixture
def small_units(monkeypatch):
    """Units of 1, 2 and 3 points in turn, whatever the solver costs."""
    sizes = type("SmallSizes", (_Sizes,), {"sizes": (1, 2, 3)})
    monkeypatch.setattr(study_kind, "UnitSizer", sizes)


def cut_all(rectangle: Rectangle, grain: str, sizes) -> list[Rectangle]:
    pieces, left = [], [rectangle]
    for size in itertools.cycle(sizes):
        if not left:
            return pieces
        piece, rest = cut_unit(left.pop(0), grain, size)
        left[:0] = rest
        pieces.append(piece)
    raise AssertionError("unreachable")


# -- cutting ---------------------------------------------------------------------


@pytest.mark.parametrize("grain", GRAINS)
@pytest.mark.parametrize("sizes", [(1,), (2,), (3, 1), (5,), (7, 2), (100,)])
def test_units_cover_the_rectangle_once_and_hold_whole_runs(grain, sizes):
    for rectangle in (Rectangle(np.array([0, 2, 3, 7]), np.array([1, 2, 4])),
                      Rectangle(np.array([3, 4, 5]), np.array([6])),
                      Rectangle(np.array([2]), np.array([0, 1, 5, 9, 10]))):
        check_cut(rectangle, grain, sizes)


def check_cut(rectangle: Rectangle, grain: str, sizes) -> None:
    pieces = cut_all(rectangle, grain, sizes)
    points = sorted((int(r), int(c)) for p in pieces for r in p.rows for c in p.columns)
    assert points == sorted(itertools.product(rectangle.rows.tolist(),
                                              rectangle.columns.tolist()))
    for piece in pieces:
        assert piece.points > 0  # no empty unit (an empty block has no axis to look up)
        if grain == "rows":  # each row of f is a run: never split
            np.testing.assert_array_equal(piece.columns, rectangle.columns)
        elif grain == "columns":  # each column of a is a run
            np.testing.assert_array_equal(piece.rows, rectangle.rows)
        elif grain == "points":
            assert piece.points <= max(sizes)
    if grain == "whole":
        assert len(pieces) == 1 and pieces[0] is rectangle
    if grain == "points" and sizes == (1,):
        assert len(pieces) == rectangle.points


def test_the_grain_follows_the_runs_of_the_method():
    wide = Rectangle(np.arange(3), np.arange(4))
    narrow = Rectangle(np.arange(3), np.arange(1))
    assert unit_grain(Method(coupling="two-way"), wide) == "points"
    continued = Method(coupling="two-way", solver=SolverSettings(continuation=True))
    assert unit_grain(continued, wide) == "rows"
    assert unit_grain(continued, narrow) == "whole"  # one column: one run down f
    assert unit_grain(Method(coupling="two-way", protocol=("a", "up")), wide) == "rows"
    assert unit_grain(Method(coupling="two-way", protocol=("f", "down")), wide) == "columns"


def test_the_sizer_aims_at_a_second_and_follows_a_dearer_stretch_at_once():
    sizer = UnitSizer(seconds=1.0)
    assert sizer.points() == 1  # nothing measured: the smallest unit
    sizer.measured(1, 30.0)  # the first unit carries the compile time
    assert sizer.points() == 1
    for _ in range(6):  # the estimate falls by at most 4 a unit
        sizer.measured(1, 1e-3)
    assert sizer.seconds_per_point == pytest.approx(30.0 / 4**6)
    sizes = []
    for _ in range(12):
        sizes.append(sizer.points())
        sizer.measured(sizes[-1], sizes[-1] * 1e-3)
    assert all(b <= 4 * max(sizes[:i + 1]) for i, b in enumerate(sizes[1:]))  # growth
    assert sizes[-1] == 1000  # one second at 1 ms a point
    sizer.measured(10, 10 * 0.5)  # a dear stretch: the next unit is sized by it
    assert sizer.points() == 2


# -- values do not depend on the cut ------------------------------------------------


def test_continued_orbits_cut_into_units_equal_the_solver_on_the_whole_grid(
        tmp_path, small_units):
    report = run_study(write(tmp_path, "cont", solver="continuation = true"),
                       tmp_path / "cont.nc", progress=False, workers=2)
    ds = open_result(tmp_path / "cont.nc")
    f, a = ds["f"].values, ds["a"].values
    expected = steady_state(STRUCTURE, f[:, None], a[None, :],
                            SolverSettings(continuation=True), coupling="two-way")
    np.testing.assert_array_equal(ds["velocity"].values, expected.velocity)
    np.testing.assert_array_equal(ds["status"].values, expected.status)
    assert report.chunks == 1 and report.points_computed == f.size * a.size


def test_cutting_a_continued_run_would_change_values(tmp_path, small_units, monkeypatch):
    """Why the grain matters (and that the test above can fail): the same units cut
    across the rows, as if every point were solved alone, give other values."""
    monkeypatch.setattr(study_kind, "unit_grain", lambda method, rectangle: "points")
    run_study(write(tmp_path, "cont", solver="continuation = true"),
              tmp_path / "cont.nc", progress=False)
    ds = open_result(tmp_path / "cont.nc")
    f, a = ds["f"].values, ds["a"].values
    expected = steady_state(STRUCTURE, f[:, None], a[None, :],
                            SolverSettings(continuation=True), coupling="two-way")
    assert np.any(ds["velocity"].values != expected.velocity)


@pytest.mark.parametrize("along", ["a", "f"])
def test_slow_sweeps_cut_into_units_equal_the_sweep_of_the_whole_grid(
        tmp_path, small_units, along):
    spec = write(tmp_path, f"sweep-{along}",
                 sweep=f'protocol = {{ along = "{along}", direction = "both" }}')
    run_study(spec, tmp_path / "s.nc", progress=False, workers=2)
    ds = open_result(tmp_path / "s.nc")
    f, a = ds["f"].values, ds["a"].values
    for index, direction in enumerate(("up", "down")):
        swept = slow_sweep(STRUCTURE, f, a, along=along, direction=direction)
        np.testing.assert_array_equal(ds["velocity"].values[index], swept.state.velocity)
        np.testing.assert_array_equal(ds["jumped"].values[index],
                                      swept.jumped.astype(np.int8))


def test_basins_cut_point_by_point_equal_the_solver_on_the_whole_grid(tmp_path,
                                                                      small_units):
    spec = write(tmp_path, "bas", observables='"basins"', extra="[basins]\nstarts = 4\n",
                 f_num=3, a_num=4)
    run_study(spec, tmp_path / "b.nc", progress=False, workers=2)
    ds = open_result(tmp_path / "b.nc")
    f, a = ds["f"].values, ds["a"].values
    found = basins(STRUCTURE, f[:, None], a[None, :], starts=4)
    np.testing.assert_array_equal(ds["attractor_count"].values, found.count)
    width = found.velocity.shape[-1]
    np.testing.assert_array_equal(ds["basin_velocity"].values[..., :width], found.velocity)
    np.testing.assert_array_equal(ds["basin_fraction"].values[..., :width], found.fraction)


# -- kept as they come back, progress within a chunk --------------------------------


def test_progress_moves_within_a_one_chunk_study(tmp_path, capsys):
    """A one-chunk study used to show nothing until it ended (one update at 100 %)."""
    run_study(write(tmp_path, "one"), tmp_path / "one.nc", progress=True)
    lines = [line for line in capsys.readouterr().err.splitlines()
             if line.startswith("one: ")]
    shares = [int(re.match(r"one:\s+(\d+)%", line).group(1)) for line in lines]
    assert any(0 < share < 100 for share in shares), lines
    assert shares == sorted(shares) and shares[-1] == 100


def test_a_stop_request_keeps_every_unit_and_the_rerun_reuses_them(
        tmp_path, monkeypatch, python_sigint):
    """Ctrl-C in the middle of a one-chunk study: the units running finish, every
    computed point is kept, the message counts them, the rerun reuses exactly those."""
    sizes = type("Fives", (_Sizes,), {"sizes": (5,)})
    monkeypatch.setattr(study_kind, "UnitSizer", sizes)
    came_back = []
    unit_done = study_kind._Run._unit_done

    def interrupting(self, job, result, pending):
        came_back.append(job.task.point_count)
        if len(came_back) == 2:
            signal.raise_signal(signal.SIGINT)  # as Ctrl-C, between two units
        return unit_done(self, job, result, pending)

    monkeypatch.setattr(study_kind._Run, "_unit_done", interrupting)
    spec = write(tmp_path, "stop", f_num=8, a_num=5)
    with pytest.raises(RunInterrupted) as stopped:
        run_study(spec, tmp_path / "stop.nc", progress=False, workers=2)
    kept = stopped.value.kept
    assert kept == sum(came_back) and 10 <= kept < 40 and stopped.value.points == 40
    assert str(stopped.value) == (f"interrupted; kept {kept} of 40 points ({kept} computed "
                                  f"in this run) in {tmp_path / '.study-cache'}; run again "
                                  "to resume")
    assert not (tmp_path / "stop.nc").exists()
    monkeypatch.undo()
    report = run_study(spec, tmp_path / "stop.nc", progress=False)
    assert (report.points_reused, report.points_computed) == (kept, 40 - kept)
    ds = open_result(tmp_path / "stop.nc")
    f, a = ds["f"].values, ds["a"].values
    expected = steady_state(STRUCTURE, f[:, None], a[None, :], coupling="two-way")
    np.testing.assert_array_equal(ds["velocity"].values, expected.velocity)


def test_a_second_interrupt_raises_at_once(python_sigint):
    with stop_requests() as stop:
        signal.raise_signal(signal.SIGINT)
        assert stop.is_set()
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(signal.SIGINT)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_program_with_its_own_sigint_handler_keeps_it(python_sigint):
    seen = []
    previous = signal.signal(signal.SIGINT, lambda number, frame: seen.append(number))
    try:
        with stop_requests() as stop:
            signal.raise_signal(signal.SIGINT)
        assert seen == [signal.SIGINT] and not stop.is_set()
    finally:
        signal.signal(signal.SIGINT, previous)


# -- compilations ---------------------------------------------------------------------


def test_a_compilation_is_said_and_shown_until_it_ends():
    from numba import njit

    @njit(cache=False)
    def never_compiled_before(x):
        return x + 1

    stream = io.StringIO()
    progress = Progress(10, "own", True, stream=stream)
    with compile_notices(progress) as watch:
        assert never_compiled_before(1) == 2
        assert never_compiled_before(2) == 3  # compiled: nothing more to say
    text = stream.getvalue()
    assert text.count(f"study: {COMPILING} (the first run") == 1
    assert watch.compilations == 1 and watch.seconds > 0
    assert "study: compiled the solver kernels in" in text
    # While it compiles, the progress names the phase in place of the time left.
    progress.set_phase(COMPILING)
    assert progress.line().endswith(COMPILING)
    progress.set_phase(None)
    assert progress.line().endswith("time left: estimating")


def test_no_compilation_no_word_and_off_means_silent():
    stream = io.StringIO()
    with compile_notices(Progress(10, "own", True, stream=stream)):
        pass
    assert stream.getvalue() == ""
    from numba import njit

    @njit(cache=False)
    def compiled_quietly(x):
        return 2 * x

    quiet = io.StringIO()
    with compile_notices(Progress(10, "own", False, stream=quiet)):
        compiled_quietly(1)
    assert quiet.getvalue() == ""

"""Study specs that would hang or be absurdly large are refused before any work.

The size guard (:func:`study.studies.size.check_size`) refuses on the axis lengths alone,
before a value is generated; budgets a user could make endless have maxima in the
schema; the frontier tolerance must be one doubles can reach.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import study.studies.spec
from study.model.status import Status
from study.model.structure import Structure
from study.solvers.frontier import frontier_from_grid
from study.studies.size import (
    MAX_CHUNK_BYTES,
    MAX_CHUNKS,
    MAX_OUTPUT_BYTES,
    MAX_POINTS,
    check_size,
)
from study.studies.spec import SpecError, parse_spec

PATH = "workflows/big.toml"


def spec_text(observables: str = '"velocity"', f: str = "{ start = 10.0, stop = 20.0, num = 11 }",
              a: str = "{ start = 0.0, stop = 12.0, num = 5 }", solver: str = "") -> str:
    return f"""\
[study]
name = "big"
observables = [{observables}]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = {f}
a = {a}

[solver]
{solver}
"""


@pytest.fixture
def no_values(monkeypatch):
    """Generating an axis's values fails the test: the guard must refuse on lengths."""

    def forbidden(*args, **kwargs):
        raise AssertionError("axis values generated before the size guard refused")

    monkeypatch.setattr(study.studies.spec, "axis_values", forbidden)


def _refused(text: str) -> str:
    with pytest.raises(SpecError) as excinfo:
        parse_spec(text, PATH)
    message = str(excinfo.value)
    assert message.startswith(f"{PATH}: ")
    return message


@pytest.mark.usefixtures("no_values")
def test_too_many_points_are_refused_naming_the_sweep_keys():
    message = _refused(spec_text(f="{ start = 10.0, stop = 20.0, num = 10000000 }",
                                 a="{ start = 0.0, stop = 12.0, num = 10000000 }"))
    assert "[sweep] f x a = 10000000 x 10000000 = 1e+14 points" in message
    assert f"allowed at most {MAX_POINTS:.3g} points and 64 GiB" in message


@pytest.mark.usefixtures("no_values")
def test_too_much_output_is_refused_though_the_points_are_allowed():
    # 1.9e9 points (allowed) of velocity, status and diagnostics: 38 bytes each.
    message = _refused(spec_text('"diagnostics"',
                                 f="{ start = 10.0, stop = 20.0, num = 19000 }",
                                 a="{ start = 0.0, stop = 12.0, num = 100000 }"))
    assert 19000 * 100000 <= MAX_POINTS
    assert 19000 * 100000 * 38 > MAX_OUTPUT_BYTES
    assert "= 1.9e+09 points (67.2 GiB of output)" in message


@pytest.mark.usefixtures("no_values")
def test_a_frequency_row_too_long_for_one_task_is_refused_naming_a():
    message = _refused(spec_text('"diagnostics"', a="{ start = 0.0, stop = 12.0, num = 10000000 }"))
    assert "[sweep] a: one frequency row of 10000000 accelerations holds 362 MiB" in message
    assert f"allowed: at most {MAX_CHUNK_BYTES // 38} values of a" in message


@pytest.mark.usefixtures("no_values")
def test_chunks_too_large_are_refused_naming_chunk_points():
    message = _refused(spec_text('"diagnostics"', f="{ start = 10.0, stop = 20.0, num = 1000 }",
                                 a="{ start = 0.0, stop = 12.0, num = 10000 }",
                                 solver="chunk_points = 10000000"))
    assert "[solver] chunk_points = 10000000 makes tasks of 362 MiB" in message
    assert f"allowed: at most {MAX_CHUNK_BYTES // 38} points per chunk" in message


@pytest.mark.usefixtures("no_values")
def test_too_many_chunks_are_refused_naming_chunk_points():
    message = _refused(spec_text('"thresholds"', f="{ start = 10.0, stop = 20.0, num = 2000000 }",
                                 solver="chunk_points = 1"))
    assert "[solver] chunk_points = 1 cuts [sweep] f into 2e+06 chunks" in message
    assert f"allowed at most {MAX_CHUNKS:.3g}: raise chunk_points to at least 2" in message


def test_the_guard_counts_only_what_is_stored():
    # Thresholds depend on f only: a long a axis adds nothing to store or compute.
    check_size({"f": 1_000_000, "a": 10_000_000}, ("thresholds",), 20_000, PATH)
    with pytest.raises(SpecError, match=r"\[sweep\] Q x f x a = 100 x 100000 x 1000 = 1e\+10"):
        check_size({"Q": 100, "f": 100_000, "a": 1000}, ("velocity",), 20_000, PATH)


@pytest.mark.parametrize(
    ("solver", "fragment"),
    [
        ("frontier_tolerance = 1e-300",
         "[solver] frontier_tolerance = 1e-300 is out of range; allowed: >= 1e-12 and <= 1"),
        ("max_events = 1000000000000000000",
         "[solver] max_events = 1000000000000000000 is out of range; allowed: >= 1 and <= "
         "1000000"),
        ("max_map_iterations = 1000000000000",
         "[solver] max_map_iterations = 1000000000000 is out of range"),
        ('method = "integrator"\nmax_periods = 1000000000', "[solver] max_periods = 1000000000"),
        ('method = "integrator"\nsteps_per_period = 1000000000',
         "[solver] steps_per_period = 1000000000"),
        ('method = "integrator"\nmax_orbit_period = 1000000000',
         "[solver] max_orbit_period = 1000000000"),
        ('method = "integrator"\ntolerance = 1e-300', "[solver] tolerance = 1e-300"),
        ("chunk_points = 1000000000000", "[solver] chunk_points = 1000000000000"),
    ],
)
def test_budgets_cannot_be_made_endless(solver, fragment):
    assert fragment in _refused(spec_text(solver=solver))


def test_a_frontier_tolerance_finer_than_doubles_near_f_is_refused():
    text = spec_text('"frontier"', f="{ values = [999999.0, 1000000.0] }",
                     solver="frontier_tolerance = 1e-12")
    message = _refused(text)
    finest = 4 * np.spacing(1e6)
    assert "[solver] frontier_tolerance = 1e-12 Hz is finer than doubles resolve near the " \
           f"largest f; allowed: >= {finest:.3g} Hz" in message
    # Near the paper's frequencies the schema's minimum is reachable.
    assert parse_spec(spec_text('"frontier"', solver="frontier_tolerance = 1e-12")) is not None


def test_bisection_at_the_finest_tolerance_allowed_ends():
    """The guard's bound is what the bisection needs: at 4 spacings of doubles near f
    the bracket still shrinks to the tolerance (below one spacing it never would)."""
    f = np.array([999_999.0, 1_000_000.0])
    root = 999_999.123456789
    calls = []

    def solve(structure, mid, a):
        calls.append(mid)
        velocity = np.sign(np.asarray(mid) - root) * np.ones_like(a)
        return SimpleNamespace(velocity=velocity,
                               status=np.full(velocity.shape, Status.STICK_SLIP))

    tolerance = 4 * float(np.spacing(f.max()))
    found = frontier_from_grid(
        Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25), f, [7.0],
        np.array([[-1.0], [1.0]]), np.full((2, 1), Status.STICK_SLIP),
        tolerance=tolerance, solve=solve,
    )
    assert found.width[0, 0] <= tolerance
    assert abs(found.frequency[0, 0] - root) <= tolerance
    assert len(calls) <= math.ceil(math.log2(1.0 / tolerance)) + 1


@pytest.mark.parametrize(
    ("sweep_f", "structure_line", "fragment"),
    [
        ("{ values = [10.0, 2000000.0] }", "",
         "[sweep] f: value 2000000.0 is out of range; allowed: > 0 and <= 1000000"),
        ("{ start = 10.0, stop = 20.0, num = 11 }", "g = 1e300",
         "[structure] g = 1e+300 is out of range; allowed: > 0 and <= 1000"),
        ("{ start = 10.0, stop = 20.0, num = 11 }", "ck = 1e300",
         "[structure] ck = 1e+300 is out of range"),
    ],
)
def test_huge_values_are_refused(sweep_f, structure_line, fragment):
    text = spec_text(f=sweep_f).replace("cs = 0.25\n", f"cs = 0.25\n{structure_line}\n")
    assert fragment in _refused(text)


def test_the_workflows_pass_the_guard():
    workflows = Path(__file__).resolve().parents[2] / "workflows"
    for path in workflows.glob("*.toml"):
        text = path.read_text(encoding="utf-8")
        if "[study]" in text:
            parse_spec(text, str(path))


# ------------------------------------------------------- slow sweeps ([sweep] protocol)


def test_both_directions_count_twice_the_points():
    lengths = {"f": 19_000, "a": 100_000}  # 1.9e9 points: allowed one way
    check_size(lengths, ("velocity",), 20_000, PATH, protocol=("a", "up"))
    with pytest.raises(SpecError) as refused:
        check_size(lengths, ("velocity",), 20_000, PATH, protocol=("a", "both"))
    assert ('[sweep] f x a = 19000 x 100000 x 2 directions ([sweep] protocol direction = '
            '"both") = 3.8e+09 points') in str(refused.value)


def test_both_directions_write_twice_but_the_unswept_values():
    # 1e9 points of velocity, status, jumped and diagnostics (39 bytes each): 36.3 GiB
    # one way, 72.6 GiB both; unswept (9 bytes) is written once: 81 GiB.
    lengths = {"f": 10_000, "a": 100_000}
    observables = ("velocity", "diagnostics")
    check_size(lengths, observables, 20_000, PATH, protocol=("a", "down"))
    with pytest.raises(SpecError, match=r"= 2e\+09 points \(72\.6 GiB of output\)"):
        check_size(lengths, observables, 20_000, PATH, protocol=("a", "both"))
    with pytest.raises(SpecError, match=r"= 2e\+09 points \(81 GiB of output\)"):
        check_size(lengths, (*observables, "unswept"), 20_000, PATH,
                   protocol=("a", "both"))


@pytest.mark.usefixtures("no_values")
def test_a_spec_swept_both_ways_is_refused_on_its_lengths():
    message = _refused(spec_text(
        f="{ start = 10.0, stop = 20.0, num = 19000 }",
        a='{ start = 0.0, stop = 12.0, num = 100000 }\nprotocol = { along = "a", '
          'direction = "both" }', solver='coupling = "two-way"'))
    assert "x 2 directions" in message and "3.8e+09 points" in message


def test_a_sweep_along_f_holds_every_f_and_a_in_one_task():
    lengths = {"f": 1000, "a": 100_000}  # 1e8 points of 10 bytes in one task
    check_size(lengths, ("velocity",), 20_000, PATH, protocol=("a", "up"))
    with pytest.raises(SpecError) as refused:
        check_size(lengths, ("velocity",), 20_000, PATH, protocol=("f", "up"))
    message = str(refused.value)
    assert '[sweep] protocol along = "f": one task holds every f and a of a structure ' \
           "(1000 x 100000 points), 954 MiB" in message
    assert f"allowed: at most {MAX_CHUNK_BYTES // 10} points (f x a)" in message


def test_chunks_both_ways_count_twice():
    lengths = {"Q": 600_000, "f": 2, "a": 2}  # one chunk per structure and direction
    check_size(lengths, ("velocity",), 4, PATH, protocol=("a", "up"))
    with pytest.raises(SpecError, match=r"1\.2e\+06 chunks"):
        check_size(lengths, ("velocity",), 4, PATH, protocol=("a", "both"))


def test_a_phase_section_counts_its_periods():
    # 1e8 points of velocity and status (9 bytes) and 64 periods of three section
    # variables (1536 bytes): 144 GiB, where 9 bytes a point would be 0.84 GiB.
    with pytest.raises(SpecError, match=r"1e\+08 points \(144 GiB of output\)"):
        check_size({"f": 10_000, "a": 10_000}, ("velocity", "section"), 20_000, PATH)

"""What keeps `study run` close to the bare solver, checked for behaviour (never timed):
solves run side by side on threads, kept blocks round-trip bit for bit and share their
acceleration axis, and large studies are cut into fewer chunks."""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import study
from study.engine.cache import ResultCache
from study.engine.cache_format import decode_array, encode_array, encode_block, entry_key
from study.studies.observables import Method, PointWork
from study.studies.spec import default_chunk_points

STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)


class _Meeting(Method):
    """A method whose solve returns only once two solves are running at the same time."""

    def __init__(self, barrier: threading.Barrier) -> None:
        super().__init__()
        object.__setattr__(self, "barrier", barrier)

    def solve(self, structure, f, a, parallel=False):
        self.barrier.wait()  # raises BrokenBarrierError if the other solve never comes
        return super().solve(structure, f, a, parallel)


def test_two_threads_solve_at_the_same_time():
    # functools.cached_property (Python < 3.12) would let only one solve run at a time:
    # the second would wait for the first, which waits for the second, until the timeout.
    barrier = threading.Barrier(2, timeout=30)
    method = _Meeting(barrier)
    f = np.array([[12.0], [14.0]])
    a = np.array([[3.0, 6.0]])
    works = [PointWork(STRUCTURE, f[i:i + 1], a, method) for i in range(2)]
    with ThreadPoolExecutor(2) as pool:
        velocities = list(pool.map(lambda work: work.solution.velocity, works))
    expected, _ = study.steady_velocity(STRUCTURE, f, a)
    np.testing.assert_array_equal(np.vstack(velocities), expected)


def test_a_solve_is_done_once_per_work():
    calls = []

    class Counting(Method):
        def solve(self, structure, f, a, parallel=False):
            calls.append(1)
            return super().solve(structure, f, a, parallel)

    work = PointWork(STRUCTURE, np.array([[13.0]]), np.array([[4.0]]), Counting())
    assert work.solution is work.solution
    assert len(calls) == 1


@pytest.mark.parametrize("array", [
    np.array([0.0, -0.0, np.nan, np.inf, -1e-300, 1e300, 5e-324]),
    np.arange(12, dtype=np.int8).reshape(3, 4) - 6,
    np.arange(6, dtype=np.int32).reshape(2, 3) * 1_000_003,
    np.empty((0, 4)),
], ids=["float64", "int8", "int32", "empty"])
def test_arrays_round_trip_bit_for_bit(array):
    back = decode_array(encode_array(array), array.dtype.str, array.shape)
    assert back.dtype == array.dtype and back.shape == array.shape
    assert back.tobytes() == array.tobytes()


def test_a_wrong_size_is_refused():
    data = encode_array(np.arange(10.0))
    with pytest.raises(ValueError, match="expected"):
        decode_array(data, "<f8", (9,))
    with pytest.raises(ValueError, match="deflate"):
        decode_array(b"not deflate at all", "<f8", (10,))


def test_blocks_share_one_acceleration_axis_and_are_found_again(tmp_path):
    cache = ResultCache(tmp_path)
    key = entry_key({"test": "axis"})
    a = np.linspace(0.0, 12.0, 7)
    f = np.linspace(10.0, 20.0, 6)
    velocity = np.arange(42.0).reshape(6, 7) - 20.0
    status = (np.arange(42) % 5).astype(np.int8).reshape(6, 7)
    for rows in (slice(0, 3), slice(3, 6)):
        cache.store_encoded(key, {"test": "axis"}, a,
                            encode_block(key, f[rows], a, {"velocity": velocity[rows],
                                                           "status": status[rows]}))
    folder = cache.entry_path(key)
    assert len(list(folder.glob("block-*.npz"))) == 2
    assert len(list(folder.glob("axis-*.bin"))) == 1
    fresh = ResultCache(tmp_path)  # another session reads what this one kept
    values, found = fresh.lookup(key, f[1:5], a[2:],
                                 {"velocity": np.dtype("f8"), "status": np.dtype("i1")})
    assert found.all()
    np.testing.assert_array_equal(values["velocity"], velocity[1:5, 2:])
    np.testing.assert_array_equal(values["status"], status[1:5, 2:])
    assert not fresh.discarded


@pytest.mark.parametrize(("points", "expected"), [
    (1, 20_000), (96_641, 20_000), (320_000, 20_000), (1_000_000, 62_500),
    (1_600_000, 100_000), (10**8, 100_000),
])
def test_default_chunk_points_grows_with_the_study_within_bounds(points, expected):
    assert default_chunk_points(points) == expected

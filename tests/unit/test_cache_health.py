"""A damaged cache heals: every bad block is moved aside, named once, and recomputed.

Each case damages the kept values of a finished study in one way (seeded), reruns
the study and compares the new result with the first one, bit for bit; ``study cache
list``, ``prune`` and ``verify`` must answer on the damaged cache without a
traceback. Every case runs under a deadline (a FIFO or ``/dev/zero`` read would
otherwise hang or exhaust memory).
"""

from __future__ import annotations

import contextlib
import os
import random
import signal
import struct
from pathlib import Path

import numpy as np
import pytest

from study.cli import main
from study.engine.cache import ResultCache
from study.engine.cache_format import MAX_BLOCK_BYTES
from study.engine.runner import run_study
from study.engine.store import open_result
from study.studies.size import MAX_CHUNK_BYTES
from tests.unit.test_incremental import spec_text

#: Seconds a case may take (a run of 45 points takes well under one).
DEADLINE = 120


@contextlib.contextmanager
def deadline(seconds: float = DEADLINE):
    """Fail (not hang) when the body blocks: SIGALRM interrupts a blocking open/read."""

    def expired(signum, frame):
        raise TimeoutError(f"still running after {seconds} s")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def study_run(folder: Path, *extra: str) -> int:
    return main(["run", str(folder / "inc.toml"), "-o", str(folder / "inc.nc"),
                 "--no-progress", *extra])


@pytest.fixture
def finished(tmp_path):
    (tmp_path / "inc.toml").write_text(spec_text())
    with deadline():
        run_study(tmp_path / "inc.toml", tmp_path / "inc.nc", progress=False)
    reference = open_result(tmp_path / "inc.nc")
    return tmp_path, {name: reference[name].values.copy() for name in ("velocity", "status")}


def cache_of(folder: Path) -> Path:
    return folder / ".study-cache"


def kept(folder: Path) -> list[Path]:
    return sorted(cache_of(folder).glob("??/*/block-*.npz"))


def garble(data: bytes, rng: random.Random) -> bytes:
    # An empty file (an earlier fuzz case may have truncated it to nothing) is garbled
    # into a few random bytes: there is no byte to overwrite.
    if not data:
        return bytes(rng.randrange(256) for _ in range(rng.randint(1, 8)))
    out = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        out[rng.randrange(len(out))] = rng.randrange(256)
    return bytes(out)


def set_zip_flag(data: bytes, bit: int) -> bytes:
    """A zip whose first member claims a feature zipfile refuses (bit 0: encrypted)."""
    out = bytearray(data)
    central = out.find(b"PK\x01\x02")
    flags = struct.unpack_from("<H", out, central + 8)[0]
    struct.pack_into("<H", out, central + 8, flags | (1 << bit))
    return bytes(out)


def damage(target: Path, how: str, rng: random.Random, outside: Path) -> None:
    data = target.read_bytes()
    if how == "truncated":
        target.write_bytes(data[:rng.randrange(1, len(data))])
    elif how == "empty":
        target.write_bytes(b"")
    elif how == "garbled":
        target.write_bytes(garble(data, rng))
    elif how == "encrypted-flag":
        target.write_bytes(set_zip_flag(data, 0))
    elif how == "not-a-zip":
        target.write_bytes(rng.randbytes(len(data)))
    elif how == "fifo":
        target.unlink()
        os.mkfifo(target)
    elif how == "folder":
        target.unlink()
        target.mkdir()
    elif how == "link-to-dev-zero":
        target.unlink()
        target.symlink_to("/dev/zero")
    elif how == "link-out-of-the-cache":
        (outside / "elsewhere.npz").write_bytes(data)  # a good block, but not in the cache
        target.unlink()
        target.symlink_to(outside / "elsewhere.npz")
    elif how == "too-large":
        with open(target, "r+b") as stream:
            stream.truncate(MAX_BLOCK_BYTES + 1)  # sparse: no disk used
    else:
        raise AssertionError(how)


KINDS = ["truncated", "empty", "garbled", "encrypted-flag", "not-a-zip", "fifo", "folder",
         "link-to-dev-zero", "link-out-of-the-cache", "too-large"]


@pytest.mark.parametrize("how", KINDS)
def test_a_bad_block_is_quarantined_named_once_and_recomputed(finished, how, capsys,
                                                              tmp_path_factory):
    folder, reference = finished
    rng = random.Random(f"block-{how}")
    target = kept(folder)[rng.randrange(len(kept(folder)))]
    outside = tmp_path_factory.mktemp("outside")
    damage(target, how, rng, outside)
    capsys.readouterr()
    with deadline():
        assert main(["cache", "list", "--cache", str(cache_of(folder))]) == 0
        listed = capsys.readouterr()
        assert "Traceback" not in listed.err
        assert study_run(folder, "--force") == 0
    err = capsys.readouterr().err
    # One warning, naming the block and where it went.
    assert err.count("\n") == 1 and err.startswith(f"study: warning: {target}: "), err
    assert f"moved to {cache_of(folder) / 'quarantine'}" in err
    result = open_result(folder / "inc.nc")
    for name, values in reference.items():
        np.testing.assert_array_equal(result[name].values, values)
    moved = cache_of(folder) / "quarantine" / target.relative_to(cache_of(folder))
    assert os.path.lexists(moved)
    assert not os.path.lexists(target)
    if how == "link-out-of-the-cache":
        assert (outside / "elsewhere.npz").is_file()  # the link moved, not its target
    # The next run reuses everything and warns about nothing.
    with deadline():
        assert study_run(folder, "--force") == 0
    assert "quarantine" not in capsys.readouterr().err


@pytest.mark.parametrize("how", KINDS)
def test_list_prune_and_verify_answer_on_a_bad_block(finished, how, capsys, tmp_path_factory):
    folder, _ = finished
    rng = random.Random(f"maintenance-{how}")
    target = kept(folder)[0]
    damage(target, how, rng, tmp_path_factory.mktemp("outside"))
    cache = str(cache_of(folder))
    capsys.readouterr()
    with deadline():
        assert main(["cache", "list", "--cache", cache]) == 0
        assert main(["cache", "prune", "--stale", "--cache", cache]) == 0
        assert main(["cache", "verify", "--cache", cache]) == 1
        out, err = capsys.readouterr()
        assert "Traceback" not in err
        assert target.name in out and "1 bad" in out
        assert not os.path.lexists(target)
        # Verified again: all good now.
        assert main(["cache", "verify", "--cache", cache]) == 0
        assert "0 bad" in capsys.readouterr().out
        assert main(["cache", "prune", "--all", "--cache", cache]) == 0
    assert not kept(folder) and not (cache_of(folder) / "quarantine").exists()


def test_seeded_garbling_never_escapes(finished, capsys):
    """Many random garblings of one block: each run answers with the reference."""
    folder, reference = finished
    rng = random.Random(19)
    target = kept(folder)[0]
    good = target.read_bytes()
    for _ in range(12):
        target.write_bytes(garble(good, rng))
        with deadline():
            assert study_run(folder, "--force") == 0
        result = open_result(folder / "inc.nc")
        np.testing.assert_array_equal(result["velocity"].values, reference["velocity"])
        # Put back the block the run wrote instead (whatever its name) for the next round.
        target = kept(folder)[0]
        good = target.read_bytes()
    capsys.readouterr()


def test_a_bad_axis_file_is_quarantined_with_its_blocks(finished, capsys):
    folder, reference = finished
    axis = next(cache_of(folder).glob("??/*/axis-*.bin"))
    axis.write_bytes(b"\x00garbage")
    with deadline():
        assert study_run(folder, "--force") == 0
    err = capsys.readouterr().err
    assert axis.name in err
    np.testing.assert_array_equal(open_result(folder / "inc.nc")["velocity"].values,
                                  reference["velocity"])


def test_a_block_of_the_previous_release_is_still_read(finished):
    """The on-disk format is unchanged: blocks written before are reused, not healed."""
    folder, _ = finished
    cache = ResultCache(cache_of(folder))
    before = kept(folder)
    report = run_study(folder / "inc.toml", folder / "inc.nc", progress=False, force=True,
                       cache=cache.root)
    assert report.points_computed == 0 and kept(folder) == before


def test_the_block_size_limit_holds_any_block_a_spec_allows():
    # A block holds at most one task's values (study.studies.size.MAX_CHUNK_BYTES), deflated
    # (at worst a little larger than the input) plus its zip headers.
    assert MAX_BLOCK_BYTES >= 2 * MAX_CHUNK_BYTES


def test_a_run_that_ends_while_a_prune_is_refused_lets_the_prune_in(tmp_path, monkeypatch):
    """A run lets go of the cache's lock, then removes its record. A prune refused by
    the lock that then finds no record has met a run just ending: the lock is free, and
    the prune goes ahead, instead of refusing with an unnamed "another process" (CI's
    race: the refusal named no pid)."""
    run, prune = ResultCache(tmp_path / "cache"), ResultCache(tmp_path / "cache")
    session = contextlib.ExitStack()
    session.enter_context(run.session("study run long.toml"))
    real = prune.live_runs

    def ending() -> list[str]:
        session.close()  # the run ends between the prune's try and its look at records
        return real()

    monkeypatch.setattr(prune, "live_runs", ending)
    with prune.maintenance("cache prune", wait=0.0):
        pass
    # A live run is still named when it holds on.
    with run.session("study run long.toml"), pytest.raises(Exception, match="pid"):
        with ResultCache(tmp_path / "cache").maintenance("cache prune", wait=0.0):
            pass

"""Seeded damage fuzz of the cache of kept values (study.engine.cache and its
study.engine.cache_* modules).

Each case damages one to three files of a finished study's cache at random (every
kind of block damage of tests/unit/test_cache_health.py, plus damaged axis files,
damaged entry records and an entry folder replaced by a link), reruns the study and
requires the reference values bit for bit, no traceback, and a cache that
``study cache verify`` then finds sound (what the run moved aside is gone from the
entries, what it wrote again is readable). Every case runs under a deadline.

Run by ``make fuzz`` (CI runs it); not part of ``make test``.
"""

from __future__ import annotations

import random
import shutil
import zipfile
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from study.cli import main
from study.engine.runner import run_study
from study.engine.store import open_result
from tests.support.reliability import record
from tests.unit.test_cache_health import KINDS, damage, deadline, garble
from tests.unit.test_incremental import spec_text

pytestmark = pytest.mark.fuzz

CASES = 60


def damage_other(cache: Path, how: str, rng: random.Random, outside: Path) -> None:
    # Entries whole and not damaged yet (an earlier case may have linked or emptied one).
    entries = sorted(e for e in cache.glob("??/*") if e.is_dir() and not e.is_symlink()
                     and (e / "entry.json").is_file() and any(e.glob("axis-*.bin")))
    if not entries:
        return
    entry = rng.choice(entries)
    if how == "axis":
        axis = next(entry.glob("axis-*.bin"))
        axis.write_bytes(garble(axis.read_bytes(), rng) if rng.random() < 0.5
                         else axis.read_bytes()[:rng.randrange(len(axis.read_bytes()))])
    elif how == "entry-record":
        record = entry / "entry.json"
        record.write_bytes(garble(record.read_bytes(), rng))
    elif how == "entry-folder-link":
        # Moved, not copied: an entry may hold a sparse "too-large" block, which a copy
        # would write out in full (a gigabyte per case).
        moved = outside / entry.name
        shutil.move(entry, moved)
        entry.symlink_to(moved, target_is_directory=True)
    else:
        raise AssertionError(how)


def test_a_damaged_cache_never_changes_a_result(tmp_path_factory, capsys):
    folder = tmp_path_factory.mktemp("fuzz")
    text = spec_text(observables='"velocity", "diagnostics"')
    (folder / "inc.toml").write_text(text)
    with deadline():
        run_study(folder / "inc.toml", folder / "inc.nc", progress=False)
    reference = open_result(folder / "inc.nc")
    expected = {name: reference[name].values.copy() for name in reference.data_vars}
    cache = folder / ".study-cache"
    rng = random.Random(1919)
    tried = Counter()
    for case in range(CASES):
        outside = tmp_path_factory.mktemp(f"outside{case}")
        for _ in range(rng.randint(1, 3)):
            how = rng.choice([*KINDS, "axis", "entry-record", "entry-folder-link"])
            tried[how] += 1
            # Blocks not damaged yet: damage() reads its target, and a FIFO, a link to
            # /dev/zero or a sparse gigabyte left by an earlier damage must not be read.
            blocks = sorted(b for b in cache.glob("??/*/block-*.npz")
                            if b.is_file() and not b.is_symlink()
                            and b.stat().st_size < 1 << 24 and zipfile.is_zipfile(b))
            if how in KINDS and blocks:
                damage(rng.choice(blocks), how, rng, outside)
            elif how not in KINDS:
                damage_other(cache, how, rng, outside)
        with deadline():
            status = main(["run", str(folder / "inc.toml"), "-o", str(folder / "inc.nc"),
                           "--force", "--no-progress"])
            err = capsys.readouterr().err
            assert status == 0 and "Traceback" not in err, (case, err)
            result = open_result(folder / "inc.nc")
            for name, values in expected.items():
                np.testing.assert_array_equal(result[name].values, values, err_msg=name)
            assert main(["cache", "list", "--cache", str(cache)]) == 0
            main(["cache", "verify", "--cache", str(cache)])  # moves what the run skipped
            assert main(["cache", "verify", "--cache", str(cache)]) == 0, case
            capsys.readouterr()
    assert sum(tried.values()) >= CASES
    record("tests/fuzz/test_damaged_cache.py",
           "cache: one to three damaged blocks, axis files, entry records or links per "
           "rerun; values bit-identical", cases=CASES, faults=sum(tried.values()),
           results_checked=CASES)

"""The counts of the reliability suite (:mod:`tests.support.reliability`): ``make fuzz``
runs its tiers in several test workers, each merging its counts into one file."""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from tests.support import reliability


def test_concurrent_records_keep_every_tier(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                            ) -> None:
    """Sixteen tiers recorded at once (each a separate open of the lock, as separate
    workers do) all reach the file, none overwritten by another's merge."""
    counts = tmp_path / "results" / "counts.json"
    monkeypatch.setenv(reliability.ENV, str(counts))
    tiers = [f"tests/fuzz/test_{k}.py" for k in range(16)]
    with ThreadPoolExecutor(8) as pool:
        list(pool.map(lambda tier: reliability.record(tier, "what", cases=3, faults=2),
                      tiers * 4))
    found = json.loads(counts.read_text(encoding="utf-8"))
    assert sorted(found) == sorted(tiers)
    assert found[tiers[0]] == {"what": "what", "cases": 3, "faults": 2,
                               "results_checked": 0, "results_lost": 0}
    assert "**48**" in reliability.table(found)  # 16 tiers of 3 cases


def test_without_the_variable_nothing_is_written(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(reliability.ENV, raising=False)
    monkeypatch.chdir(tmp_path)
    reliability.record("tests/fuzz/test_x.py", "what", cases=1, faults=1)
    assert list(tmp_path.iterdir()) == []

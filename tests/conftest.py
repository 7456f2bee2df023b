"""Shared fixtures: the paper's structure (Fig. 1-2)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import study

# tests/ holds the independent references (exact_reference, reference_integrator).
sys.path.insert(0, str(Path(__file__).parent))

PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25, "g": 9.8}


@pytest.fixture(scope="session")
def paper_structure() -> study.Structure:
    """The structure of the paper's Fig. 1-2."""
    return study.Structure(**PAPER)

"""Shared fixtures: the paper's structure (Fig. 1-2)."""

from __future__ import annotations

import pytest

import study
from study.model.paper import paper_structure as papers_structure


@pytest.fixture(scope="session")
def paper_structure() -> study.Structure:
    """The structure of the paper's Fig. 1-2 (:data:`study.model.paper.PAPER_STRUCTURE`)."""
    return papers_structure()

"""The statuses are declared once (:class:`study.model.status.Status`): the flag
attributes of the files, the statuses without a velocity, the documentation's table and
the figures' legends all follow from the enum (issue 34)."""

from __future__ import annotations

import pickle
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from study.figures.common import VALID, status_handles, status_layers
from study.model import codes
from study.model.status import INVALID_STATUSES, VELOCITY_KINDS, Status, markdown_table
from study.studies.variables import VARIABLES

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_codes_are_the_kernels_codes():
    for status in Status:
        assert int(status) == getattr(codes, status.name)


@pytest.mark.parametrize("status", list(Status), ids=lambda s: s.name)
def test_every_status_declares_its_meaning_velocity_and_legend(status):
    assert status.meaning.endswith(".")
    assert status.velocity in VELOCITY_KINDS
    assert status.legend and status.legend == status.legend.strip()
    assert status.flag == status.name.lower()
    # A status without a velocity is painted flat in the maps: it needs a colour.
    assert (status.colour is not None) == (not status.has_velocity)
    assert pickle.loads(pickle.dumps(status)) is status


def test_statuses_without_velocity_follow_from_the_declaration():
    assert INVALID_STATUSES == (Status.LIFT_OFF, Status.NOT_CONVERGED,
                                Status.FRICTION_PARADOX)
    assert set(VALID) | set(INVALID_STATUSES) == set(Status)
    assert not set(VALID) & set(INVALID_STATUSES)


def test_the_files_flags_name_every_status_in_code_order():
    for name in ("status", "status_without_flight"):
        variable = VARIABLES[name]
        assert variable.flags == tuple(s.flag for s in Status)
        assert variable.flag_values == tuple(int(s) for s in Status)


def test_the_docs_table_has_one_row_per_status_and_is_not_written_by_hand():
    table = markdown_table().splitlines()
    assert len(table) == 2 + len(Status)
    for row, status in zip(table[2:], Status, strict=True):
        assert row.startswith(f"| {int(status)} | `{status.name}` |")
        assert row.endswith(f"| {VELOCITY_KINDS[status.velocity]} |")
    page = (DOCS / "user-guide" / "python-api.md").read_text()
    assert "```{statuses}" in page
    assert "| `STATIC` |" not in page
    for status in Status:
        assert f"    {status.name}\n" in Status.__doc__


def test_the_maps_paint_and_name_each_status_without_velocity():
    status = np.array([[Status.STICK_SLIP, Status.LIFT_OFF, Status.NOT_CONVERGED],
                       [Status.FRICTION_PARADOX, Status.BOUNCING, Status.STATIC]])
    fig, ax = plt.subplots()
    try:
        painted = status_layers(ax, np.arange(3.0), np.arange(2.0), status)
        assert painted == list(INVALID_STATUSES)
        assert len(ax.collections) == len(INVALID_STATUSES)
        handles = status_handles(painted + painted)  # once each
        assert [h.get_label() for h in handles] == [s.legend for s in INVALID_STATUSES]
        colours = [matplotlib.colors.to_rgba(s.colour) for s in INVALID_STATUSES]
        assert [h.get_facecolor() for h in handles] == colours
    finally:
        plt.close(fig)

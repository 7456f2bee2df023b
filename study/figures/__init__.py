"""Figures redrawn from a result file alone: ``study figure NAME FILE``.

Each figure module has ``draw(dataset, output) -> list[Path]`` and computes nothing
the file does not hold (closed-form force traces at the paper's four points are
evaluated from the structure parameters stored in the file).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path

import xarray as xr

__all__ = ["FIGURES", "FigureError", "draw_figure"]


class FigureError(ValueError):
    """A result file that lacks what a figure needs."""


@dataclass(frozen=True)
class Figure:
    """A registered figure: its module, the workflow that makes its data, what it needs."""

    module: str
    workflow: str
    requires: tuple[str, ...]
    shows: str


FIGURES: dict[str, Figure] = {
    "thresholds": Figure(
        "study.figures.thresholds", "thresholds",
        ("a_star_plus", "a_star_minus", "mode_gain"),
        "Fig. 1B: thresholds a*_+ and a*_- against frequency, the mode's resonance behind",
    ),
    "velocity-curves": Figure(
        "study.figures.velocity_curves", "velocity-curves",
        ("velocity", "status"),
        "Fig. 1C inset: velocity against acceleration at fixed frequencies 10-20 Hz",
    ),
    "regime-map": Figure(
        "study.figures.regime_map", "regime-map",
        ("velocity", "status", "a_star_plus", "a_star_minus", "lift_off_acceleration",
         "frontier_frequency"),
        "Fig. 2: velocity over (f, a), regions S, P, N, PN, thresholds and frontier f*(a)",
    ),
    "force-traces": Figure(
        "study.figures.force_traces", "regime-map",
        ("velocity",),
        "Fig. 2 insets: n(t) and tau(t)/cs at the paper's points in S, P, N and PN",
    ),
    "mass-ratio": Figure(
        "study.figures.mass_ratio", "mass-ratio",
        ("a_star_plus", "a_star_minus", "M"),
        "Fig. 3: thresholds for the paper's loads and the minimum threshold against M",
    ),
    "threshold-collapse": Figure(
        "study.figures.threshold_collapse", "threshold-collapse",
        ("a_star_plus", "a_star_minus"),
        "Q m1 ~ m: minimum thresholds for many Q and M collapse onto one closed form",
    ),
    "mass-ratio-limit": Figure(
        "study.figures.mass_ratio_limit", "mass-ratio-limit",
        ("velocity", "status", "frontier_frequency"),
        "The limit M -> 1: regime maps and frontier branches from M = 0.08 to 1",
    ),
    "coupling": Figure(
        "study.figures.coupling", "coupling",
        ("velocity", "status", "velocity_one_way", "status_one_way", "M"),
        "Two-way against one-way coupling over M: where the paper's model stops holding",
    ),
    "steering": Figure(
        "study.figures.steering", "steering",
        ("x", "y", "heading", "segment_index", "segment_label", "frequency"),
        "Fig. 4A: the disk steered by a frequency sequence, path coloured by segment",
    ),
    "steering-calibration": Figure(
        "study.figures.steering_calibration", "steering-calibration",
        ("forward_speed", "turn_rate", "status"),
        "Steering commands: the disk's forward speed and turn rate against frequency",
    ),
    "steering-plan": Figure(
        "study.figures.steering_plan", "steering-plan",
        ("waypoint_x", "waypoint_y", "x", "y", "miss_distance"),
        "Steering through waypoints: open-loop plan against closed-loop correction",
    ),
}


def draw_figure(name: str, dataset: xr.Dataset, output: str | Path) -> list[Path]:
    """Draw figure ``name`` from a (validated) result dataset into ``output.png/.pdf``.

    Raises
    ------
    FigureError
        For an unknown figure, or a dataset without the variables it needs (the
        message names them and the workflow that makes them).
    """
    if name not in FIGURES:
        raise FigureError(f"unknown figure {name!r}; figures: {', '.join(FIGURES)}")
    figure = FIGURES[name]
    missing = [v for v in figure.requires if v not in dataset.variables]
    if missing:
        raise FigureError(
            f"figure {name!r} needs {', '.join(missing)}, which this file does not hold "
            f"(study {dataset.attrs.get('study_name')!r}); it is drawn from the "
            f"'{figure.workflow}' workflow: workflows/{figure.workflow}.toml"
        )
    module = importlib.import_module(figure.module)
    return module.draw(dataset, Path(output))

"""Figures redrawn from a result file alone: ``study figure NAME FILE``.

Each figure module has ``draw(dataset, output, **options) -> list[Path]`` and computes
nothing the file does not hold (closed-form force traces are evaluated from the
structure parameters stored in the file). :func:`draw_figure` first applies the
``--sel`` selections (:mod:`study.analyses.selection`), so that every figure draws any study
whose other axes are selected; a figure takes the options it declares
(:attr:`Figure.options`): ``points`` (``--point F,A``) and ``measurements``
(``--measurements FILE.csv``, :mod:`study.analyses.measurements`).
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import xarray as xr

from study.analyses.selection import select
from study.figures.record import DRAWN_FROM, drawn_from

__all__ = ["FIGURES", "FigureError", "draw_figure", "figure_request", "is_current"]


class FigureError(ValueError):
    """A result file that lacks what a figure needs."""


@dataclass(frozen=True)
class Figure:
    """A registered figure: its module, the workflow that makes its data, what it needs,
    and the options of :func:`draw_figure` it takes (``points``, ``measurements``)."""

    module: str
    workflow: str
    requires: tuple[str, ...]
    shows: str
    options: tuple[str, ...] = ()

    @property
    def source(self) -> str:
        """Where its data come from, for messages."""
        if self.workflow == "fit":
            return "a 'study fit' result (docs/user-guide/measurements-and-fits.md)"
        return f"the '{self.workflow}' workflow: workflows/{self.workflow}.toml"


FIGURES: dict[str, Figure] = {
    "thresholds": Figure(
        "study.figures.thresholds", "thresholds",
        ("a_star_plus", "a_star_minus", "mode_gain"),
        "Fig. 1B: thresholds a*_+ and a*_- against frequency, the mode's resonance behind",
        ("measurements",),
    ),
    "velocity-curves": Figure(
        "study.figures.velocity_curves", "velocity-curves",
        ("velocity", "status"),
        "Fig. 1C inset: velocity against acceleration at fixed frequencies",
        ("measurements",),
    ),
    "regime-map": Figure(
        "study.figures.regime_map", "regime-map",
        ("velocity", "status", "a_star_plus", "a_star_minus", "lift_off_acceleration"),
        "Fig. 2: velocity over (f, a), regions S, P, N, PN, thresholds and, when the study "
        "computed it, the frontier f*(a)",
    ),
    "force-traces": Figure(
        "study.figures.force_traces", "regime-map",
        ("velocity",),
        "Fig. 2 insets: n(t) and tau(t)/cs at chosen points (the paper's S, P, N, PN)",
        ("points",),
    ),
    "mass-ratio": Figure(
        "study.figures.mass_ratio", "mass-ratio",
        ("a_star_plus", "a_star_minus", "M"),
        "Fig. 3: thresholds for on-board loads and the minimum threshold against M",
        ("measurements",),
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
    "bouncing": Figure(
        "study.figures.bouncing", "mass-ratio-limit-flight",
        ("velocity", "status", "largest_hop", "airborne_fraction"),
        "With flight: velocity, largest hop and time in the air over (f, a) per M, the "
        "bouncing region's edge and the frontier f*(a) through it",
    ),
    "lyapunov": Figure(
        "study.figures.lyapunov", "irregular-bouncing",
        ("velocity", "status", "lyapunov_exponent"),
        "Irregular motion: the mean velocity with chaotic and quasi-periodic points "
        "hatched, and the largest Lyapunov exponent over (f, a)",
    ),
    "bifurcation": Figure(
        "study.figures.bifurcation", "bifurcation-along-a",
        ("section_speed", "velocity", "status", "lyapunov_exponent"),
        "Bifurcation diagram: the phase-0 section of the motion against f or a, coloured "
        "by the largest Lyapunov exponent, the mean velocity beneath",
    ),
    "hysteresis": Figure(
        "study.figures.hysteresis", "hysteresis-flight",
        ("velocity", "status", "jumped"),
        "Slow sweeps up and down: the velocity against the swept drive with the jumps "
        "marked, or over a map where the two sweeps end on different motions",
    ),
    "branch-diagram": Figure(
        "study.figures.branch_diagram", "hysteresis-flight",
        ("velocity", "jumped", "branch_sweep", "branch_steps", "branch_start_f",
         "branch_start_a", "branch_f", "branch_a", "branch_velocity", "branch_stable",
         "branch_largest_hop", "branch_bifurcation_kind", "branch_bifurcation_f",
         "branch_bifurcation_a", "branch_bifurcation_velocity", "branch_bifurcation_step"),
        "Bifurcation diagram of slow sweeps: the branches they ride (stable solid, unstable "
        "dashed, each bifurcation marked), the sweeps' velocities and located jumps over "
        "them, per value of the other drive axis",
    ),
    "fold-curves": Figure(
        "study.figures.fold_curves", "mass-ratio-folds",
        ("velocity", "jump_bifurcation", "jump_f", "jump_velocity"),
        "Where the forward and backward hops coexist: their fold curves f(a) located "
        "exactly from slow sweeps both ways, per value of a structure axis (M)",
    ),
    "basins": Figure(
        "study.figures.basins", "basins-flight",
        ("basin_status", "basin_velocity", "basin_largest_hop", "basin_period",
         "basin_fraction"),
        "Basins: each motion followed across the drive (global continuation), its region "
        "coloured by its basin fraction over (f, a), or the fractions stacked along one "
        "axis",
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
    "fit": Figure(
        "study.figures.fit_result", "fit",
        ("estimate", "standard_error", "quantity", "value", "sigma"),
        "A fit: measurements with error bars over the fitted thresholds and velocities",
    ),
}

#: The command-line spelling of each option, for messages.
_OPTION_FLAGS = {"points": "--point", "measurements": "--measurements"}


def _missing_message(name: str, dataset: xr.Dataset, missing: Sequence[str]) -> str:
    """Why figure ``name`` cannot be drawn from ``dataset``, and the observables to add
    to the study's spec (from the registry's declared variables) when a spec can."""
    from study.engine.validation import RESULT_SCHEMA
    from study.studies.observables import OBSERVABLES

    figure = FIGURES[name]
    message = (f"figure {name!r} needs {', '.join(missing)}, which this file does not hold "
               f"(study {dataset.attrs.get('study_name')!r})")
    flight_only = {v for o in OBSERVABLES.values() for v in o.flight_variables}
    if set(missing) & flight_only and dataset.attrs.get("study_result_schema") == RESULT_SCHEMA:
        return (f"{message}: they are written only by a study with flight; add [solver] "
                f'flight = true (with coupling = "two-way") to the spec and run it again, '
                f"or draw it from {figure.source}")
    swept_only = {v for o in OBSERVABLES.values() for v in o.protocol_variables}
    swept = [v for v in missing if v in swept_only]
    if swept and dataset.attrs.get("study_result_schema") == RESULT_SCHEMA:
        message += (f": {', '.join(swept)} {'is' if len(swept) == 1 else 'are'} written "
                    "only by a slow sweep; add [sweep] protocol = { along = \"f\", "
                    "direction = \"both\" } (the axis swept, \"f\" or \"a\"; exact "
                    "two-way solver: [solver] coupling = \"two-way\") to the spec")
        missing = [v for v in missing if v not in swept_only]
        if not missing:
            return f"{message} and run it again, or draw it from {figure.source}"
    writers = [o.name for o in OBSERVABLES.values() if set(o.variables) & set(missing)]
    if writers and dataset.attrs.get("study_result_schema") == RESULT_SCHEMA:
        held = {o.name for o in OBSERVABLES.values()
                if all(v in dataset.variables for v in o.variables)}
        listed = ", ".join(f'"{n}"' for n in OBSERVABLES if n in held or n in writers)
        message += (f"; add {', '.join(map(repr, writers))} to the spec's observables "
                    f"(observables = [{listed}]) and run it again, or draw it from "
                    f"{figure.source}")
        return message
    return f"{message}; it is drawn from {figure.source}"


def draw_figure(name: str, dataset: xr.Dataset, output: str | Path, *,
                sel: Iterable[str] = (), source: str = "",
                points: Sequence[tuple[float, float]] | None = None,
                measurements: Sequence[str | Path] | None = None) -> list[Path]:
    """Draw figure ``name`` from a (validated) result dataset into ``output.png/.pdf``.

    Parameters
    ----------
    name : str
        A key of :data:`FIGURES`.
    dataset : xarray.Dataset
        The result.
    output : path
        File stem.
    sel : iterable of str
        ``--sel`` selections (``"Q=30"``, ``"M==0.1"``, ``"a=0:9"``) applied first; the
        title says what was selected.
    source : str
        The file's name, for messages.
    points : sequence of (f, a), optional
        ``force-traces``: the drive points to draw (default: the paper's four for the
        paper's structure, else one per region the file holds).
    measurements : sequence of paths, optional
        ``thresholds``, ``velocity-curves``, ``mass-ratio``: measurement files
        (:mod:`study.analyses.measurements`) drawn with error bars over the model.

    Raises
    ------
    FigureError
        For an unknown figure, an option it does not take, a dataset without the
        variables it needs (the message names them and the workflow that makes them),
        or more axes than it draws (the message names the ``--sel`` keys to give).
    study.analyses.selection.SelectionError
        For a selection that does not apply (the available values listed).
    study.analyses.measurements.MeasurementError
        For an unreadable or invalid measurement file.
    """
    if name not in FIGURES:
        raise FigureError(f"unknown figure {name!r}; figures: {', '.join(FIGURES)}")
    figure = FIGURES[name]
    options = {"points": points, "measurements": measurements}
    for option, value in options.items():
        if value and option not in figure.options:
            takers = [n for n, f in FIGURES.items() if option in f.options]
            raise FigureError(f"figure {name!r} takes no {_OPTION_FLAGS[option]}; it is "
                              f"an option of {', '.join(takers)}")
    missing = [v for v in figure.requires if v not in dataset.variables]
    if missing:
        raise FigureError(_missing_message(name, dataset, missing))
    sel = list(sel)
    request = figure_request(name, dataset, sel=sel, points=points,
                             measurements=measurements)
    if sel:
        dataset = select(dataset, sel, source=source)
    else:
        dataset = dataset.copy(deep=False)  # the record below is this drawing's own
    dataset.attrs[DRAWN_FROM] = request
    module = importlib.import_module(figure.module)
    kwargs = {k: v for k, v in options.items() if v}
    return module.draw(dataset, Path(output), **kwargs)


def figure_request(name: str, dataset: xr.Dataset, *, sel: Iterable[str] = (),
                   points: Sequence[tuple[float, float]] | None = None,
                   measurements: Sequence[str | Path] | None = None) -> str:
    """What a drawing of figure ``name`` depends on, as one JSON line: the figure, the
    result's content checksum, the options, every measurement file's sha256 and the
    code fingerprint of the figure's modules.

    Two drawings with the same request draw the same picture; :func:`draw_figure`
    stores it in the PNG, and :func:`is_current` compares against it.
    """
    import hashlib
    import json

    from study.analyses.measurements import MeasurementError, measurement_file_bytes
    from study.engine.fingerprint import code_fingerprint

    if name not in FIGURES:
        raise FigureError(f"unknown figure {name!r}; figures: {', '.join(FIGURES)}")
    files = []
    for path in measurements or ():
        try:  # as the figure reads it: never a FIFO, a device or beyond the size limit
            digest = hashlib.sha256(measurement_file_bytes(path)).hexdigest()
        except MeasurementError:
            digest = None  # unreadable: draw_figure says why
        files.append([str(path), digest])
    code = code_fingerprint(("study.figures", FIGURES[name].module)).sha256
    return json.dumps({
        "figure": name,
        "content_sha256": dataset.attrs.get("study_content_sha256"),
        "sel": list(sel),
        "points": [list(map(float, p)) for p in points or ()],
        "measurements": files,
        "code_sha256": code,
    }, sort_keys=True)


def is_current(output: str | Path, request: str) -> bool:
    """Whether ``output.png`` and ``output.pdf`` exist and the PNG was drawn for exactly
    ``request`` (:func:`figure_request`): same figure, data, options and code."""
    stem = Path(output)
    if stem.suffix in (".png", ".pdf"):
        stem = stem.with_suffix("")
    import json

    if json.loads(request).get("content_sha256") is None:
        return False  # data without a checksum: nothing proves it is the same data
    pdf = stem.with_suffix(".pdf")
    return pdf.is_file() and drawn_from(stem.with_suffix(".png")) == request

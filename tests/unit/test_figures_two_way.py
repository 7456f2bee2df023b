"""Every figure of a velocity study drawn from a small two-way study file (exact solver),
each saying in its title which coupling the file holds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from study.cli import main
from study.engine.runner import run_study
from study.engine.store import open_result
from study.figures import FIGURES, draw_figure
from study.figures.common import coupling_label
from study.model.status import Status
from tests.support.tiers import headline

STRUCTURE = """\
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
cs = 0.25
"""

TWO_WAY = """\
[solver]
coupling = "two-way"
"""

SPECS = {
    "map": """\
[study]
name = "map-two-way"
observables = ["resonance", "thresholds", "lift_off", "velocity", "diagnostics", "floquet",
               "paper_model", "frontier"]
{structure}M = 0.08
[sweep]
f = {{ start = 10.0, stop = 20.0, num = 41 }}
a = {{ start = 0.0, stop = 12.0, num = 31 }}
{solver}""",
    "curves": """\
[study]
name = "curves-two-way"
observables = ["thresholds", "lift_off", "velocity", "paper_model"]
{structure}M = 0.08
[sweep]
f = {{ values = [12.0, 14.5, 16.0] }}
a = {{ start = 0.0, stop = 12.0, num = 31 }}
{solver}""",
    "masses": """\
[study]
name = "masses-two-way"
observables = ["thresholds", "lift_off", "velocity", "paper_model", "frontier"]
{structure}
[sweep]
M = {{ values = [0.08, 1.0] }}
f = {{ start = 5.0, stop = 30.0, num = 26 }}
a = {{ start = 0.0, stop = 12.0, num = 13 }}
{solver}""",
    "loads": """\
[study]
name = "loads-two-way"
observables = ["thresholds", "lift_off", "velocity"]
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
cs = 0.25
[structure.mass]
m0 = 8.2e-3
m1_fraction = 0.08
[sweep]
m_add = {{ values = [0.0, 16.6e-3] }}
f = {{ start = 10.0, stop = 20.0, num = 41 }}
a = {{ start = 0.0, stop = 12.0, num = 7 }}
{solver}""",
}

#: figure -> the small two-way file it is drawn from.
SOURCES = {
    "regime-map": "map",
    "force-traces": "map",
    "velocity-curves": "curves",
    "mass-ratio-limit": "masses",
    "coupling": "masses",
    "mass-ratio": "loads",
}


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("two-way-figures")
    files = {}
    for name, text in SPECS.items():
        spec = folder / f"{name}.toml"
        spec.write_text(text.format(structure=STRUCTURE, solver=TWO_WAY))
        files[name] = folder / f"{name}.nc"
        run_study(spec, files[name], progress=False, workers=1)
    return files


def test_the_small_files_are_exact_two_way_studies(results):
    for path in results.values():
        dataset = open_result(path)
        assert dataset.attrs["study_coupling"] == "two-way"
        assert dataset.attrs["study_solver_method"] == "exact"
    floquet = open_result(results["map"])["floquet_multiplier"].values
    moving = np.isfinite(floquet) & (floquet > 0)
    assert np.any(moving) and np.all(floquet[moving] < 1.0 + 1e-6)  # attracting orbits


def test_every_velocity_figure_is_covered():
    velocity_figures = {name for name, figure in FIGURES.items()
                        if "velocity" in figure.requires}
    # bouncing, lyapunov and bifurcation: drawn from studies with flight
    # (tests/unit/test_figures_flight.py); hysteresis from slow sweeps
    # (tests/unit/test_figures_hysteresis.py, tests/unit/test_figures_selection.py),
    # fold-curves from slow sweeps with jumps (tests/unit/test_hop_folds.py),
    # branch-diagram from slow sweeps with branches (tests/unit/test_swept_branches.py).
    assert velocity_figures <= set(SOURCES) | {"mass-ratio", "bouncing", "lyapunov",
                                               "bifurcation", "hysteresis", "fold-curves",
                                               "branch-diagram"}


@pytest.mark.parametrize("figure", headline(sorted(SOURCES)))
def test_figure_of_a_two_way_file_says_two_way(figure, results, tmp_path):
    source = results[SOURCES[figure]]
    stem = tmp_path / figure
    assert main(["figure", figure, str(source), "-o", str(stem)]) == 0
    png = stem.with_suffix(".png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert stem.with_suffix(".pdf").read_bytes()[:4] == b"%PDF"
    with Image.open(png) as image:
        title = dict(image.text)["Title"]
    assert "two-way coupling" in title, title
    assert coupling_label(open_result(source)) in title


@pytest.mark.parametrize("figure", ["regime-map", "velocity-curves", "force-traces"])
def test_figure_of_a_one_way_file_says_one_way(figure, tmp_path):
    spec = tmp_path / "one-way.toml"
    text = SPECS[SOURCES[figure]].format(structure=STRUCTURE, solver="")
    spec.write_text(text.replace(' "floquet",', "").replace(', "paper_model"', "")
                    .replace(' "paper_model",', ""))
    run_study(spec, tmp_path / "one-way.nc", progress=False, workers=1)
    dataset = open_result(tmp_path / "one-way.nc")
    assert dataset.attrs["study_coupling"] == "one-way"
    png, _ = draw_figure(figure, dataset, tmp_path / figure)
    with Image.open(png) as image:
        title = dict(image.text)["Title"]
    assert "one-way coupling (the paper's model)" in title, title


def _legend_labels(source, figure, tmp_path, monkeypatch) -> list[str]:
    from study.figures import common

    kept = []
    close = common.plt.close
    monkeypatch.setattr(common.plt, "close", lambda fig=None: kept.append(fig))
    draw_figure(figure, open_result(source), tmp_path / figure)
    (fig,) = kept
    labels = [t.get_text() for legend in fig.legends + [ax.get_legend() for ax in fig.axes]
              if legend is not None for t in legend.get_texts()]
    close(fig)
    return labels


def _drawn_lines(source, figure, tmp_path, monkeypatch):
    """The figure's legend labels and the y data of every line on its maps."""
    from study.figures import common

    kept = []
    close = common.plt.close
    monkeypatch.setattr(common.plt, "close", lambda fig=None: kept.append(fig))
    draw_figure(figure, open_result(source), tmp_path / figure)
    (fig,) = kept
    labels = [t.get_text() for legend in fig.legends + [ax.get_legend() for ax in fig.axes]
              if legend is not None for t in legend.get_texts()]
    lines = [np.asarray(line.get_ydata(), dtype=float) for ax in fig.axes
             for line in ax.get_lines()]
    close(fig)
    return labels, lines


@pytest.mark.parametrize("figure", ["regime-map", "mass-ratio-limit"])
def test_a_two_way_map_draws_its_own_lift_off_not_the_one_way_estimate(
        figure, results, tmp_path, monkeypatch):
    """The closed-form lift-off is that of a base at rest (the one-way model's): a
    sliding two-way base lifts off elsewhere (at M = 1 near 5 m s-2 where the estimate
    says under 3), so a two-way map draws the study's own lift-off (its lift_off points)
    and not the estimate: no line of it, no legend entry."""
    source = results[SOURCES[figure]]
    labels, lines = _drawn_lines(source, figure, tmp_path, monkeypatch)
    dataset = open_result(source)
    estimate = dataset["lift_off_acceleration"]
    estimates = ([estimate.values] if "M" not in estimate.dims else
                 [estimate.isel(M=i).values for i in range(dataset.sizes["M"])])
    drawn = [line for line in lines if any(
        line.shape == e.shape and np.allclose(line, e, equal_nan=True) for e in estimates)]
    assert not drawn
    assert not any(label.startswith("lift-off of the base at rest") for label in labels), labels
    assert not any("n < 0 above" in label for label in labels), labels
    # Its own lift-off instead: the points that leave the table, in the legend.
    assert int((dataset["status"] == Status.LIFT_OFF).sum()) > 0
    assert any(label.startswith("lift-off: outside the model") for label in labels), labels

"""Figures drawn from result files: thresholds, velocity curves, regime map, force traces."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from study.cli import main
from study.engine.runner import run_study
from study.engine.store import open_result
from study.figures import FIGURES, draw_figure
from study.figures.force_traces import region_of
from study.figures.velocity_curves import frequency_position
from study.model.status import Status
from tests.support.tiers import headline

STRUCTURE = """\
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25
"""

SPECS = {
    "thresholds": """\
[study]
name = "thresholds"
observables = ["resonance", "thresholds", "lift_off"]
{structure}
[sweep]
f = {{ start = 10.0, stop = 20.0, num = 41 }}
""",
    "velocity-curves": """\
[study]
name = "velocity-curves"
observables = ["thresholds", "lift_off", "velocity"]
{structure}
[sweep]
f = {{ values = [12.0, 14.0, 14.5, 16.0] }}
a = {{ start = 0.0, stop = 12.0, num = 31 }}
""",
    "regime-map": """\
[study]
name = "regime-map"
observables = ["resonance", "thresholds", "lift_off", "velocity", "frontier"]
{structure}
[sweep]
f = {{ start = 10.0, stop = 20.0, num = 41 }}
a = {{ start = 0.0, stop = 12.0, num = 31 }}
""",
}

#: figure -> the result it is drawn from in these tests.
SOURCES = {
    "thresholds": "thresholds",
    "velocity-curves": "velocity-curves",
    "regime-map": "regime-map",
    "force-traces": "regime-map",
}


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> dict[str, Path]:
    """Small result files of the three workflows these figures are drawn from."""
    folder = tmp_path_factory.mktemp("figure-results")
    files = {}
    for name, text in SPECS.items():
        spec = folder / f"{name}.toml"
        spec.write_text(text.format(structure=STRUCTURE))
        files[name] = folder / f"{name}.nc"
        run_study(spec, files[name], progress=False, workers=1)
    return files


def test_the_small_specs_hold_what_their_figures_require(results):
    for figure, source in SOURCES.items():
        dataset = open_result(results[source])
        missing = [v for v in FIGURES[figure].requires if v not in dataset.variables]
        assert not missing, (figure, missing)


@pytest.mark.parametrize("figure", headline(sorted(SOURCES)))
def test_figure_command_writes_png_and_pdf_with_provenance(figure, results, tmp_path, capsys):
    source = results[SOURCES[figure]]
    stem = tmp_path / figure
    assert main(["figure", figure, str(source), "-o", str(stem)]) == 0
    png, pdf = stem.with_suffix(".png"), stem.with_suffix(".pdf")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert pdf.read_bytes()[:4] == b"%PDF"
    assert str(png) in capsys.readouterr().out
    sha = open_result(source).attrs["study_spec_sha256"]
    with Image.open(png) as image:
        text = dict(image.text)
        width, height = image.size
    assert sha in text["Source"]
    assert sha in text["Description"]
    assert text["Title"]
    assert width >= 900 and height >= 600  # 150 dpi, a readable size


@pytest.mark.parametrize(
    ("figure", "source", "missing"),
    [
        ("regime-map", "thresholds", "velocity"),
        ("thresholds", "velocity-curves", "mode_gain"),
        ("velocity-curves", "thresholds", "status"),
        ("force-traces", "thresholds", "velocity"),
    ],
)
def test_a_file_without_a_required_variable_is_refused(figure, source, missing, results,
                                                       tmp_path, capsys):
    stem = tmp_path / figure
    assert main(["figure", figure, str(results[source]), "-o", str(stem)]) == 1
    message = capsys.readouterr().err
    assert missing in message
    assert f"workflows/{FIGURES[figure].workflow}.toml" in message
    assert not stem.with_suffix(".png").exists()


def test_a_file_sweeping_the_structure_is_refused(results, tmp_path, capsys):
    spec = tmp_path / "swept.toml"
    spec.write_text(
        SPECS["thresholds"].format(structure=STRUCTURE.replace("M = 0.08\n", ""))
        .replace("[sweep]\n", "[sweep]\nM = { values = [0.05, 0.08] }\n")
    )
    run_study(spec, tmp_path / "swept.nc", progress=False, workers=1)
    assert main(["figure", "thresholds", str(tmp_path / "swept.nc"),
                 "-o", str(tmp_path / "fig")]) == 1
    assert "sweeps M" in capsys.readouterr().err


@pytest.mark.parametrize("figure", ["regime-map", "velocity-curves"])
def test_unconverged_and_sliding_points_are_drawn_apart(figure, results, tmp_path):
    """Statuses absent from the small maps (not converged, continuous sliding) draw too."""
    dataset = open_result(results[SOURCES[figure]])
    status = dataset["status"].values
    velocity = dataset["velocity"].values
    moving = np.argwhere(status == Status.STICK_SLIP)
    status[tuple(moving[0])] = Status.NOT_CONVERGED
    velocity[tuple(moving[0])] = np.nan
    status[tuple(moving[-1])] = Status.CONTINUOUS_SLIDING
    written = draw_figure(figure, dataset, tmp_path / figure)
    assert [p.suffix for p in written] == [".png", ".pdf"]
    assert all(p.stat().st_size > 1000 for p in written)


def test_region_names_follow_the_thresholds():
    assert region_of(1.0, 2.0, 3.0) == "S"
    assert region_of(2.5, 2.0, 3.0) == "P"
    assert region_of(2.5, 3.0, 2.0) == "N"
    assert region_of(3.5, 2.0, 3.0) == "PN"


def test_frequency_colours_diverge_from_the_resonance():
    f = np.array([10.0, 14.0, 14.44, 15.0, 20.0])
    position = frequency_position(f, 14.44)
    assert position[2] == pytest.approx(0.5)
    assert np.all(np.diff(position) > 0)
    assert position[0] < 0.5 < position[-1]
    assert 0.0 <= position.min() and position.max() <= 1.0


README_SPEC = """\
[study]
name = "own"
observables = ["thresholds", "velocity"]
{structure}
[sweep]
f = {{ start = 10.0, stop = 20.0, num = 5 }}
a = {{ start = 0.0, stop = 12.0, num = 4 }}
"""


def test_a_refusal_names_the_observables_to_add(tmp_path, capsys):
    """The README's example spec (thresholds, velocity) drawn as regime-map: the message
    names lift_off, the observable the registry says writes the missing variable, and
    the spec so extended holds everything the figure needs (the frontier is optional)."""
    from study.studies.observables import variables_of

    spec = tmp_path / "own.toml"
    spec.write_text(README_SPEC.format(structure=STRUCTURE))
    run_study(spec, tmp_path / "own.nc", progress=False, workers=1)
    assert main(["figure", "regime-map", str(tmp_path / "own.nc"), "-o",
                 str(tmp_path / "x")]) == 1
    message = capsys.readouterr().err
    assert "needs lift_off_acceleration, which" in message
    assert ("add 'lift_off' to the spec's observables (observables = "
            '["thresholds", "lift_off", "velocity"])') in message
    suggested = ["thresholds", "lift_off", "velocity"]
    written = {v.name for v in variables_of(suggested)}
    assert set(FIGURES["regime-map"].requires) <= written
    assert not set(FIGURES["regime-map"].requires) <= {v.name for v in variables_of(
        ["thresholds", "velocity"])}


def _legend_labels(figure) -> list[str]:
    return [t.get_text() for legend in figure.legends + [ax.get_legend() for ax in figure.axes]
            if legend is not None for t in legend.get_texts()]


def test_a_regime_map_without_the_frontier_is_drawn_and_says_so(results, tmp_path,
                                                                monkeypatch):
    """The frontier's bisections can cost more than the map (15x on a flight study):
    a study without the observable ``frontier`` draws its map, and the legend says the
    frontier was not computed; with it, the legend names the frontier's line instead.
    (Refused before: figure 'regime-map' needed frontier_frequency.)"""
    import matplotlib.pyplot as plt

    from study.figures import common, regime_map

    drawn = {}

    def keep(fig, output, dataset, description):
        drawn[output.name] = _legend_labels(fig)
        plt.close(fig)
        return []

    monkeypatch.setattr(common, "save", keep)
    full = open_result(results["regime-map"])
    draw_figure("regime-map", full.drop_vars([v for v in full.variables
                                               if str(v).startswith("frontier_")]),
                tmp_path / "without")
    draw_figure("regime-map", full, tmp_path / "with")
    assert regime_map.NO_FRONTIER in drawn["without"]
    assert "frontier f*(a): v changes sign" not in drawn["without"]
    assert "frontier f*(a): v changes sign" in drawn["with"]
    assert regime_map.NO_FRONTIER not in drawn["with"]
    assert "not computed" in regime_map.NO_FRONTIER

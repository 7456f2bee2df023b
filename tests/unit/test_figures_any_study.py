"""Figures for any study (issue 13): a structure of one's own with Q and M swept, drawn
with --sel; the paper's points only on the paper's structure; colour bars for many
curves; force traces at named points; measurements beside the model."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

from study.cli import main
from study.engine.runner import run_study
from study.engine.store import open_result
from study.figures import FIGURES, FigureError, common, draw_figure
from study.model.paper import PAPER_STRUCTURE, is_paper_structure, paper_structure
from tests.support.tiers import headline

#: The issue's new user: f0 = 22 Hz, Q = 30, alpha = 45, M = 0.15, cs = 0.35, ck = 0.3.
OWN = """\
[study]
name = "own"
observables = ["resonance", "thresholds", "lift_off", "velocity", "frontier"]
[structure]
f0 = 22.0
alpha = 45.0
cs = 0.35
ck = 0.3
[sweep]
Q = { values = [15.0, 30.0] }
M = { values = [0.1, 0.15] }
f = { start = 15.0, stop = 30.0, num = 16 }
a = { start = 0.0, stop = 12.0, num = 13 }
"""

MANY_CURVES = """\
[study]
name = "many-curves"
observables = ["thresholds", "lift_off", "velocity"]
[structure]
f0 = 22.0
Q = 30.0
alpha = 45.0
M = 0.15
cs = 0.35
ck = 0.3
[sweep]
f = { start = 15.0, stop = 30.0, num = 12 }
a = { start = 0.0, stop = 12.0, num = 7 }
"""

Q_SWEPT = """\
[study]
name = "q-swept"
observables = ["thresholds", "lift_off"]
[structure]
f0 = 22.0
alpha = 45.0
M = 0.15
cs = 0.35
ck = 0.3
[sweep]
Q = { start = 5.0, stop = 60.0, num = 12 }
f = { start = 15.0, stop = 30.0, num = 61 }
"""

LOADS = """\
[study]
name = "loads"
observables = ["thresholds", "lift_off"]
[structure]
f0 = 22.0
Q = 30.0
alpha = 45.0
cs = 0.35
ck = 0.3
[structure.mass]
m0 = 10e-3
m1_fraction = 0.15
[sweep]
m_add = { values = [0.0, 2e-3, 5e-3] }
f = { start = 15.0, stop = 30.0, num = 61 }
"""

PAPER_MAP = """\
[study]
name = "paper-map"
observables = ["thresholds", "lift_off", "velocity", "frontier"]
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25
[sweep]
f = { start = 10.0, stop = 20.0, num = 21 }
a = { start = 0.0, stop = 12.0, num = 13 }
"""

LAB = """\
quantity,f,a,value,sigma,direction,M
threshold,18.0,,4.6,0.2,forward,
threshold,26.0,,5.5,0.3,backward,
threshold,22.0,,1.3,0.1,,
threshold,20.0,,2.4,,unknown,0.15
threshold,20.0,,2.9,0.2,unknown,0.1
velocity,21.0,5.0,0.004,0.0005,,
velocity,24.0,8.0,-0.008,0.001,,
"""

LOAD_LAB = """\
quantity,f,value,sigma,m_add,direction
threshold,22.0,1.4,0.1,0.0,unknown
threshold,20.0,2.5,0.2,0.0,forward
threshold,21.5,1.7,0.1,0.002,unknown
threshold,21.0,2.3,0.2,0.008,unknown
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("any-study")
    out = {}
    for name, text in (("own", OWN), ("many", MANY_CURVES), ("q", Q_SWEPT),
                       ("loads", LOADS), ("paper", PAPER_MAP)):
        (folder / f"{name}.toml").write_text(text)
        out[name] = folder / f"{name}.nc"
        run_study(folder / f"{name}.toml", out[name], progress=False, workers=1)
    (folder / "lab.csv").write_text(LAB)
    (folder / "loads.csv").write_text(LOAD_LAB)
    out["lab"] = folder / "lab.csv"
    out["load-lab"] = folder / "loads.csv"
    return out


def _title(png: Path) -> str:
    with Image.open(png) as image:
        return dict(image.text)["Title"]


@pytest.fixture
def drawn(monkeypatch):
    """The matplotlib figures saved (``common.save`` closes each), kept for inspection."""
    figures = []
    close = common.plt.close

    def keep(fig=None):
        if isinstance(fig, Figure):
            figures.append(fig)
        return close(fig)

    monkeypatch.setattr(common.plt, "close", keep)
    return figures


def _texts(fig) -> list[str]:
    found = [t.get_text() for ax in fig.axes for t in ax.texts]
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is not None:
            found += [t.get_text() for t in legend.get_texts()]
    for legend in fig.legends:
        found += [t.get_text() for t in legend.get_texts()]
    return found


def test_the_paper_structure_is_in_one_place():
    assert is_paper_structure(paper_structure())
    assert is_paper_structure({"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25})
    assert not is_paper_structure(paper_structure(M=0.066))
    assert is_paper_structure(paper_structure(M=0.066), ignore=("M",))
    assert not is_paper_structure(paper_structure(ck=0.2))
    own = {"f0": 22.0, "Q": 30.0, "alpha": 45.0, "M": 0.15, "cs": 0.35, "ck": 0.3}
    assert not is_paper_structure(own)
    assert PAPER_STRUCTURE["f0"] == 14.44


@pytest.mark.parametrize("figure", headline(["regime-map", "thresholds", "velocity-curves",
                                             "force-traces"]))
def test_a_swept_study_of_its_own_structure_draws_with_sel(figure, files, tmp_path):
    stem = tmp_path / figure
    assert main(["figure", figure, str(files["own"]), "-o", str(stem),
                 "--sel", "Q=30", "--sel", "M=0.15"]) == 0
    title = _title(stem.with_suffix(".png"))
    assert "selected: Q=30, M=0.15" in title, title
    assert "paper's points" not in title


@pytest.mark.parametrize("figure", ["regime-map", "thresholds", "velocity-curves",
                                    "force-traces"])
def test_a_missing_selection_names_the_keys_and_their_values(figure, files, tmp_path,
                                                            capsys):
    stem = tmp_path / figure
    assert main(["figure", figure, str(files["own"]), "-o", str(stem),
                 "--sel", "Q=30"]) == 1
    message = capsys.readouterr().err
    assert "sweeps M" in message and "--sel M=0.1" in message
    assert "M [1]: 0.1, 0.15" in message
    assert not stem.with_suffix(".png").exists()
    assert main(["figure", figure, str(files["own"]), "-o", str(stem)]) == 1
    assert "sweeps Q, M" in capsys.readouterr().err


def test_a_selection_outside_the_file_lists_the_values(files, tmp_path, capsys):
    assert main(["figure", "regime-map", str(files["own"]), "-o", str(tmp_path / "x"),
                 "--sel", "Q=100", "--sel", "M=0.1"]) == 1
    message = capsys.readouterr().err
    assert "Q=100" in message and "15, 30" in message


def test_paper_points_only_on_the_paper_structure(files, tmp_path, drawn):
    draw_figure("regime-map", open_result(files["own"]), tmp_path / "own",
                sel=["Q=30", "M=0.15"])
    draw_figure("regime-map", open_result(files["paper"]), tmp_path / "paper")
    own, paper = (_texts(fig) for fig in drawn)
    assert not {"S", "P", "N", "PN"} & set(own)
    assert not any("paper's points" in t for t in own)
    assert {"S", "P", "N", "PN"} <= set(paper)
    assert any("paper's points" in t for t in paper)


def test_force_traces_points(files, tmp_path):
    own = open_result(files["own"])
    png, _ = draw_figure("force-traces", own, tmp_path / "own", sel=["Q=30", "M=0.15"])
    assert "a point of each region S, P, N, PN of the file's grid" in _title(png)
    png, _ = draw_figure("force-traces", open_result(files["paper"]), tmp_path / "paper")
    assert "the paper's points S, P, N, PN" in _title(png)
    assert main(["figure", "force-traces", str(files["own"]), "-o", str(tmp_path / "pts"),
                 "--sel", "Q=15", "--sel", "M=0.1", "--point", "20,3",
                 "--point", "25,6.5", "--point", "40,1"]) == 0
    assert "at the points asked for" in _title(tmp_path / "pts.png")


def test_many_curves_get_a_colour_bar(files, tmp_path, drawn):
    draw_figure("velocity-curves", open_result(files["many"]), tmp_path / "many")
    (fig,) = drawn
    assert len(fig.axes) == 2  # the plot and its colour bar
    assert not any(t.endswith(" Hz") for t in _texts(fig))
    assert "drive frequency f [Hz]" in fig.axes[1].get_ylabel()


def test_threshold_collapse_colours_each_q(files, tmp_path, drawn):
    draw_figure("threshold-collapse", open_result(files["q"]), tmp_path / "q")
    (fig,) = drawn
    main_axes = fig.axes[0]
    colours = {tuple(np.round(line.get_color(), 3)) for line in main_axes.lines
               if line.get_marker() == "o" and len(line.get_xdata())}
    assert len(colours) >= 10  # 12 values of Q, not one colour
    assert any(ax.get_ylabel().startswith("Q (12 values)") for ax in fig.axes)
    assert "quality factor Q" in fig.axes[1].get_xlabel()


def test_the_fit_figure_is_registered(tmp_path):
    assert "fit" in FIGURES
    (tmp_path / "m.csv").write_text("quantity,f,a,value,sigma\n"
                                    "threshold,13.0,,6.25,0.05\nthreshold,16.5,,6.6,0.05\n")
    (tmp_path / "fit.toml").write_text(
        '[fit]\nname = "t"\nmeasurements = ["m.csv"]\nfree = { cs = [0.05, 1.0] }\n'
        'coupling = "two-way"\n'
        "[structure]\nf0 = 14.44\nQ = 17.5\nalpha = 64.0\nM = 0.08\ncs = 0.3\n")
    assert main(["fit", str(tmp_path / "fit.toml"), "-o", str(tmp_path / "fit.nc")]) == 0
    assert main(["figure", "fit", str(tmp_path / "fit.nc"), "-o", str(tmp_path / "f")]) == 0
    assert (tmp_path / "f.png").stat().st_size > 1000


@pytest.mark.parametrize(("figure", "source", "lab", "sel", "shown"), [
    ("thresholds", "own", "lab", ["Q=30", "M=0.15"], 4),
    ("velocity-curves", "own", "lab", ["Q=30", "M=0.15"], 2),
    ("mass-ratio", "loads", "load-lab", [], 4),
])
def test_measurements_beside_the_model(figure, source, lab, sel, shown, files, tmp_path):
    args = ["figure", figure, str(files[source]), "-o", str(tmp_path / figure),
            "--measurements", str(files[lab])]
    for s in sel:
        args += ["--sel", s]
    assert main(args) == 0
    assert f"with {shown} measured" in _title(tmp_path / f"{figure}.png")


def test_measurement_mismatches_are_clear(files, tmp_path, capsys):
    out = str(tmp_path / "x")
    velocities = tmp_path / "v.csv"
    velocities.write_text("quantity,f,a,value,sigma\nvelocity,21.0,5.0,4.0,0.5\n")
    own = [str(files["own"]), "-o", out, "--sel", "Q=30", "--sel", "M=0.15"]
    assert main(["figure", "thresholds", *own, "--measurements", str(velocities)]) == 1
    message = capsys.readouterr().err
    assert "no 'threshold' rows" in message and "velocity (1 rows)" in message
    assert main(["figure", "velocity-curves", *own, "--measurements", str(velocities)]) == 1
    assert "not mm/s" in capsys.readouterr().err
    other = tmp_path / "o.csv"
    other.write_text("quantity,f,value,M\nthreshold,20.0,2.0,0.3\n")
    assert main(["figure", "thresholds", *own, "--measurements", str(other)]) == 1
    assert "other structures (M = 0.3)" in capsys.readouterr().err
    assert main(["figure", "regime-map", *own, "--measurements", str(other)]) == 1
    assert "takes no --measurements" in capsys.readouterr().err
    assert main(["figure", "thresholds", *own, "--point", "20,3"]) == 1
    assert "takes no --point" in capsys.readouterr().err
    bad = tmp_path / "bad.csv"
    bad.write_text("quantity,f,value\nthreshold,20.0,fast\n")
    assert main(["figure", "thresholds", *own, "--measurements", str(bad)]) == 1
    assert "line 2, column 'value'" in capsys.readouterr().err


def test_figure_error_is_a_value_error():
    assert issubclass(FigureError, ValueError)

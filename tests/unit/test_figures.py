"""Figure commands of Fig. 1B, 1C and 2 run on small result files and write images."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from study.cli import main
from study.runner import run_study
from study.store import open_result

STRUCTURE = "[structure]\nf0 = 14.44\nQ = 17.5\nalpha = 64.0\nM = 0.08\ncs = 0.25\n"
SPECS = {
    "thresholds": ('["resonance", "thresholds", "lift_off"]',
                   "f = { start = 10.0, stop = 20.0, num = 41 }\n"),
    "velocity-curves": ('["thresholds", "lift_off", "velocity"]',
                        "f = { values = [12.0, 14.5, 17.0] }\n"
                        "a = { start = 0.0, stop = 12.0, num = 31 }\n"),
    "regime-map": ('["thresholds", "lift_off", "velocity", "frontier"]',
                   "f = { start = 10.0, stop = 20.0, num = 41 }\n"
                   "a = { start = 0.0, stop = 12.0, num = 25 }\n"),
}


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    folder = tmp_path_factory.mktemp("figures")
    files = {}
    for name, (observables, sweep) in SPECS.items():
        spec = folder / f"{name}.toml"
        spec.write_text(f'[study]\nname = "{name}"\nobservables = {observables}\n'
                        f"{STRUCTURE}[sweep]\n{sweep}")
        files[name] = run_study(spec, folder / f"{name}.nc", progress=False).output
    return files


@pytest.mark.parametrize(
    ("figure", "source"),
    [("thresholds", "thresholds"), ("velocity-curves", "velocity-curves"),
     ("regime-map", "regime-map"), ("force-traces", "regime-map")],
)
def test_figure_command_writes_png_and_pdf_with_provenance(results, tmp_path, figure, source):
    stem = tmp_path / figure
    assert main(["figure", figure, str(results[source]), "-o", str(stem)]) == 0
    png, pdf = stem.with_suffix(".png"), stem.with_suffix(".pdf")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert pdf.read_bytes()[:5] == b"%PDF-"
    sha = open_result(results[source]).attrs["study_spec_sha256"]
    with Image.open(png) as image:
        metadata = image.text
        assert image.size[0] > 600
        pixels = np.asarray(image.convert("L"))
    assert sha in metadata["Description"] and sha in metadata["Source"]
    assert metadata["Title"]
    assert pixels.std() > 10  # something was drawn


def test_figure_from_a_file_without_its_variables_is_refused(results, tmp_path, capsys):
    status = main(["figure", "regime-map", str(results["thresholds"]),
                   "-o", str(tmp_path / "x")])
    err = capsys.readouterr().err
    assert status == 1
    assert "velocity" in err and "workflows/regime-map.toml" in err
    assert not (tmp_path / "x.png").exists()


def test_single_structure_figures_refuse_a_swept_structure(tmp_path, capsys):
    spec = tmp_path / "swept.toml"
    spec.write_text('[study]\nname = "swept"\nobservables = ["resonance", "thresholds"]\n'
                    "[structure]\nf0 = 14.44\nQ = 17.5\nalpha = 64.0\ncs = 0.25\n"
                    "[sweep]\nM = { values = [0.05, 0.08] }\n"
                    "f = { start = 10.0, stop = 20.0, num = 11 }\n")
    output = run_study(spec, tmp_path / "swept.nc", progress=False).output
    assert main(["figure", "thresholds", str(output), "-o", str(tmp_path / "t")]) == 1
    assert "sweeps M" in capsys.readouterr().err


def test_unknown_figure_is_a_usage_error(results):
    with pytest.raises(SystemExit) as exit_info:
        main(["figure", "fig-99", str(results["thresholds"])])
    assert exit_info.value.code == 2

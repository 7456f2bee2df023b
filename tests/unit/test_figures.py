"""Figure commands run and write an image."""

from __future__ import annotations

import numpy as np

import study
from study.figures import regime_map


def test_regime_map_figure_writes_a_png(tmp_path):
    s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    out = regime_map.draw(s, np.linspace(10, 20, 21), np.linspace(0, 12, 13), tmp_path / "m.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_regime_map_command(tmp_path):
    regime_map.main(["--output", str(tmp_path / "fig.png"), "--num-f", "11", "--num-a", "7"])
    assert (tmp_path / "fig.png").stat().st_size > 1000

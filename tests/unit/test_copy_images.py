"""``make docs`` copies a figure into docs/images/ (tracked) only when its pixels
changed: a figure that differs from the tracked picture only in its PNG metadata (the
version, fingerprint and date that :func:`study.figures.common.save` records) leaves
the tracked file untouched (docs/copy_images.py)."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import matplotlib.pyplot as plt

ROOT = Path(__file__).resolve().parents[2]


def load_copy_images():
    spec = importlib.util.spec_from_file_location("copy_images", ROOT / "docs" / "copy_images.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


copy_images = load_copy_images()


def draw(path: Path, *, software: str, date: str, y=(0.0, 1.0, 0.5)) -> Path:
    fig, ax = plt.subplots(figsize=(2, 1.5))
    ax.plot([0, 1, 2], list(y))
    fig.savefig(path, dpi=50, metadata={"Software": software, "Description": date})
    plt.close(fig)
    return path


def test_a_figure_differing_only_in_metadata_is_not_copied(tmp_path: Path) -> None:
    tracked = tmp_path / "images"
    tracked.mkdir()
    old = draw(tracked / "regime-map.png", software="study 0.9.0", date="2026-01-01")
    before = old.read_bytes()
    (tmp_path / "figures").mkdir()
    new = draw(tmp_path / "figures" / "regime-map.png", software="study 1.0.0",
               date="2026-11-28")
    assert new.read_bytes() != before  # the files differ ...
    assert copy_images.same_pixels(new, old)  # ... their pictures do not
    assert copy_images.copy_images([new], tracked) == []
    assert old.read_bytes() == before


def test_a_figure_with_other_pixels_is_copied_and_a_new_one_too(tmp_path: Path) -> None:
    tracked = tmp_path / "images"
    tracked.mkdir()
    old = draw(tracked / "regime-map.png", software="study 0.9.0", date="2026-01-01")
    (tmp_path / "figures").mkdir()
    changed = draw(tmp_path / "figures" / "regime-map.png", software="study 0.9.0",
                   date="2026-01-01", y=(0.0, 1.0, 0.8))
    added = draw(tmp_path / "figures" / "coupling.png", software="study 1.0.0", date="x")
    assert not copy_images.same_pixels(changed, old)
    assert copy_images.copy_images([changed, added], tracked) == [
        tracked / "regime-map.png", tracked / "coupling.png"]
    assert old.read_bytes() == changed.read_bytes()
    assert (tracked / "coupling.png").read_bytes() == added.read_bytes()
    assert sorted(p.name for p in tracked.iterdir()) == ["coupling.png", "regime-map.png"]


def test_a_damaged_tracked_picture_is_replaced(tmp_path: Path) -> None:
    (tmp_path / "images").mkdir()
    (tmp_path / "images" / "a.png").write_bytes(b"not a png")
    source = draw(tmp_path / "a.png", software="study", date="d")
    assert copy_images.copy_images([source], tmp_path / "images") == [
        tmp_path / "images" / "a.png"]
    assert (tmp_path / "images" / "a.png").read_bytes() == source.read_bytes()


def test_the_command_line_reports_and_a_missing_figure_fails(tmp_path: Path,
                                                            capsys) -> None:
    source = draw(tmp_path / "a.png", software="study", date="d")
    assert copy_images.main([str(source), str(tmp_path / "images")]) == 0
    assert copy_images.main([str(source), str(tmp_path / "images")]) == 0
    out = capsys.readouterr().out
    assert "1 of 1 pictures unchanged" in out
    assert copy_images.main([str(tmp_path / "none.png"), str(tmp_path / "images")]) == 1
    assert "none.png" in capsys.readouterr().err


def test_make_docs_copies_with_the_script() -> None:
    """The docs target goes through the script, not a plain ``cp`` into docs/images/."""
    makefile = (ROOT / "Makefile").read_text()
    target = re.search(r"^docs:.*\n((?:\t.*\n)+)", makefile, re.MULTILINE)
    assert target is not None
    recipe = target[1]
    assert "docs/copy_images.py" in recipe
    assert not re.search(r"\bcp\b", recipe)

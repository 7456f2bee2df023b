"""What a figure was drawn from, recorded in its PNG (a module of its own, imported by
the figure registry and by the writer of figures alike)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["DRAWN_FROM", "drawn_from"]

#: PNG text key recording what a figure was drawn from (figure, data, options, code), so
#: that ``study figure --if-changed`` redraws a figure drawn from anything else.
DRAWN_FROM = "study_figure"


def drawn_from(png: str | Path) -> str | None:
    """The :data:`DRAWN_FROM` record of a PNG written by
    :func:`study.figures.common.save`, or None (no such
    file, not a PNG, or drawn without a record)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(png) as image:
            return image.text.get(DRAWN_FROM)
    except (OSError, UnidentifiedImageError, AttributeError):
        return None

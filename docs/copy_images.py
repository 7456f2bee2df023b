"""Copy figures into the documentation's pictures only where the picture changed.

``make docs`` copies the figures the pages show (``figures/NAME.png``) into
``docs/images/``, which git tracks so that the pages show their pictures on GitHub too.
A figure redrawn from a result of the same values differs from the tracked picture only
in its metadata (the study version, the result's fingerprint and date): copying it
would leave a clean clone with modified files after ``make docs``. So a figure is copied
only when its pixels (the decoded image: mode, size, every pixel, palette) differ from
those of the picture already there, or when there is none.

Usage (from the Makefile)::

    python docs/copy_images.py figures/regime-map.png [...] docs/images

Independent of the ``study`` package: only Pillow (a dependency of matplotlib).
"""

from __future__ import annotations

import os
import shutil
import sys
from collections.abc import Iterable
from pathlib import Path

from PIL import Image


def pixels(path: Path) -> tuple | None:
    """What a picture shows (mode, size, palette, pixel bytes), or None if unreadable."""
    try:
        with Image.open(path) as image:
            image.load()
            return image.mode, image.size, image.getpalette(), image.tobytes()
    except (OSError, ValueError, SyntaxError):  # missing, not an image, truncated
        return None


def same_pixels(a: Path, b: Path) -> bool:
    """Whether pictures ``a`` and ``b`` show the same pixels (metadata aside)."""
    first = pixels(a)
    return first is not None and first == pixels(b)


def copy_images(sources: Iterable[str | Path], folder: str | Path) -> list[Path]:
    """Copy each of ``sources`` into ``folder`` unless the picture of that name there
    shows the same pixels; returns the pictures written. A picture is replaced whole
    (written beside it, then renamed over it)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for source in map(Path, sources):
        target = folder / source.name
        if target.exists() and same_pixels(source, target):
            continue
        temporary = target.with_name(f".{target.name}.copying")
        try:
            shutil.copyfile(source, temporary)
            os.replace(temporary, target)
        finally:
            temporary.unlink(missing_ok=True)
        written.append(target)
    return written


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print("usage: python docs/copy_images.py IMAGE.png [...] FOLDER", file=sys.stderr)
        return 2
    *sources, folder = argv
    try:
        written = copy_images(sources, folder)
    except OSError as err:  # a figure not drawn, a folder not writable
        print(f"copy_images: {err.filename}: {err.strerror}", file=sys.stderr)
        return 1
    for path in written:
        print(f"{path}: copied (its pixels changed)")
    print(f"{folder}: {len(sources) - len(written)} of {len(sources)} pictures unchanged "
          "(same pixels: left as they are)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

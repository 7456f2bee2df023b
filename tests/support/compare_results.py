"""Compare every result file of two folders, variable by variable, bit for bit.

A refactor must keep results identical. Run ``make`` on the commit before and after a
change and compare the two ``results/`` folders::

    python -m tests.support.compare_results BEFORE_DIR AFTER_DIR

(``make compare BEFORE=BEFORE_DIR`` compares against ``results/``.) For each ``*.nc``
of ``BEFORE_DIR`` the file of the same name in ``AFTER_DIR`` must hold the same
variables with the same shapes, dtypes and ``units`` attributes, and the same values
bit for bit (NaN payloads included; the raw stored values are compared, without
decoding). Global attributes (dates, code hashes, provenance) are not compared. The exit
status is 1 when a file is missing or any value differs.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import xarray as xr


def differences(before: Path, after: Path) -> list[str]:
    """What differs between two result files: one line per variable, empty if none."""
    with xr.open_dataset(before, decode_cf=False) as old, \
            xr.open_dataset(after, decode_cf=False) as new:
        found = []
        for name in sorted(set(old.variables) | set(new.variables)):
            if name not in old.variables or name not in new.variables:
                found.append(f"{name}: only in {'before' if name in old.variables else 'after'}")
                continue
            x, y = old[name].values, new[name].values
            if x.shape != y.shape or x.dtype != y.dtype:
                found.append(f"{name}: {x.shape} {x.dtype} before, {y.shape} {y.dtype} after")
                continue
            if x.dtype.kind in "fc":
                same = np.array_equal(np.ascontiguousarray(x).view(np.uint8),
                                      np.ascontiguousarray(y).view(np.uint8))
            else:
                same = np.array_equal(x, y)
            if not same:
                found.append(f"{name}: values differ")
            if old[name].attrs.get("units") != new[name].attrs.get("units"):
                found.append(f"{name}: units {old[name].attrs.get('units')!r} before, "
                             f"{new[name].attrs.get('units')!r} after")
        return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path, help="folder of the reference result files")
    parser.add_argument("after", type=Path, help="folder of the result files to check")
    args = parser.parse_args(argv)
    files = sorted(args.before.glob("*.nc"))
    if not files:
        print(f"no result files (*.nc) in {args.before}", file=sys.stderr)
        return 1
    failed = 0
    for old in files:
        new = args.after / old.name
        if not new.exists():
            print(f"MISSING   {old.name}")
            failed += 1
            continue
        found = differences(old, new)
        print(f"{'DIFFERS' if found else 'IDENTICAL':9} {old.name}"
              + (": " + "; ".join(found) if found else ""))
        failed += bool(found)
    print(f"{len(files) - failed} of {len(files)} files identical")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

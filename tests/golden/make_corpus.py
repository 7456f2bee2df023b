"""Write the golden corpus of one release: small result files of every kind.

Run once per release, with the ``study`` command of that release (a venv made from the
release's commit), never again for a release already in the corpus: its files are
what that release wrote, and every later version must read them
(``tests/golden/test_golden_corpus.py``)::

    python tests/golden/make_corpus.py v0.2.0 --study .venv/bin/study

The specs are in ``tests/golden/specs/``; a release runs the ones it can (flight did not
exist in 0.1.0: ``--skip`` leaves such specs out). Each file is written to
``tests/golden/<release>/<spec>.nc`` with the release's own command line, so nothing of
the running code enters it. The environment is pinned (creator, cache folder) so that a
file names no person.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
SPECS = HERE / "specs"

#: spec -> the command that writes its result (study run, fit, design).
COMMANDS = {
    "own": "run",
    "frontier-two-way": "run",
    "mass-ratio-two-way": "run",
    "thresholds": "run",
    "integrator": "run",
    "paradox": "run",
    "flight": "run",
    "irregular": "run",
    "stribeck": "run",
    "steering": "run",
    "steering-calibration": "run",
    "steering-plan": "run",
    "fit": "fit",
    "design": "design",
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("release", help="the release's folder name, e.g. v0.2.0")
    parser.add_argument("--study", required=True, help="that release's study command")
    parser.add_argument("--skip", nargs="*", default=[], help="specs the release cannot run")
    args = parser.parse_args(argv)
    out = HERE / args.release
    out.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as work_dir:
        work = Path(work_dir)
        for name in SPECS.iterdir():
            shutil.copy(name, work / name.name)
        env = {**os.environ, "STUDY_CREATOR": "golden-corpus",
               "STUDY_CACHE": str(work / "cache")}
        for name, command in COMMANDS.items():
            if name in args.skip or not (work / f"{name}.toml").exists():
                continue
            target = out / f"{name}.nc"
            if target.exists():
                print(f"{target}: kept (a release's files are never rewritten)")
                continue
            done = subprocess.run([args.study, command, f"{name}.toml", "-o", f"{name}.nc"],
                                  cwd=work, env=env, capture_output=True, text=True,
                                  check=False)
            if done.returncode != 0:
                print(f"{name}: {done.stderr.strip()}", file=sys.stderr)
                return 1
            shutil.copy(work / f"{name}.nc", target)
            print(f"{target}: {target.stat().st_size} bytes")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""
Your own structure, from spec to figure
=======================================

A structure is five numbers: the plate's resonance ``f0`` [Hz], its quality factor ``Q``,
its tilt ``alpha`` [degree], the mass ratio ``M`` of the plate's moving mass to the whole
structure, and the friction coefficient ``cs``. A study spec names them, the drive
frequencies and accelerations to sweep, and what to compute; ``study run`` computes it
into one netCDF file and ``study figure`` draws it.
"""

# %%
# A folder to work in, and a way to run the ``study`` command as in a terminal.
import atexit
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import study

work = Path(tempfile.mkdtemp(prefix="study-example-"))
atexit.register(shutil.rmtree, work, ignore_errors=True)


def shell(command):
    """Run a ``study`` command line in the work folder; print its output."""
    print("$", command)
    program, *args = shlex.split(command)
    assert program == "study"
    done = subprocess.run([sys.executable, "-m", "study.cli", *args],
                          cwd=work, capture_output=True, text=True, check=False)
    print(done.stdout + done.stderr)
    done.check_returncode()


def show(png):
    """Show a PNG file as it is, pixel for pixel."""
    image = plt.imread(work / png)
    height, width = image.shape[:2]
    plt.figure(figsize=(width / 100, height / 100), dpi=100).figimage(image)


# %%
# The spec
# --------
# The plate of this structure resonates at 16 Hz, leans at 60 degrees and carries a
# tenth of the mass. The map sweeps 10-22 Hz and 0-12 m s-2 on a coarse grid (a few
# thousand points: a second). ``observables`` says what to compute: the motion
# thresholds, lift-off, the steady velocity and the frontier where it changes sign,
# everything the ``regime-map`` figure draws.
(work / "own.toml").write_text("""\
[study]
name = "own"
observables = ["thresholds", "lift_off", "velocity", "frontier"]

[structure]
f0 = 16.0      # Hz
Q = 25.0
alpha = 60.0   # degree
M = 0.1
cs = 0.3

[sweep]
f = { start = 10.0, stop = 22.0, num = 61 }   # Hz
a = { start = 0.0, stop = 12.0, num = 49 }    # m s-2
""")

# %%
# Run it
# ------
# ``study run`` checks the spec before any work, computes the grid on every core and
# writes ``results/own.nc``, sealed and validated. Run again, it says the result is up to
# date and computes nothing.
(work / "results").mkdir()
shell("study run own.toml -o results/own.nc --no-progress")
shell("study run own.toml -o results/own.nc --no-progress")

# %%
# The same from Python: :func:`study.run` is ``study run`` without the shell (the same
# runner, here finding the result up to date) and returns the result as a labelled
# :class:`xarray.Dataset`.
own = study.run(work / "own.toml", work / "results" / "own.nc")
print(own["velocity"].sel(f=16.5, a=6.0, method="nearest"))

# %%
# What the file holds
# -------------------
shell("study info results/own.nc")

# %%
# Draw it
# -------
# ``study figure regime-map`` draws the velocity over the map, the thresholds, lift-off
# and the frontier from the file alone; the title names the structure and the model.
shell("study figure regime-map results/own.nc -o own-map")
show("own-map.png")

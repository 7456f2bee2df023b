"""
The steering disk
=================

The paper's Fig. 4 structure: a disk carrying two resonant plates, one along its axis
(the head plate, resonant near 14.4 Hz) and one across it (the tail plate, near 7.7 Hz).
A single vertical shaker steers it by its frequency alone: the head plate walks it
forward at 14.2 Hz and backward at 15.2 Hz, the tail plate turns it left at 7.2 Hz and
right at 8.2 Hz. A *scene* spec (a ``[scene]`` table) describes the disk, the plates and
a sequence of drive commands; ``study run`` simulates the disk's path in the plane.
"""

# %%
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
# The scene
# ---------
# The disk (radius, friction), its two plates (each a structure of its own, with the
# direction it pushes in and where it is clamped), and the drive: one segment per
# command, each with its frequency, acceleration and duration. Angles are in degrees,
# the start pose is ``[x (m), y (m), heading (degree)]``.
(work / "steer.toml").write_text("""\
[scene]
name = "steer"
kind = "trajectory"
title = "The two-plate disk: forward, right, forward, left, backward"

[disk]
radius = 0.02          # m
cs = 0.25

[[plate]]
name = "head"
f0 = 14.44             # Hz
Q = 17.5
alpha = 64.0           # degree
M = 0.08
direction = 0.0        # degree from the heading: it pushes along the axis
attachment = [0.005, 0.0]  # m, in the disk's frame

[[plate]]
name = "tail"
f0 = 7.7               # Hz
Q = 10.0
alpha = 64.0           # degree
M = 0.08
direction = -90.0      # degree: across the axis
attachment = [-0.02, 0.0]  # m: at the tail

[trajectory]
sample_interval = 0.05   # s
start = [0.0, 0.0, 90.0] # x (m), y (m), heading (degree)

[[segment]]
label = "forward"
f = 14.2
a = 7.0
duration = 4.0
[[segment]]
label = "right"
f = 8.2
a = 7.0
duration = 3.0
[[segment]]
label = "forward"
f = 14.2
a = 7.0
duration = 3.0
[[segment]]
label = "left"
f = 7.2
a = 7.0
duration = 3.0
[[segment]]
label = "backward"
f = 15.2
a = 7.0
duration = 3.0
""")

# %%
# Simulate and draw
# -----------------
# :func:`study.run` runs a scene as ``study run`` does and returns its result; the
# ``study figure steering`` command draws the file.
(work / "results").mkdir()
scene = study.run(work / "steer.toml", work / "results" / "steer.nc")
shell("study figure steering results/steer.nc -o steer")
show("steer.png")

# %%
# What each command did
# ---------------------
# The file holds the path (over ``t``) and one row per segment: how far the disk went
# and how much it turned, in the units the file states.
columns = ["frequency", "duration", "forward_displacement", "lateral_displacement",
           "heading_change"]
table = scene[columns].to_dataframe()
table.columns = [f"{name} [{scene[name].attrs['units']}]" for name in columns]
table.index = scene["segment_label"].values
print(table.round(4).to_string())

"""
Your own structure past lift-off: bouncing
==========================================

Above the lift-off acceleration the normal force under the base would become negative:
the base leaves the table. By default the solvers stop there (status ``LIFT_OFF``, no
velocity). With ``[solver] coupling = "two-way"`` and ``flight = true`` they follow the
structure through its flights and landings, and report ``BOUNCING`` points with their
mean velocity, their largest hop and their time in the air. How hard the base lands is
its restitution ``e`` (0: a plastic landing), swept here.
"""

# %%
# A folder to work in.
import atexit
import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import study

work = Path(tempfile.mkdtemp(prefix="study-example-"))
atexit.register(shutil.rmtree, work, ignore_errors=True)

# %%
# The spec
# --------
# The structure of :doc:`/getting-started/own-structure`, its plate at 20 Hz with a
# quality factor of 30, on a map that reaches past lift-off (about 8 m s-2 at the
# resonance, 9-11 m s-2 away from it), for two restitutions: plastic landings
# (``e = 0``) and landings that give back half the impact speed (``e = 0.5``).
# ``without_flight`` keeps, for the same points, the run that stops at lift-off.
(work / "flight.toml").write_text("""\
[study]
name = "own-flight"
observables = ["lift_off", "velocity", "floquet", "without_flight"]

[structure]
f0 = 20.0      # Hz
Q = 30.0
alpha = 60.0   # degree
M = 0.1
cs = 0.3

[sweep]
restitution = { values = [0.0, 0.5] }
f = { values = [18.0, 19.5, 21.0, 22.5] }      # Hz
a = { start = 0.0, stop = 16.0, num = 81 }     # m s-2

[solver]
coupling = "two-way"   # flight needs the two-way model
flight = true
""")

# %%
# Run it
# ------
# :func:`study.run` is ``study run`` from Python: it checks the spec, computes the grid
# and returns the result as a labelled :class:`xarray.Dataset` (also written to
# ``flight.nc``).
result = study.run(work / "flight.toml", work / "flight.nc")
print(result[["velocity", "status", "largest_hop", "airborne_fraction"]])

# %%
# What the points are
# -------------------
# Each point has a status. Without flight every point past lift-off is ``LIFT_OFF``;
# with flight it bounces (``BOUNCING``, with a velocity), or its motion never repeats
# within 16 periods (``CHAOTIC`` or ``QUASI_PERIODIC``: its time-averaged velocity is
# given), or is so irregular that its mean would need more periods than the budget
# (``NOT_CONVERGED``, no velocity).
def counts(status):
    codes, number = np.unique(status.values, return_counts=True)
    return ", ".join(f"{study.Status(int(c)).name} {n}" for c, n in zip(codes, number, strict=True))


for e in result["restitution"].values:
    at = result.sel(restitution=e)
    print(f"e = {e:g}: {counts(at['status'])}")
    print(f"  without flight: {counts(at['status_without_flight'])}")

# %%
# Draw it
# -------
# The velocity against the drive acceleration at each frequency: the dotted curve is the
# run that stops at lift-off, the solid ones go on through the bouncing region (thick:
# ``BOUNCING`` points). Below them, the largest hop of the base: what a camera beside
# the table would see, from zero at the edge of the region to a fraction of a
# millimetre.
fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
colours = plt.cm.coolwarm(np.linspace(0.0, 1.0, result.sizes["f"]))
styles = {0.0: "-", 0.5: "--"}
a = result["a"].values
for colour, f in zip(colours, result["f"].values, strict=True):
    plain = result.sel(f=f, restitution=0.0)
    top.plot(a, 1e3 * plain["velocity_without_flight"], ":", color="k", lw=1)
    for e, style in styles.items():
        at = result.sel(f=f, restitution=e)
        bouncing = at["status"] == study.Status.BOUNCING
        top.plot(a, 1e3 * at["velocity"], style, color=colour, lw=1,
                 label=f"{f:g} Hz, e = {e:g}")
        top.plot(a, 1e3 * at["velocity"].where(bouncing), style, color=colour, lw=3)
        bottom.semilogy(a, 1e3 * at["largest_hop"].where(bouncing), style, color=colour)
top.axhline(0.0, color="0.5", lw=0.5)
top.set_ylabel("mean velocity [mm s-1]")
top.legend(fontsize=7, ncol=2)
bottom.set_ylabel("largest hop [mm]")
bottom.set_xlabel("drive acceleration a [m s-2]")
fig.suptitle("Own structure, two-way coupling with flight")
fig.tight_layout()

# %%
# How strongly each bouncing motion attracts: the Floquet multiplier (below 1 for a
# stable orbit; near 1 the motion settles slowly after a disturbance and is sensitive
# to small changes of the drive). With ``e > 0`` the base rebounds several times before
# it rests on the table (chattering): the impacts a period grow and the time in the air
# can reach the whole period.
bouncing = result["status"] == study.Status.BOUNCING
for e in result["restitution"].values:
    at = result.sel(restitution=e).where(bouncing.sel(restitution=e))
    print(f"e = {e:g}: Floquet multipliers {float(at['floquet_multiplier'].min()):.2f}"
          f" .. {float(at['floquet_multiplier'].max()):.2f}, up to"
          f" {float(at['impacts_per_period'].max()):g} impacts a period, in the air up to"
          f" {100 * float(at['airborne_fraction'].max()):.0f} % of the period")

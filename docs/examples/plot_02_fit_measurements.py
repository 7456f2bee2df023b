"""
A measured data set, fitted
===========================

Thresholds read off a shaker (the lowest acceleration at which the structure starts to
move, at six frequencies) and four steady velocities filmed at chosen drive points go in
a CSV file; ``study fit`` estimates the structure parameters the lab cannot measure
directly (here the friction coefficient ``cs`` and the mass ratio ``M``), with standard
errors, and draws the measurements over the fitted model.
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
import xarray as xr

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
# The measurements
# ----------------
# One row per measurement, SI units (accelerations in m s-2, velocities in m s-1,
# positive forward), ``sigma`` the standard uncertainty of each value. A threshold whose
# direction of motion was not seen is compared with the lower of the two model
# thresholds.
(work / "lab.csv").write_text("""\
# shaker run of 2024-05-02, plate B; thresholds by slow ramps of a, velocities by video
quantity,f,a,value,sigma,note
threshold,12.0,,7.45,0.05,
threshold,13.0,,6.30,0.05,
threshold,14.0,,3.95,0.05,
threshold,15.0,,4.71,0.05,
threshold,16.0,,6.22,0.05,
threshold,17.0,,7.10,0.05,
velocity,13.0,8.5,0.0021,0.0002,forward
velocity,14.2,7.0,0.0054,0.0003,forward
velocity,15.2,7.0,-0.0022,0.0002,backward
velocity,16.0,9.0,-0.0027,0.0002,backward
""")

# %%
# The fit spec
# ------------
# ``free`` names the parameters to estimate with their bounds; ``[structure]`` gives
# their start values and the parameters known from elsewhere (the plate's ring-down gave
# ``f0`` and ``Q``, its tilt was measured). ``coupling`` names the model of the velocity
# rows: ``"two-way"`` (the sliding base also forces the plate's mode, the physical model)
# or ``"one-way"`` (the paper's).
(work / "fit.toml").write_text("""\
[fit]
name = "plate-b"
measurements = ["lab.csv"]
free = { cs = [0.05, 1.0], M = [0.01, 0.5] }
coupling = "two-way"

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.1
cs = 0.3
""")

# %%
# Fit
# ---
# The command prints each estimate with its standard error, and chi^2 per degree of
# freedom: near 1 when the model describes the data within their stated uncertainties.
(work / "results").mkdir()
shell("study fit fit.toml -o results/plate-b.nc --figure plate-b")
show("plate-b.png")

# %%
# The result file
# ---------------
# Estimates, standard errors, correlations and every measurement's residual are in a
# netCDF file, over the dimensions ``parameter`` and ``measurement``.
fitted = xr.open_dataset(work / "results" / "plate-b.nc")
for name in fitted["parameter"].values:
    p = fitted.sel(parameter=name)
    print(f"{name:3} = {float(p.estimate):.4g} +- {float(p.standard_error):.2g} "
          f"[{p.parameter_units.item()}], bounds {float(p.lower_bound):g} to "
          f"{float(p.upper_bound):g}")
print("correlation of cs and M:", round(float(fitted["correlation"][0, 1]), 3))
residuals = fitted[["quantity", "f", "a", "value", "model", "normalized_residual"]]
print(residuals.to_dataframe().to_string(float_format="{:.4g}".format))
fitted.close()

"""
Reading a result with plain xarray
==================================

A result file is a netCDF file that any netCDF reader opens; with xarray it is a
labelled dataset: dimensions named after the swept parameters, coordinates with their
values, ``units`` and ``long_name`` on every variable, and the solver's status as a CF
flag variable whose ``flag_meanings`` name each code. Nothing of ``study`` is needed to
read it, so a file can be shared with anyone.
"""

# %%
# A small result to read, written by :func:`study.run` (any result file will do:
# ``results/regime-map.nc`` after ``make``).
import atexit
import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

import study

work = Path(tempfile.mkdtemp(prefix="study-example-"))
atexit.register(shutil.rmtree, work, ignore_errors=True)
(work / "map.toml").write_text("""\
[study]
name = "map"
observables = ["thresholds", "lift_off", "velocity"]

[structure]
f0 = 14.44     # Hz
Q = 17.5
alpha = 64.0   # degree
M = 0.08
cs = 0.25

[sweep]
f = { start = 12.0, stop = 17.0, num = 51 }   # Hz
a = { start = 0.0, stop = 12.0, num = 49 }    # m s-2
""")
study.run(work / "map.toml", work / "map.nc")  # or: study run map.toml -o map.nc

# %%
# Open it
# -------
ds = xr.open_dataset(work / "map.nc")
print(ds)

# %%
# Units and names
# ---------------
# Every variable and coordinate says what it is and in which units (CF/UDUNITS
# spelling: ``m s-1``, ``m s-2``, ``Hz``, ``degree``, ``1``).
for name, variable in {**ds.coords, **ds.data_vars}.items():
    print(f"{name:22} {variable.dims!s:12} [{variable.attrs.get('units', '')}] "
          f"{variable.attrs.get('long_name', '')}")

# %%
# The status flags
# ----------------
# ``status`` holds one code per point; its attributes map codes to names. Velocity is
# NaN exactly where the status says the model has no answer (lift-off, no convergence).
status = ds["status"]
meanings = dict(zip(status.attrs["flag_values"].tolist(),
                    status.attrs["flag_meanings"].split(), strict=True))
print(meanings)
codes, counts = np.unique(status.values, return_counts=True)
for code, count in zip(codes, counts, strict=True):
    print(f"{meanings[int(code)]:20} {count:5} points")
lift_off = next(code for code, name in meanings.items() if name == "lift_off")
print("velocity NaN exactly at lift-off:",
      bool((ds["velocity"].isnull() == (status == lift_off)).all()))

# %%
# Select and plot
# ---------------
# Label-based selection and xarray's plotting use the coordinates and units: here the
# velocity against acceleration at the frequency nearest to 14.2 Hz, and the velocity
# map with the forward threshold over it.
fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
line = ds["velocity"].sel(f=14.2, method="nearest") * 1e3
line.attrs.update(units="mm s-1", long_name="mean velocity")
line.plot(ax=left, marker=".")
left.set_title(f"f = {float(line.f):.1f} Hz (Q = 17.5, M = 0.08, cs = 0.25)",
               fontsize=10)
ds["velocity"].T.plot(ax=right, cmap="RdBu", center=0.0)
ds["a_star_plus"].plot(ax=right, color="k", label="a*+: forward slips start")
right.set_ylim(0, 12)
right.set_ylabel("drive acceleration a [m s-2]")
right.legend(loc="upper left", fontsize=8)
right.set_title("velocity over (f, a) (f0 = 14.44 Hz, alpha = 64 degree)",
                fontsize=10)
fig.tight_layout()

# %%
# To pandas, for a table
# ----------------------
at_14 = ds[["velocity", "status"]].sel(f=14.2, method="nearest")
table = at_14.reset_coords(drop=True).to_dataframe()
table["status"] = table["status"].map(meanings)
print(table.iloc[::8])
ds.close()

"""
A distributed run on a dask cluster
===================================

``study run --scheduler ADDRESS`` fans a study out over the workers of a
dask.distributed scheduler instead of threads in its own process. On a cluster, a
scheduler is started once (``dask scheduler``), workers join it from any machine that
has the same ``study`` installed (``dask worker tcp://HOST:8786``, or dask-jobqueue's
``SLURMCluster`` from a batch system), and every ``study run`` given its address uses
them. Here a small cluster lives in this Python process, on this machine only: a
scheduler on 127.0.0.1 at a free port, no dashboard, and one worker with two threads.
"""

# %%
import atexit
import json
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import xarray as xr
from dask.distributed import LocalCluster

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


# %%
# The cluster
# -----------
# ``processes=False`` keeps the worker in this process (threads, over TCP like any
# worker); a real worker is a process of its own, often on another machine. Port 0 takes
# a free port, for the scheduler and for its HTTP server (which serves the dashboard where
# bokeh is installed; ``dashboard_address=None`` would still open it, on port 8787).
cluster = LocalCluster(host="127.0.0.1", scheduler_port=0, protocol="tcp",
                       dashboard_address="127.0.0.1:0", n_workers=1,
                       threads_per_worker=2, processes=False)
address = cluster.scheduler_address
print(address)

# %%
# The study
# ---------
# The paper's structure over a coarse map, cut into chunks of 500 points (one task
# each) so that the workers share the work.
(work / "map.toml").write_text("""\
[study]
name = "map"
observables = ["thresholds", "velocity"]

[structure]
f0 = 14.44     # Hz
Q = 17.5
alpha = 64.0   # degree
M = 0.08
cs = 0.25

[sweep]
f = { start = 10.0, stop = 20.0, num = 81 }   # Hz
a = { start = 0.0, stop = 12.0, num = 41 }    # m s-2

[solver]
chunk_points = 500
""")

# %%
# Run on the scheduler
# --------------------
# :func:`study.run` with ``scheduler=`` (``study run --scheduler ADDRESS`` on the command
# line) checks that every worker runs the same ``study`` code as itself before any work,
# then sends the chunks; the result records the scheduler and the number of worker
# threads in its provenance.
(work / "results").mkdir()
remote = study.run(work / "map.toml", work / "results" / "map.nc", scheduler=address)
run = json.loads(remote.attrs["provenance"])["run"]
print({key: run[key] for key in ("scheduler", "workers")})

# %%
# The map the workers computed: the velocity over (f, a), in the file's units.
(remote["velocity"] * 1e3).T.plot(cmap="RdBu", center=0.0,
                                  cbar_kwargs={"label": "mean velocity [mm s-1]"})
plt.title("Computed on a dask cluster\n"
          "(f0 = 14.44 Hz, Q = 17.5, alpha = 64 degree, M = 0.08, cs = 0.25)", fontsize=9)

# %%
# The same from the command line (``--force``: recompute although the file is up to
# date; the values kept by the first run are reused):
shell(f"study run map.toml -o results/map.nc --scheduler {address} --force "
      "--no-progress")

# %%
# Without a scheduler the study runs on threads of this process (here with a cache of
# its own, so that it computes every point again rather than reusing the values the
# first run kept); the numbers are the same, bit for bit.
local = study.run(work / "map.toml", work / "results" / "map-local.nc",
                  cache=work / "local-cache")
xr.testing.assert_identical(remote["velocity"], local["velocity"])
print("identical velocities:", remote["velocity"].equals(local["velocity"]))

# %%
cluster.close()

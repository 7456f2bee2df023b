"""The paper's Fig. 2 insets: n(t) and tau(t)/cs at its points in S, P, N and PN.

The forces are closed form (PHYSICS.md section 2), evaluated for the structure
stored in the result file; the velocity quoted is the file's, at its nearest grid point.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

import study
from study.figures import common
from study.figures.regime_map import PAPER_POINTS, parameter_text, single_structure
from study.status import Status

__all__ = ["draw"]


def _velocity_note(dataset: xr.Dataset, f: float, a: float) -> str:
    if "velocity" not in dataset or "a" not in dataset.dims:
        return ""
    point = dataset.sel(f=f, a=a, method="nearest")
    status = Status(int(point["status"]))
    where = f"nearest grid point {float(point['f']):.3g} Hz, {float(point['a']):.3g} m s$^{{-2}}$"
    if status == Status.STATIC:
        return f"static ({where})"
    if status in (Status.LIFT_OFF, Status.NOT_CONVERGED):
        return f"{status.name.lower().replace('_', ' ')} ({where})"
    return f"v = {1e3 * float(point['velocity']):.3g} mm s$^{{-1}}$ ({where})"


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Force traces at the paper's four points into ``output.png/.pdf``."""
    single_structure(dataset, "force-traces")
    structure = common.structure_from_dataset(dataset)
    g, cs = structure.g, structure.cs
    fig, axes = plt.subplots(2, 2, figsize=(9.0, 6.0), sharex=True, sharey=True,
                             layout="constrained")
    phase = np.linspace(0.0, 2.0, 801)  # in drive periods
    for ax, (name, (f, a)) in zip(axes.ravel(), PAPER_POINTS.items(), strict=True):
        t = phase / f
        n = study.normal_force(structure, f, a, t) / g
        tau = study.tangential_force(structure, f, a, t) / (cs * g)
        ax.plot(phase, n, color="k", lw=1.5, label="$n(t)/g$")
        ax.plot(phase, tau, color="tab:purple", lw=1.5, label="$\\tau(t)/(c_s g)$")
        ax.plot(phase, -tau, color="tab:purple", lw=0.8, ls=":", label="$-\\tau(t)/(c_s g)$")
        ax.fill_between(phase, -3, 3, where=tau > n, color="tab:blue", alpha=0.2, lw=0,
                        label="$\\tau > c_s n$: forward slip possible")
        ax.fill_between(phase, -3, 3, where=-tau > n, color="tab:red", alpha=0.2, lw=0,
                        label="$-\\tau > c_s n$: backward slip possible")
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.set_title(f"{name}: f = {f:g} Hz, a = {a:g} m s$^{{-2}}$\n"
                     f"{_velocity_note(dataset, f, a)}", fontsize=8.5)
        ax.set_ylim(-2.2, 2.2)
    for ax in axes[-1]:
        ax.set_xlabel("time t f [drive periods]")
    for ax in axes[:, 0]:
        ax.set_ylabel("force per unit weight [1]")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8)
    title = "Normal and tangential forces at the paper's four regime points (Fig. 2)"
    fig.suptitle(f"{title}\n{parameter_text(dataset)}", fontsize=10)
    return common.save(fig, output, dataset, title)

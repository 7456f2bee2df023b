"""The paper's Fig. 2 insets: normal and tangential forces at its points S, P, N and PN.

``n(t)/g`` and ``tau(t)/(cs g)`` over two drive periods, in closed form for the
structure stored in the result file (``study figure force-traces FILE``); each panel
also gives the velocity the file holds at the grid point nearest to the paper's point.
A slip is possible forward where ``tau > cs n`` and backward where ``-tau > cs n``.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from study.figures import common
from study.figures.common import PAPER_POINTS, coupling_label, parameter_text, single_structure
from study.physics.forces import normal_force, tangential_force, thresholds
from study.status import Status

__all__ = ["draw", "region_of"]

#: Drive periods shown.
PERIODS = 2.0


def region_of(a: float, a_plus: float, a_minus: float) -> str:
    """The paper's region name of a drive acceleration: S, P, N or PN."""
    forward, backward = a > a_plus, a > a_minus
    return {(False, False): "S", (True, False): "P", (False, True): "N",
            (True, True): "PN"}[(bool(forward), bool(backward))]


def _grid_text(dataset: xr.Dataset, f_point: float, a_point: float) -> str:
    """What the file holds at the grid point nearest to (f_point, a_point)."""
    near = dataset.sel(f=f_point, a=a_point, method="nearest")
    velocity = float(near["velocity"])
    where = (f"nearest grid point ({float(near['f']):.4g} Hz, "
             f"{float(near['a']):.3g} m s$^{{-2}}$)")
    code = int(near["status"]) if "status" in near else None
    if code == Status.LIFT_OFF:
        return f"{where}: lift-off (model invalid)"
    if code == Status.NOT_CONVERGED:
        return f"{where}: not converged"
    if code == Status.STATIC or velocity == 0.0:
        return f"{where}: static, v = 0"
    if not np.isfinite(velocity):
        return f"{where}: no velocity"
    text = f"{where}: v = {1e3 * velocity:+.3g} mm s$^{{-1}}$"
    if "velocity_one_way" in near and "status_one_way" in near:
        # A two-way study with the paper's model beside it.
        paper = float(near["velocity_one_way"])
        text += (f"\nthe one-way (paper's) model: v = {1e3 * paper:+.3g} mm s$^{{-1}}$"
                 if np.isfinite(paper)
                 else "\nthe one-way (paper's) model: no velocity")
    return text


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the force traces at the paper's four points into ``output.png/.pdf``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A result over (f, a) holding the velocity (and normally the status), with
        the structure's parameters as scalar coordinates.
    output : pathlib.Path
        File stem.

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    single_structure(dataset, "force-traces")
    structure = common.structure_from_dataset(dataset)
    g, cs = structure.g, structure.cs
    phase = np.linspace(0.0, PERIODS, 1601)  # time in drive periods

    fig, axes = plt.subplots(2, 2, figsize=(10.0, 7.2), sharex=True, sharey=True,
                             layout="constrained")
    lowest = highest = 0.0
    any_lift = False
    for ax, (name, (f_point, a_point)) in zip(axes.flat, PAPER_POINTS.items(), strict=True):
        t = phase / f_point
        n = normal_force(structure, f_point, a_point, t)
        tau = tangential_force(structure, f_point, a_point, t)
        lifted = n < 0.0  # outside the model: neither slip criterion applies
        forward = (tau > cs * n) & ~lifted
        backward = (-tau > cs * n) & ~lifted
        strip = ax.get_xaxis_transform()
        ax.fill_between(phase, 0, 1, where=forward, color="tab:blue", alpha=0.18, lw=0,
                        transform=strip)
        ax.fill_between(phase, 0, 1, where=backward, color="tab:red", alpha=0.18, lw=0,
                        transform=strip)
        if np.any(lifted):
            any_lift = True
            ax.fill_between(phase, 0, 1, where=lifted, facecolor="none", edgecolor="0.4",
                            hatch="xx", lw=0, transform=strip)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.plot(phase, n / g, color="black", lw=1.6)
        ax.plot(phase, -n / g, color="black", lw=0.9, ls=":")
        ax.plot(phase, tau / (cs * g), color="tab:purple", lw=1.6)
        lowest = min(lowest, float(np.min(-n / g)), float(np.min(tau / (cs * g))))
        highest = max(highest, float(np.max(n / g)), float(np.max(tau / (cs * g))))

        a_plus, a_minus = (float(x) for x in thresholds(structure, f_point))
        model = region_of(a_point, a_plus, a_minus)
        region = f"region {name}" if model == name else f"region {name} (model: {model})"
        ax.set_title(
            f"{region}: f = {f_point:g} Hz, a = {a_point:g} m s$^{{-2}}$\n"
            f"{_grid_text(dataset, f_point, a_point)}",
            fontsize=9.5,
        )
    pad = 0.06 * (highest - lowest)
    axes[0, 0].set(xlim=(0.0, PERIODS), ylim=(lowest - pad, highest + pad))
    for ax in axes[1]:
        ax.set_xlabel("time t / T  (T = 1/f: drive periods)")
    for ax in axes[:, 0]:
        ax.set_ylabel("force per unit weight [1]")

    handles = [
        Line2D([], [], color="black", lw=1.6, label="n(t) / g  (normal)"),
        Line2D([], [], color="black", lw=0.9, ls=":", label="-n(t) / g"),
        Line2D([], [], color="tab:purple", lw=1.6, label=r"$\tau(t)$ / ($c_s$ g)  (tangential)"),
        Patch(facecolor="tab:blue", alpha=0.18, label=r"$\tau > c_s n$: forward slip possible"),
        Patch(facecolor="tab:red", alpha=0.18,
              label=r"$-\tau > c_s n$: backward slip possible"),
    ]
    if any_lift:
        handles.append(Patch(facecolor="none", edgecolor="0.4", hatch="xx",
                             label="n < 0: lift-off, model invalid"))
    title = "Contact forces over two drive periods at the paper's points S, P, N, PN"
    traces = "forces with the base at rest and the mode on its steady response"
    if dataset.attrs.get("study_coupling") == "two-way":
        # Two-way coupling changes the forces only once the base slides: the traces
        # still decide where slips start, the velocities are the file's.
        traces += " (as in both couplings until a slip starts)"
    title = f"{title}; velocities: {coupling_label(dataset)}"
    fig.suptitle(f"{title.replace('; ', chr(10), 1)}\n{traces}\n{parameter_text(dataset)}",
                 fontsize=10.5)
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=8.5,
               frameon=False)
    return common.save(fig, output, dataset, title)

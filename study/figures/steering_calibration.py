"""Calibrating the steering commands: the disk's steady motion against drive frequency.

Drawn from a ``steering-calibration`` result file alone (``study figure
steering-calibration FILE``), a calibration scene over drive frequency ``f`` and
acceleration ``a``. Top: the forward speed; bottom: the turn rate (degree s-1, as
the file stores it), one line per acceleration. Points where the disk lifts off or the motion
did not converge have no speed and are marked on the zero line. Dotted lines mark
the paper's command frequencies: forward 14.2 Hz, backward 15.2 Hz, turns 7.2 and
8.2 Hz.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.colors import ListedColormap, Normalize
from matplotlib.lines import Line2D

from study.figures import FigureError
from study.figures.common import require_axis, restore_dim, save, scene_suptitle
from study.figures.steering import angle_values, check_scene_kind, flag_codes, flag_names
from study.model.status import Status
from study.model.units import DEGREE_PER_SECOND

__all__ = ["COMMANDS", "draw"]

#: The paper's command frequencies [Hz] (Fig. 4). Its text has the right turn at 7.2 Hz
#: and the left at 8.2 Hz, its caption the other way round, so both are "turn".
COMMANDS: tuple[tuple[str, float], ...] = (
    ("forward", 14.2),
    ("backward", 15.2),
    ("turn", 7.2),
    ("turn", 8.2),
)

#: Colours of the accelerations (viridis without its lightest yellow).
ACCELERATION_COLORS = ListedColormap(colormaps["viridis"](np.linspace(0.0, 0.9, 256)),
                                     name="viridis-dark")

#: More accelerations than this get a colour bar instead of a legend entry each.
LEGEND_MAX = 6

#: Statuses without a speed, and how they are marked on the zero line.
UNMARKED = {Status.LIFT_OFF: ("x", "0.45"), Status.NOT_CONVERGED: ("+", "black")}

#: A calibration's variables over (f, a).
ALONG_F_A = ("forward_speed", "lateral_speed", "turn_rate", "slips_per_period",
             "stuck_fraction", "status", "periods", "orbit_period", "edge_contact_margin")

STATUS_NAMES = ("static", "stick_slip", "continuous_sliding", "lift_off", "not_converged")


def _plot(dataset: xr.Dataset) -> plt.Figure:
    """The calibration figure (not saved): speed lines carry gid ``forward-I`` and
    ``turn-I`` for acceleration index ``I``; the status marks ``lift_off-forward``,
    ``not_converged-turn`` etc."""
    check_scene_kind(dataset, "steering-calibration", "calibration")
    require_axis(dataset, "steering-calibration", "f",
                 "the steady motion against f, one line per acceleration")
    # One acceleration selected (--sel a=7): its line alone.
    dataset = restore_dim(dataset, "a", ALONG_F_A)
    for name in ("forward_speed", "turn_rate", "status"):
        if set(dataset[name].dims) != {"f", "a"}:
            raise FigureError(
                f"figure 'steering-calibration' draws variables over (f, a); {name!r} has "
                f"dimensions {dataset[name].dims}"
            )
    f = dataset["f"].values
    a = dataset["a"].values
    forward = 1e3 * dataset["forward_speed"].transpose("a", "f").values  # mm s-1 over (a, f)
    angle_values(dataset, "turn_rate", "steering-calibration", DEGREE_PER_SECOND)
    turn = dataset["turn_rate"].transpose("a", "f").values  # degree/s
    status = flag_codes(dataset["status"].transpose("a", "f"), missing=Status.NOT_CONVERGED)
    names = flag_names(dataset["status"], STATUS_NAMES)

    norm = Normalize(float(np.min(a)), float(np.max(a))) if a.size > 1 else None
    colors = ACCELERATION_COLORS(norm(a) if norm is not None else np.zeros(a.size))
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9.0, 7.4), sharex=True,
                                      layout="constrained")
    for ax, values, kind in ((top, forward, "forward"), (bottom, turn, "turn")):
        ax.axhline(0.0, color="0.4", lw=0.7)
        for i in range(a.size):
            (line,) = ax.plot(f, values[i], "-", marker="." if f.size <= 40 else None,
                              ms=3, lw=1.2, color=colors[i])
            line.set_gid(f"{kind}-{i}")
        for code, (marker, color) in UNMARKED.items():
            where = status == code
            if np.any(where):
                ax.plot(np.broadcast_to(f, status.shape)[where], np.zeros(int(where.sum())),
                        marker, ls="none", color=color, ms=6, mew=1.2,
                        gid=f"{names.get(int(code), str(code))}-{kind}")
        ax.grid(color="0.92", lw=0.6)

    low, high = float(np.min(f)), float(np.max(f))
    for name, frequency in COMMANDS:
        if low <= frequency <= high:
            for ax in (top, bottom):
                ax.axvline(frequency, color="0.25", ls=":", lw=1.0)
            top.annotate(f"{name} {frequency:g} Hz", (frequency, 1.0),
                         xycoords=("data", "axes fraction"), xytext=(2, -3),
                         textcoords="offset points", rotation=90, va="top", ha="left",
                         fontsize=7, color="0.25")

    top.set_ylabel("forward speed [mm s$^{-1}$]")
    top.set_title("along the head-tail axis (> 0: forward)", fontsize=10)
    bottom.set_ylabel("turn rate [degree s$^{-1}$]")
    bottom.set_title("rotation of the heading (> 0: counterclockwise)", fontsize=10)
    bottom.set_xlabel("drive frequency f [Hz]")

    marks = [
        Line2D([], [], marker=marker, ls="none", color=color, ms=6, mew=1.2,
               label=f"{names.get(int(code), str(code))} (no speed)")
        for code, (marker, color) in UNMARKED.items() if np.any(status == code)
    ]
    marks.append(Line2D([], [], color="0.25", ls=":", lw=1.0, label="paper's commands"))
    if a.size <= LEGEND_MAX or norm is None:
        marks = [Line2D([], [], color=colors[i], lw=1.5, label=f"a = {v:g} m s$^{{-2}}$")
                 for i, v in enumerate(a)] + marks
    else:
        fig.colorbar(ScalarMappable(norm=norm, cmap=ACCELERATION_COLORS), ax=[top, bottom],
                     label="drive acceleration a [m s$^{-2}$]", shrink=0.8)
    fig.legend(handles=marks, fontsize=8, loc="outside lower center", frameon=False,
               ncol=min(len(marks), 4))
    at = (f"a = {a[0]:g} m s$^{{-2}}$" if a.size == 1 else f"{a.size} accelerations")
    scene_suptitle(fig, dataset, "Steering commands: steady motion of the disk over "
                   f"f = {low:g}-{high:g} Hz at {at}", 10)
    return fig


def draw(dataset: xr.Dataset, output: Path) -> list[Path]:
    """Draw the calibration of a ``steering-calibration`` result into ``output.png/.pdf``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A calibration scene: forward speed, turn rate and status over (f, a).
    output : pathlib.Path
        File stem.

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    return save(_plot(dataset), output, dataset,
                "Steering commands: forward speed and turn rate against drive frequency")

"""How far two-way coupling moves a study's velocities from the paper's one-way model."""

from __future__ import annotations

import numpy as np
import xarray as xr

from study.model.status import Status
from study.model.units import DIMENSIONLESS

__all__ = ["coupling_effect"]

#: Statuses of a moving structure (the one-way model never bounces: flight needs
#: two-way coupling).
_MOVING = (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING, Status.BOUNCING)


def coupling_effect(dataset: xr.Dataset, threshold: float = 0.1) -> xr.Dataset:
    """How far two-way coupling moves the steady velocity from the paper's one-way model.

    Parameters
    ----------
    dataset : xarray.Dataset
        A two-way study holding ``velocity``/``status`` and the ``paper_model``
        observable (``velocity_one_way``/``status_one_way``) over ``(..., f, a)``.
    threshold : float
        Relative change [1] above which a point counts as changed.

    Returns
    -------
    xarray.Dataset
        Over the structure axes (the drive axes reduced), each a fraction [1] of the
        points where the one-way model moves (stick-slip or continuous sliding):
        ``changed`` (two-way also moves, bouncing included, and
        ``|v2 - v1| > threshold |v1|``), ``reversed`` (opposite direction), ``lifted``
        (two-way leaves the table and stops: lift-off), ``bouncing`` (two-way leaves the
        table and lands again: a study with flight), ``paradox`` (two-way friction
        paradox), and ``median_change`` (median ``|v2 - v1| / |v1|`` over the points
        where both move) and ``moving_points``.
    """
    missing = [v for v in ("velocity", "status", "velocity_one_way", "status_one_way")
               if v not in dataset]
    if missing:
        raise ValueError(
            f"coupling_effect needs {', '.join(missing)}: a two-way study with the "
            "'paper_model' observable"
        )
    v1 = dataset["velocity_one_way"]
    v2 = dataset["velocity"]
    moving1 = dataset["status_one_way"].isin(list(_MOVING)) & (v1 != 0)
    moving2 = dataset["status"].isin([*_MOVING, Status.STATIC])
    both = moving1 & moving2
    relative = (abs(v2 - v1) / abs(v1)).where(both)
    drive = [d for d in ("f", "a") if d in dataset.dims]
    count = moving1.sum(drive)
    safe = count.where(count > 0)

    def share(mask: xr.DataArray) -> xr.DataArray:
        return (mask & moving1).sum(drive) / safe

    out = xr.Dataset(
        {
            "changed": share(both & (relative > threshold)),
            "reversed": share(both & (np.sign(v2) * np.sign(v1) < 0)),
            "lifted": share(dataset["status"] == Status.LIFT_OFF),
            "bouncing": share(dataset["status"] == Status.BOUNCING),
            "paradox": share(dataset["status"] == Status.FRICTION_PARADOX),
            "median_change": relative.median(drive),
            "moving_points": count,
        }
    )
    for name in ("changed", "reversed", "lifted", "bouncing", "paradox", "median_change"):
        out[name].attrs["units"] = DIMENSIONLESS
    out["moving_points"].attrs["units"] = DIMENSIONLESS
    out.attrs["threshold"] = threshold
    return out

"""A result-like dataset of the ``basins`` variables computed by the API
(:func:`study.solvers.basins.basins`), for the tests of the global continuation and its
figures until the engine's ``basins`` observable writes them.

The variable names are the observable's: per drive point and attractor ``basin_status``,
``basin_velocity``, ``basin_velocity_error``, ``basin_largest_hop``, ``basin_period``,
``basin_multiplier``, ``basin_exponent``, ``basin_fraction``, ``basin_fraction_low``,
``basin_fraction_high``; per point ``attractor_count``, ``default_attractor`` and
``starts_drawn``.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

import study
from study.solvers.basins import Basins, basins

#: The fields of :class:`~study.solvers.basins.Basins` each variable is.
PER_ATTRACTOR = {
    "basin_status": "status",
    "basin_velocity": "velocity",
    "basin_velocity_error": "velocity_error",
    "basin_largest_hop": "largest_hop",
    "basin_period": "orbit_period",
    "basin_multiplier": "floquet_multiplier",
    "basin_exponent": "lyapunov_exponent",
    "basin_fraction": "fraction",
    "basin_fraction_low": "fraction_low",
    "basin_fraction_high": "fraction_high",
}
PER_POINT = {"attractor_count": "count", "default_attractor": "default_attractor",
             "starts_drawn": "starts_drawn"}


def as_dataset(found: Basins, structure: study.Structure, f, a, *, flight: bool,
               name: str = "basins-test") -> xr.Dataset:
    """The :class:`Basins` of the grid ``f`` x ``a`` (``indexing="ij"``) as a dataset
    over ``(f, a, attractor)``."""
    dims = ("f", "a", "attractor")
    variables = {key: (dims, getattr(found, field)) for key, field in PER_ATTRACTOR.items()}
    variables.update({key: (dims[:2], getattr(found, field))
                      for key, field in PER_POINT.items()})
    units = {"basin_velocity": "m s-1", "basin_velocity_error": "m s-1",
             "basin_largest_hop": "m"}
    dataset = xr.Dataset(
        variables,
        coords={"f": ("f", np.asarray(f, float), {"units": "Hz"}),
                "a": ("a", np.asarray(a, float), {"units": "m s-2"}),
                "attractor": np.arange(found.status.shape[-1]),
                **{k: getattr(structure, k) for k in ("f0", "Q", "alpha", "M", "cs")}},
        attrs={"study_name": name, "study_coupling": "two-way",
               "study_flight": int(bool(flight))})
    for key, unit in units.items():
        dataset[key].attrs["units"] = unit
    return dataset


def computed(structure: study.Structure, f, a, *, starts: int = 8, flight: bool = False,
             seed: int = 0, name: str = "basins-test") -> xr.Dataset:
    """:func:`basins` on the grid ``f`` x ``a`` as a dataset (:func:`as_dataset`)."""
    f, a = np.asarray(f, float), np.asarray(a, float)
    grid_f, grid_a = np.meshgrid(f, a, indexing="ij")
    found = basins(structure, grid_f, grid_a, starts=starts, seed=seed, flight=flight)
    return as_dataset(found, structure, f, a, flight=flight, name=name)

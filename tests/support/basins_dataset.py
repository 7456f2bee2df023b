"""A basins map computed in memory by the engine (``compute_map`` with the ``basins``
observable), for the tests of the global continuation and its figures: the dataset a
study file with ``observables = ["basins"]`` holds (``basin_status``,
``basin_velocity``, ..., over ``(f, a, attractor)``).
"""

from __future__ import annotations

import xarray as xr

import study
from study.studies.maps import compute_map


def computed(structure: study.Structure, f, a, *, starts: int = 8, flight: bool = False,
             seed: int = 0, name: str = "basins-test") -> xr.Dataset:
    """The basins observable on the grid ``f`` x ``a`` (two-way coupling, ``starts``
    seeded starts a point), named ``name`` (``study_name``)."""
    dataset = compute_map(structure, f, a, observables=["basins"], coupling="two-way",
                          flight=flight, basins={"starts": starts, "seed": seed})
    dataset.attrs.setdefault("study_name", name)
    return dataset

"""The study kind's format steps: rewrite an older study result in a newer format
without recomputing a value (declared in :data:`study.studies.variables.STUDY_FORMATS`,
run by :func:`study.engine.upgrade.upgrade_result`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from study.studies.layout import method_attributes, protocol_attributes, study_summary
from study.studies.spec import parse_spec
from study.studies.variables import VARIABLES

__all__ = ["to_format_3", "to_format_4", "to_format_5"]


def to_format_3(nc: Any) -> None:
    """Format 2 -> 3: the method attributes and today's status flags.

    The method attributes (friction law and its parameters, lift-off law and its
    restitution, ``source``, and the ``summary`` that names them) follow from the
    embedded spec, which decided the numbers;
    each flag variable declares today's full set of flags, a superset of the one it was
    written with whose codes keep their meanings. No value is read or written.

    Parameters
    ----------
    nc : netCDF4.Dataset
        A study result of format 2, open in append mode.
    """
    spec = parse_spec(str(nc.getncattr("study_spec")), "the embedded spec")
    for name, value in method_attributes(spec).items():
        nc.setncattr(name, value)
    nc.setncattr("summary", study_summary(spec))  # it names the method too
    _declare_flags(nc)


def to_format_4(nc: Any) -> None:
    """Format 3 -> 4: today's status and nonconvergence flags (``chaotic``,
    ``quasi_periodic`` and ``average_budget`` added; every code keeps its meaning).
    No value is read or written: a file of format 3 holds none of the new codes.

    Parameters
    ----------
    nc : netCDF4.Dataset
        A study result of format 3, open in append mode.
    """
    _declare_flags(nc)


def to_format_5(nc: Any) -> None:
    """Format 4 -> 5: the start each point's motion began from, recorded.

    A file of format 4 (study 0.3.0) has no start attributes: its points started by the
    release, and it holds no slow sweep (no ``[sweep] protocol``, no ``jumped``, no
    ``direction`` dimension), no ``unswept`` and no ``section`` variables. Format 5
    requires ``study_start`` and ``study_start_kind``: they are written from the
    embedded spec, which decided the numbers (``"release"`` for every file 0.3.0
    wrote), as :func:`study.studies.layout.protocol_attributes` writes them for a new
    file. No value is read or written; the flags are already today's.

    Parameters
    ----------
    nc : netCDF4.Dataset
        A study result of format 4, open in append mode.
    """
    spec = parse_spec(str(nc.getncattr("study_spec")), "the embedded spec")
    for name, value in protocol_attributes(spec).items():
        nc.setncattr(name, value)


def _declare_flags(nc: Any) -> None:
    """Each flag variable declares today's full set of flags, a superset of the one it
    was written with whose codes keep their meanings."""
    for name, variable in nc.variables.items():
        declared = VARIABLES.get(name)
        if declared is not None and declared.is_flag:
            variable.setncattr("flag_values", np.array(declared.flag_values,
                                                       dtype=declared.dtype))
            variable.setncattr("flag_meanings", " ".join(declared.flags))

"""study: parameter studies of vibration-driven stick-slip locomotion.

A soft structure with a resonant plate, on a vertically shaken table, walks forward
or backward by stick-slip (Barois, Boucherie, Tadrist & Kellay). See the documentation
in docs/ (``make docs``).

The computing functions are imported with the package, and so are the modules of the
result kinds (study, scene, fit, design), which register themselves in
:mod:`study.engine.kinds`; :func:`run`, :func:`open_result` and :class:`ResultError`
are imported on first use.
"""

from importlib import import_module as _import_module

from study.analyses.branches import bifurcation_curve, branch, doubled_branch
from study.analyses.frontier import frontier
from study.analyses.thresholds import minimum_threshold
from study.engine.spec_files import SpecError
from study.model import (
    force_amplitudes,
    lift_off_acceleration,
    mode_response,
    normal_force,
    tangential_force,
    thresholds,
)
from study.model.contact import Friction
from study.model.inputs import StudyWarning, SuspectInputWarning
from study.model.starts import Drop
from study.model.status import NonConvergence, Status
from study.model.structure import Structure
from study.solvers.exact import steady_state, steady_velocity
from study.solvers.settings import SolverSettings
from study.solvers.steady import SteadyState
from study.studies.maps import compute_map
from study.version import VERSION as __version__

# The result kinds register themselves (study.engine.kinds) when their modules are
# imported, in this order (which messages listing the kinds follow): the engine looks
# them up there and imports no scene or analysis module. Through an alias the code
# fingerprint does not follow, on purpose: registering one kind changes no other kind's
# numbers, so each kind's code hash stays its own modules' (study.engine.fingerprint).
_import_module("study.studies.kind")
_import_module("study.scenes.scene_kind")
_import_module("study.analyses.fit")
_import_module("study.analyses.design")

__all__ = [
    "Drop",
    "Friction",
    "NonConvergence",
    "ResultError",
    "SolverSettings",
    "SpecError",
    "Status",
    "SteadyState",
    "Structure",
    "StudyWarning",
    "SuspectInputWarning",
    "__version__",
    "bifurcation_curve",
    "branch",
    "compute_map",
    "doubled_branch",
    "force_amplitudes",
    "frontier",
    "lift_off_acceleration",
    "minimum_threshold",
    "mode_response",
    "normal_force",
    "open_result",
    "run",
    "steady_state",
    "steady_velocity",
    "tangential_force",
    "thresholds",
]


#: Public names defined by the modules that keep and read result files, imported on
#: first use: name -> module.
_ON_FIRST_USE = {"run": "study.api", "open_result": "study.engine.validation",
                 "ResultError": "study.engine.validation"}


def __getattr__(name: str):
    module = _ON_FIRST_USE.get(name)
    if module is None:
        raise AttributeError(f"module 'study' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})

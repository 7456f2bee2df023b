"""The named columns of a traced branch's rows (:func:`study.kernels.two_way.
bifurcations.trace_branch`): a step's and a located bifurcation's, with their units, and
the index of each column the kernels read or write."""

from __future__ import annotations

__all__ = ["BIFURCATION_COLUMNS", "B_IMAG", "B_KIND", "B_MAP_PASSES", "B_NEWTON_PASSES",
           "B_REAL", "B_SECTION", "B_STATE", "B_STEP", "B_T", "B_TEST", "B_VELOCITY",
           "N_BIFURCATION", "N_STEP", "STEP_COLUMNS", "S_AIRBORNE", "S_EVENTS", "S_HOP",
           "S_IMPACTS", "S_RADIUS", "S_SECTION", "S_SLIPS", "S_STATE", "S_STICK", "S_T",
           "S_TANGENT", "S_VELOCITY"]

#: The columns of a traced step's row, in order, with their units.
STEP_COLUMNS = (
    ("t", "1", "the step's place on the segment: 0 at the start, 1 at its end"),
    ("velocity", "m s-1", "mean velocity over the orbit"),
    ("radius", "1", "largest modulus of the orbit's Floquet multipliers"),
    ("tangent_t", "1", "the branch tangent's drive component (its sign: the way the "
     "branch runs along the segment)"),
    ("events", "1", "events of the orbit over its period"),
    ("slips", "1", "slip events per drive period"),
    ("impacts", "1", "impacts per drive period"),
    ("stick", "1", "fraction of the period the base is stuck"),
    ("airborne", "1", "fraction of the period the base is off the table"),
    ("hop", "m", "largest gap between the base and the table over the orbit"),
    ("section", "1", "the section's place in the orbit's period (a fraction of it from "
     "phase 0)"),
    ("delta", "m", "the mode's displacement on the section"),
    ("delta_rate", "m s-1", "the mode's velocity on the section"),
    ("speed", "m s-1", "the sliding speed on the section"),
    ("gap", "m", "the base's height above the table on the section"),
    ("gap_rate", "m s-1", "the rate of that height on the section"),
)
_STEP = tuple(name for name, _, _ in STEP_COLUMNS)
S_T = _STEP.index("t")
S_VELOCITY = _STEP.index("velocity")
S_RADIUS = _STEP.index("radius")
S_TANGENT = _STEP.index("tangent_t")
S_EVENTS = _STEP.index("events")
S_SLIPS = _STEP.index("slips")
S_IMPACTS = _STEP.index("impacts")
S_STICK = _STEP.index("stick")
S_AIRBORNE = _STEP.index("airborne")
S_HOP = _STEP.index("hop")
S_SECTION = _STEP.index("section")
S_STATE = _STEP.index("delta")
#: Length of a step's row.
N_STEP = len(STEP_COLUMNS)

#: The columns of a located bifurcation's row, in order, with their units.
BIFURCATION_COLUMNS = (
    ("kind", "1", "study.model.bifurcations code of the bifurcation"),
    ("t", "1", "its place on the segment"),
    ("velocity", "m s-1", "mean velocity of the orbit there"),
    ("test", "1", "the test function's value there (the tangent's drive component at a "
     "fold, mu + 1 at a period doubling, |mu| - 1 at a torus, mu - 1 at a branch point; "
     "0 where located by bisection)"),
    ("multiplier_real", "1", "the multiplier that crosses (real part; the largest "
     "modulus's where located by bisection)"),
    ("multiplier_imag", "1", "its imaginary part"),
    ("step", "1", "the index of the step before it"),
    ("section", "1", "the section's place in the orbit's period"),
    ("delta", "m", "the mode's displacement on the section"),
    ("delta_rate", "m s-1", "the mode's velocity on the section"),
    ("speed", "m s-1", "the sliding speed on the section"),
    ("gap", "m", "the base's height above the table on the section"),
    ("gap_rate", "m s-1", "the rate of that height on the section"),
    ("newton_passes", "1", "passes of the period map with its Jacobian that locating it "
     "took (beyond the branch's own steps)"),
    ("map_passes", "1", "passes without the Jacobian that locating it took"),
)
_BIFURCATION = tuple(name for name, _, _ in BIFURCATION_COLUMNS)
B_KIND = _BIFURCATION.index("kind")
B_T = _BIFURCATION.index("t")
B_VELOCITY = _BIFURCATION.index("velocity")
B_TEST = _BIFURCATION.index("test")
B_REAL = _BIFURCATION.index("multiplier_real")
B_IMAG = _BIFURCATION.index("multiplier_imag")
B_STEP = _BIFURCATION.index("step")
B_SECTION = _BIFURCATION.index("section")
B_STATE = _BIFURCATION.index("delta")
B_NEWTON_PASSES = _BIFURCATION.index("newton_passes")
B_MAP_PASSES = _BIFURCATION.index("map_passes")
#: Length of a bifurcation's row.
N_BIFURCATION = len(BIFURCATION_COLUMNS)

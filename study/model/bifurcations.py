"""The bifurcations of a periodic orbit's branch and the ends of a traced branch,
declared once: each kind's code, its name, what it means for the walker and its test
function.

The codes are :mod:`study.model.codes`' (the kernels return them as plain integers);
the ``flag_values``/``flag_meanings`` of the result variables, the documentation's
table (:func:`markdown_table`) and the figures' markers follow from :data:`KINDS` and
:data:`ENDS`. A kind is only ever added, never renumbered.
"""

from __future__ import annotations

from dataclasses import dataclass

from study.model import codes

__all__ = ["CURVE_ENDS", "ENDS", "JUMP_FLAGS", "JUMP_FLAG_VALUES", "JUMP_NONE",
           "JUMP_UNLOCATED", "KINDS", "LOCATED", "LOCATION_FLAGS", "LOCATION_NONE",
           "NOT_CONVERGED", "BifurcationKind", "BranchEnd", "curve_end_named",
           "end_named", "kind_named", "kind_of_code", "markdown_table"]


@dataclass(frozen=True)
class BifurcationKind:
    """A kind of bifurcation on a periodic orbit's branch.

    Attributes
    ----------
    name : str
        Its name in data and in the API (``bifurcation_kind``'s flag meaning).
    code : int
        Its code (:mod:`study.model.codes`).
    meaning : str
        What happens to the orbit there, and what it means for the walker.
    test : str
        How it is found and located.
    marker : str
        Its matplotlib marker in the figures.
    """

    name: str
    code: int
    meaning: str
    test: str
    marker: str


#: The kinds of bifurcation, in code order.
KINDS = (
    BifurcationKind(
        "fold", codes.BIFURCATION_FOLD,
        "a real Floquet multiplier through +1: the branch turns back (a saddle-node), "
        "the stable orbit meeting an unstable one; a slow sweep that rides the stable "
        "one jumps here",
        "the sign of the branch tangent's drive component, located by regula falsi on "
        "it", "s"),
    BifurcationKind(
        "period_doubling", codes.BIFURCATION_PERIOD_DOUBLING,
        "a real multiplier through -1: the orbit loses (or gains) its stability to an "
        "orbit of twice its period, a hop that alternates between two heights",
        "mu + 1 for the real multiplier nearest -1, located by regula falsi", "D"),
    BifurcationKind(
        "torus", codes.BIFURCATION_TORUS,
        "a complex pair of multipliers through the unit circle (Neimark-Sacker): a "
        "quasi-periodic motion is born about the orbit",
        "|mu| - 1 for the complex pair nearest the unit circle, located by regula falsi",
        "o"),
    BifurcationKind(
        "grazing", codes.BIFURCATION_GRAZING,
        "the orbit's sequence of events changes: a flight touches the table, a stick or "
        "a slip shrinks to nothing (the period map is only piecewise smooth there: the "
        "branch may go on with the new sequence, fold or end)",
        "the sequence of events of a period, located by bisection", "^"),
    BifurcationKind(
        "lift_off", codes.BIFURCATION_LIFT_OFF,
        "without flight the orbit's normal force reaches 0: the base would leave the "
        "table, where the contact model stops applying; the branch ends",
        "the corrector refused by a lift-off past the last step, located by bisection "
        "between the last orbit in contact and the first refused", "v"),
    BifurcationKind(
        "slip_onset", codes.BIFURCATION_SLIP_ONSET,
        "on the table a stick first slips (or the last slip vanishes): the static "
        "motion ends at the thresholds a*+- of eq. 5 and the structure starts to walk",
        "the sequence of events (a slip appears), located by bisection", "P"),
    BifurcationKind(
        "branch_point", codes.BIFURCATION_BRANCH_POINT,
        "a real multiplier through +1 while the branch runs on: another branch crosses "
        "this one (as an orbit of twice the period meets its own at a period doubling)",
        "mu - 1 for the real multiplier nearest +1, located by regula falsi", "X"),
)


#: A slow sweep's point that did not jump: no bifurcation to locate.
JUMP_NONE = 0
#: A point where the sweep jumped but the branch of the previous point's orbit shows no
#: bifurcation between the two drives that ends its stable motion (it goes on stable
#: and the carried state left its basin, or the motion before had no orbit to follow).
JUMP_UNLOCATED = -1
#: The flags of a located jump (``jump_bifurcation``): ``unlocated``, ``no_jump`` and
#: every kind, by its name.
JUMP_FLAGS = ("unlocated", "no_jump", *(kind.name for kind in KINDS))
#: Their codes, in the order of :data:`JUMP_FLAGS`.
JUMP_FLAG_VALUES = (JUMP_UNLOCATED, JUMP_NONE, *(kind.code for kind in KINDS))

#: How a bifurcation of a branch was placed, by code (0, 1, 2): ``none``, a slot past the
#: branch's bifurcations; ``located``, its test function solved to the tracer's
#: tolerance (or its event sequence bisected) to 1e-10 of the drive; ``not_converged``,
#: the location stopped short of it (the corrector failed, or the test function did not
#: come within 100 times its tolerance, as at the birth of a doubled orbit's branch,
#: where its tangent is not defined): the bifurcation lies within the step before it,
#: recorded at the best point found or at the step's end (its multiplier then NaN).
LOCATION_FLAGS = ("none", "located", "not_converged")
LOCATION_NONE, LOCATED, NOT_CONVERGED = range(len(LOCATION_FLAGS))

@dataclass(frozen=True)
class BranchEnd:
    """Why a traced branch ended.

    Attributes
    ----------
    name : str
        Its name (the ``branch_end`` attribute).
    code : int
        Its code (:mod:`study.model.codes`).
    meaning : str
        What it means.
    """

    name: str
    code: int
    meaning: str


#: The ends of a traced branch, in code order.
ENDS = (
    BranchEnd("reached", codes.BRANCH_REACHED,
              "the branch reached the drive asked for (`to`)"),
    BranchEnd("ended", codes.BRANCH_ENDED,
              "the orbit ceases to exist: no step, however short, follows it on (a "
              "non-smooth end; without flight a lift-off)"),
    BranchEnd("budget", codes.BRANCH_BUDGET,
              "the budget of steps was spent before `to`"),
    BranchEnd("turned_back", codes.BRANCH_LEFT,
              "the branch turned back through its folds and came back past its start"),
    BranchEnd("not_followed", codes.BRANCH_LOST,
              "the orbit could not be followed from its start (not a fixed point of the "
              "period map to the solver's precision there)"),
    BranchEnd("stopped", codes.BRANCH_STOPPED,
              "stopped on the step past the first bifurcation of the kind asked for (a "
              "curve's search for its next point needs no more of the branch)"),
)


#: The ends of a bifurcation's curve over the drive plane, in code order.
CURVE_ENDS = (
    BranchEnd("reached", codes.CURVE_REACHED,
              "the curve reached the drive asked for (`to`)"),
    BranchEnd("vanished", codes.CURVE_VANISHED,
              "the branch runs on past where the bifurcation was without meeting it: "
              "for a fold, a cusp, where it meets the branch's other fold and the "
              "coexistence of two orbits is born or dies"),
    BranchEnd("ended", codes.CURVE_ENDED,
              "the branch's orbit ceases to exist before the bifurcation (another "
              "bifurcation, a grazing or a lift-off, cuts the curve)"),
    BranchEnd("lost", codes.CURVE_LOST,
              "the last point's orbit could not be corrected at the next drive: the "
              "curve moves faster than its sampling (more points follow it further)"),
)


def _find(family, field, value, what):
    """The member of ``family`` whose ``field`` is ``value``; a ValueError lists them."""
    for member in family:
        if getattr(member, field) == value:
            return member
    raise ValueError(f"unknown {what} {value!r}; allowed: "
                     f"{', '.join(str(getattr(m, field)) for m in family)}")


def curve_end_named(code: int) -> BranchEnd:
    """The curve end (:data:`CURVE_ENDS`) of ``code``."""
    return _find(CURVE_ENDS, "code", code, "curve end")


def kind_named(name: str) -> BifurcationKind:
    """The :class:`BifurcationKind` called ``name``; a ValueError lists the names."""
    return _find(KINDS, "name", name, "bifurcation kind")


def kind_of_code(code: int) -> BifurcationKind:
    """The :class:`BifurcationKind` of ``code``."""
    return _find(KINDS, "code", code, "bifurcation code")


def end_named(code: int) -> BranchEnd:
    """The :class:`BranchEnd` of ``code``."""
    return _find(ENDS, "code", code, "branch end")


def markdown_table() -> str:
    """The kinds of bifurcation as a Markdown table (the documentation's)."""
    lines = ["| kind | code | what happens | found and located by |", "|---|---|---|---|"]
    for kind in KINDS:
        lines.append(f"| `{kind.name}` | {kind.code} | {kind.meaning} | {kind.test} |")
    return "\n".join(lines)

"""Status codes stored with every solved point (a CF flag variable on disk), declared
once: each status's code, its meaning, what its velocity is, and how figures show it.

The values are :mod:`study.model.codes`' (the kernels return them as plain integers).
Everything else follows from :class:`Status`: the ``flag_values``/``flag_meanings`` of
the ``status`` variables, :data:`INVALID_STATUSES`, the statuses table of the
documentation (:func:`markdown_table`) and the legend entries of the figures
(:attr:`Status.legend`, :attr:`Status.colour`). A status added here appears in all of
them by itself; a status is only ever added, never renumbered (files of older versions
keep their meaning).
"""

from __future__ import annotations

from enum import IntEnum

from study.model import codes

__all__ = ["INVALID_STATUSES", "VELOCITY_KINDS", "NonConvergence", "Status",
           "markdown_table"]

#: What a status's ``velocity`` is: ``"zero"`` exactly 0, ``"mean"`` the mean velocity
#: of the motion, ``"none"`` no velocity (NaN: outside the model or not found).
VELOCITY_KINDS = {"zero": "exactly 0", "mean": "mean velocity", "none": "NaN"}


class Status(IntEnum):
    """Outcome of the steady-state solver at one drive point.

    Every member carries its declaration: :attr:`meaning` (one sentence),
    :attr:`velocity` (a key of :data:`VELOCITY_KINDS`), :attr:`legend` (the label of
    its class in a figure's legend), :attr:`colour` (its flat colour in the maps, for
    the statuses without a velocity) and :attr:`hatch` (the hatch over its velocity in
    the maps, for a class of motion drawn apart; ``None`` for neither).
    """

    meaning: str
    velocity: str
    legend: str
    colour: str | None
    hatch: str | None

    def __new__(cls, code: int, meaning: str, velocity: str, legend: str,
                colour: str | None = None, hatch: str | None = None) -> Status:
        if velocity not in VELOCITY_KINDS:
            raise ValueError(f"Status velocity {velocity!r}; allowed: "
                             f"{', '.join(VELOCITY_KINDS)}")
        member = int.__new__(cls, code)
        member._value_ = code
        member.meaning = meaning
        member.velocity = velocity
        member.legend = legend
        member.colour = colour
        member.hatch = hatch
        return member

    STATIC = (codes.STATIC,
              "Below both motion thresholds: the structure never slips, ``v = 0`` exactly.",
              "zero", "static: never slips")
    STICK_SLIP = (codes.STICK_SLIP,
                  "Periodic orbit with at least one stick phase in every period.",
                  "mean", "stick-slip")
    CONTINUOUS_SLIDING = (codes.CONTINUOUS_SLIDING,
                          "Periodic orbit without any stick: slips reverse at ``v = 0`` "
                          "(seen as ``M -> 1``).",
                          "mean", "continuous sliding (no stick)", None, "////")
    LIFT_OFF = (codes.LIFT_OFF,
                "``n(t) < 0`` during the cycle: the structure leaves the table, the model "
                "without flight does not apply and no velocity is given.",
                "none", "lift-off: outside the model, no velocity", "0.72")
    NOT_CONVERGED = (codes.NOT_CONVERGED,
                     "No periodic orbit was found within the solver's budget; the reason "
                     "is in :class:`NonConvergence`. No velocity is given.",
                     "none", "not converged: no velocity", "black")
    FRICTION_PARADOX = (codes.FRICTION_PARADOX,
                        "Two-way coupling only: a slip's equations have no unique solution "
                        "(Painleve's paradox, ``1 - M sin(alpha) (sin(alpha) + s ck "
                        "cos(alpha)) <= 0``), as can happen for ``M`` close to 1 at steep "
                        "tilt. Outside the model; no velocity.",
                        "none", "friction paradox: outside the model, no velocity",
                        "tab:orange")
    BOUNCING = (codes.BOUNCING,
                "With flight only: a periodic orbit that leaves the table and lands again "
                "in every period (flight phases and impacts); its mean velocity is given.",
                "mean", "bouncing: flights and impacts (with flight)")
    CHAOTIC = (codes.CHAOTIC,
               "Two-way coupling: no stable cycle within reach, and the motion the solver's "
               "start reaches is chaotic (its largest Lyapunov exponent more than three "
               "standard errors above 0); its velocity is the time average over the "
               "period map's iterates, with its standard error and the periods averaged.",
               "mean", "chaotic: irregular, time-averaged velocity", None, "xxxx")
    QUASI_PERIODIC = (codes.QUASI_PERIODIC,
                      "Two-way coupling: no stable cycle within reach, and the motion "
                      "reached is irregular without a clearly positive Lyapunov exponent "
                      "(a quasi-periodic motion on an invariant curve, or a stable cycle "
                      "longer than the cycle search's 16 periods); its velocity is the "
                      "time average, as for CHAOTIC.",
                      "mean", "quasi-periodic: time-averaged velocity", None, "....")

    @property
    def flag(self) -> str:
        """The status's name in a file's ``flag_meanings`` (lower case)."""
        return self.name.lower()

    @property
    def has_velocity(self) -> bool:
        """Whether points of this status carry a velocity (not NaN)."""
        return self.velocity != "none"


def _attributes_section(enum: type[IntEnum], meanings: dict[str, str]) -> str:
    """A numpydoc ``Attributes`` section naming each member with its meaning."""
    lines = ["", "    Attributes", "    ----------"]
    for member in enum:
        lines += [f"    {member.name}", f"        {meanings[member.name]}"]
    return "\n".join(lines) + "\n"


Status.__doc__ = (Status.__doc__ or "") + _attributes_section(
    Status, {s.name: f"{s.meaning} Velocity: {VELOCITY_KINDS[s.velocity]}." for s in Status})


class NonConvergence(IntEnum):
    """Why a point has status ``NOT_CONVERGED`` (``NONE`` for every other status).

    Attributes
    ----------
    NONE
        The point converged (or did not need to).
    NO_PERIODIC_ORBIT
        The continuous-sliding circle map did not lock onto a stable periodic orbit
        within the budget of map iterations (quasi-periodic, chaotic, or too slowly
        attracting for the budget).
    EVENT_BUDGET
        The event loop exhausted its budget without closing an orbit.
    AVERAGE_BUDGET
        Two-way coupling: an irregular motion's time-averaged velocity was still outside
        the velocity tolerance after the most periods allowed (``max_average_periods``);
        its velocity error, periods averaged and exponent are kept.
    """

    NONE = codes.REASON_NONE
    NO_PERIODIC_ORBIT = codes.REASON_NO_PERIODIC_ORBIT
    EVENT_BUDGET = codes.REASON_EVENT_BUDGET
    AVERAGE_BUDGET = codes.REASON_AVERAGE_BUDGET


#: Statuses outside the model's validity or without a solution: no velocity (NaN),
#: derived from each status's declared :attr:`Status.velocity`.
INVALID_STATUSES = tuple(status for status in Status if not status.has_velocity)


def markdown_table() -> str:
    """The statuses as a Markdown table (code, name, meaning, velocity), for the docs.

    Returns
    -------
    str
        One row per :class:`Status`, in code order.
    """
    rows = ["| code | status | meaning | velocity |", "|---|---|---|---|"]
    for status in Status:
        meaning = status.meaning.replace("|", "\\|").replace(
            ":class:`NonConvergence`", "`NonConvergence`")
        rows.append(f"| {int(status)} | `{status.name}` | {meaning} | "
                    f"{VELOCITY_KINDS[status.velocity]} |")
    return "\n".join(rows) + "\n"

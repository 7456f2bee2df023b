"""Every data variable a study result can hold, declared once.

A :class:`Variable` carries what the file needs (dims, dtype, units, long_name, CF
flags) and what validation checks; :mod:`study.studies.observables` groups them into the
observables a spec asks for and says how each is computed. Nothing here computes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from study.engine.kinds import ResultFormat
from study.model.bifurcations import ENDS, JUMP_FLAG_VALUES, JUMP_FLAGS, KINDS, LOCATION_FLAGS
from study.model.statistics import Z_95
from study.model.status import NonConvergence, Status
from study.model.units import (
    DEGREE,
    DIMENSIONLESS,
    HERTZ,
    METRE,
    METRE_PER_SECOND,
    METRE_PER_SECOND_SQUARED,
)
from study.solvers.attractors import ATTRACTOR_DROPS, ATTRACTOR_STARTS
from study.solvers.basins import NO_ATTRACTOR
from study.solvers.fold_curves import (
    DOUBLING_STATUS_FLAGS,
    FOLD_END_FLAGS,
    FOLD_END_VALUES,
    FOLD_STATUS_FLAGS,
)
from study.solvers.section import SECTION_PERIODS
from study.solvers.steady import FIELD_DTYPES, FIELD_UNITS

__all__ = ["BASIN_STATUS_FLAGS", "DEFAULT_MAX_ATTRACTORS", "FRONTIER_KINDS", "GRIDS",
           "GRID_SIZES", "RESULT_FORMAT", "STALE_RESULT_FORMATS", "STUDY_FORMATS", "VARIABLES",
           "Variable", "solver_output"]

#: Every layout study results were written in (global attribute ``study_result_format``),
#: oldest first; the last is the one this version writes. Files without the attribute
#: are format 1, whose ``mode_phase`` was in rad: one that holds ``mode_phase`` is refused
#: as stale by validation (and so by ``info``, ``figure`` and ``export``) and rerun by
#: ``study run``; its other variables never changed units. A file of format 2 or later is
#: read by the rules of its own format; ``study upgrade`` rewrites it in the current one.
STUDY_FORMATS = (
    ResultFormat(1, "before 0.1.0", "mode_phase in rad", "study-result-v1.format-2"),
    ResultFormat(2, "0.1.0", "every angle in degree (mode_phase too)",
                 "study-result-v1.format-2"),
    ResultFormat(3, "0.2.0", "the friction and lift-off laws with their parameters as "
                 "attributes, and every status declared (bouncing included)",
                 "study-result-v1.format-3",
                 upgrade="study.studies.upgrade:to_format_3"),
    ResultFormat(4, "0.3.0", "irregular motions measured: statuses chaotic and "
                 "quasi_periodic, nonconvergence average_budget, the irregular observable's "
                 "variables", "study-result-v1.format-4",
                 upgrade="study.studies.upgrade:to_format_4"),
    ResultFormat(5, "0.4.0", "the start recorded (study_start, study_start_kind, a drop's "
                 "height and phase), slow sweeps (study_protocol and its along and "
                 "direction, jumped, the unswept observable's variables, a direction "
                 "dimension both ways), the section observable's variables and the basins "
                 "observable's (study_basins_* attributes, an attractor dimension)",
                 "study-result-v1",
                 upgrade="study.studies.upgrade:to_format_5"),
)

#: The format this version writes.
RESULT_FORMAT = STUDY_FORMATS[-1].number

#: Variables whose values a stale format stored in other units: format -> {name: units}.
STALE_RESULT_FORMATS: dict[int, dict[str, str]] = {1: {"mode_phase": "rad"}}

#: Where a variable lives: over (structure..., f), (structure..., f, a), the
#: frontier's (structure..., a, branch), a phase section's (structure..., f, a,
#: section_period): consecutive drive periods of the motion at each point, the
#: basins' (structure..., f, a, attractor): the attractors at each point, a fold
#: curve's (structure..., hop, a): each hop's fold at each acceleration, or its ends'
#: (structure..., hop, curve_end): towards smaller and larger accelerations, and the
#: forward hop's period-doubling curve (structure..., a).
GRIDS = {"row": ("f",), "point": ("f", "a"), "frontier": ("a", "branch"),
         "section": ("f", "a", "section_period"), "attractor": ("f", "a", "attractor"),
         "curve": ("hop", "a"), "curve_end": ("hop", "curve_end"), "doubling": ("a",)}
#: The branches slow sweeps ride (the branches observable): per branch (structure...,
#: branch), per step of each (structure..., branch, step) and per located bifurcation
#: on each (structure..., branch, bifurcation).
GRIDS.update({"branch": ("branch",), "branch_step": ("branch", "step"),
              "branch_bifurcation": ("branch", "bifurcation")})

#: Attractor slots per point of the basins observable without ``[basins]
#: max_attractors``.
DEFAULT_MAX_ATTRACTORS = 8

#: Lengths of the dimensions after a drive point's: a phase section's periods, and the
#: attractor slots (by default; a spec's ``[basins] max_attractors`` sets them: the
#: ``sizes`` of :meth:`Variable.trailing`).
GRID_SIZES = {"section_period": SECTION_PERIODS, "attractor": DEFAULT_MAX_ATTRACTORS}

#: How the velocity changes sign at a frontier point.
FRONTIER_KINDS = ("none", "crossing", "jump")


@dataclass(frozen=True)
class Variable:
    """One data variable of a result file.

    Attributes
    ----------
    name : str
        netCDF variable name.
    grid : {"row", "point", "frontier"}
        Trailing dimensions after the structure axes (see :data:`GRIDS`).
    dtype : str
        numpy dtype name on disk.
    units, long_name : str
        CF attributes.
    flags : tuple of str
        CF ``flag_meanings`` of a flag variable; its ``flag_values`` are
        ``flag_values`` (default ``0 .. len(flags) - 1``).
    flag_values : tuple of int
        Codes of the flags, in the order of ``flags``.
    comment : str
        CF ``comment`` (optional).
    invalid_where : str
        For a float variable paired with a status flag: the name of that flag
        variable; the value is NaN exactly where the status is invalid and (with
        ``zero_when_static``) 0 where it is static.
    zero_when_static : bool
        Whether the value must be 0 where the status is static.
    missing_where : tuple of str
        Statuses (flag names) with a velocity where this value is NaN too (a Floquet
        multiplier of an irregular motion, which has no orbit), beside the invalid
        ones of ``invalid_where``.
    flight_long_name, flight_comment : str
        ``long_name`` and ``comment`` in a study with flight, where they differ
        (default: the same as without).
    observable_texts : tuple of (str, str, str)
        ``(observable, long_name, comment)``: the texts of a variable that two
        observables write (never in one study), in a study that asks for that
        observable (``attractor_count``: the ``attractors`` observable's count of 12
        starts, or the ``basins`` observable's of its own starts).
    field : str
        The :class:`~study.solvers.steady.SteadyState` field whose values it holds, at
        each drive point of the study's solution ("": none); such a variable is made
        by :func:`solver_output`, which takes its dtype and units from the field's
        kernel column.
    optional : bool
        Whether a file whose observables write it may lack it: a variable added to an
        observable after files of it were written (the averaged velocity's interval),
        which those files, of any format, and their upgrades (``study upgrade``
        recomputes nothing) stay valid without; held, it is checked as any other.
        Default False.
    """

    name: str
    grid: str
    dtype: str
    units: str
    long_name: str
    flags: tuple[str, ...] = ()
    flag_values: tuple[int, ...] = ()
    comment: str = ""
    invalid_where: str = ""
    zero_when_static: bool = True
    missing_where: tuple[str, ...] = ()
    flight_long_name: str = ""
    flight_comment: str = ""
    observable_texts: tuple[tuple[str, str, str], ...] = ()
    field: str = ""
    optional: bool = False

    def __post_init__(self) -> None:
        if self.grid not in GRIDS:
            raise ValueError(f"{self.name}: grid {self.grid!r}; allowed: {', '.join(GRIDS)}")
        if self.flags and not self.flag_values:
            object.__setattr__(self, "flag_values", tuple(range(len(self.flags))))

    @property
    def is_flag(self) -> bool:
        """Whether the variable is a CF flag variable."""
        return bool(self.flags)

    def dims(self, structure_dims: tuple[str, ...]) -> tuple[str, ...]:
        """Dimensions of the variable in a study with these structure axes."""
        return (*structure_dims, *GRIDS[self.grid])

    @property
    def trailing_shape(self) -> tuple[int, ...]:
        """Lengths of its dimensions after the drive point's (``()`` but for a
        section's periods and the attractor slots, these by default): what a point's
        value holds."""
        return self.trailing()

    def trailing(self, sizes: dict[str, int] | None = None) -> tuple[int, ...]:
        """Lengths of its dimensions after the drive point's in a study whose
        dimensions have these ``sizes`` (:data:`GRID_SIZES` where not given: a spec's
        ``[basins] max_attractors`` sets the attractor slots)."""
        if self.grid not in ("section", "attractor"):
            return ()
        given = {**GRID_SIZES, **(sizes or {})}
        return tuple(given[d] for d in GRIDS[self.grid][2:])

    def texts(self, flight: bool = False,
              observables: tuple[str, ...] | list[str] = ()) -> tuple[str, str]:
        """``long_name`` and ``comment`` in a study without or with flight (asking for
        ``observables``: see :attr:`observable_texts`)."""
        for observable, long_name, comment in self.observable_texts:
            if observable in observables:
                return long_name, comment
        if not flight:
            return self.long_name, self.comment
        return (self.flight_long_name or self.long_name, self.flight_comment or self.comment)

    def attrs(self, flight: bool = False,
              observables: tuple[str, ...] | list[str] = ()) -> dict[str, Any]:
        """CF/ACDD attributes as written to the file (of a study with ``flight``, asking
        for ``observables``)."""
        long_name, comment = self.texts(flight, observables)
        attrs: dict[str, Any] = {"units": self.units, "long_name": long_name}
        if self.flags:
            attrs["flag_values"] = np.array(self.flag_values, dtype=self.dtype)
            attrs["flag_meanings"] = " ".join(self.flags)
            attrs["coverage_content_type"] = "qualityInformation"
        else:
            attrs["coverage_content_type"] = "modelResult"
        if comment:
            attrs["comment"] = comment
        return attrs


#: Starts of the attractors observable: in contact, and with flight also drops.
_CONTACT_STARTS = len(ATTRACTOR_STARTS["phases"]) * len(ATTRACTOR_STARTS["mode_factors"])
_DROP_STARTS = len(ATTRACTOR_DROPS["heights"]) * len(ATTRACTOR_DROPS["phases"])
_DROPS = (f"the base dropped from "
          f"{', '.join(f'{1e3 * h:g}' for h in ATTRACTOR_DROPS['heights'])} mm at "
          f"{len(ATTRACTOR_DROPS['phases'])} drive phases")

_STATUS_FLAGS = tuple(s.name.lower() for s in Status)
#: The statuses of motions averaged on the period map, without an orbit.
_IRREGULAR = (Status.CHAOTIC.flag, Status.QUASI_PERIODIC.flag)
_STATUS_VALUES = tuple(int(s) for s in Status)
#: The flags of ``basin_status``: the statuses, and ``no_attractor`` for a slot a point
#: does not fill (fewer attractors than slots).
BASIN_STATUS_FLAGS = ("no_attractor", *_STATUS_FLAGS)
_BASIN_STATUS_VALUES = (NO_ATTRACTOR, *_STATUS_VALUES)
#: What every per-attractor value of the basins observable says of an empty slot.
_EMPTY_SLOT = "NaN (missing) exactly where basin_status is no_attractor (a slot the point "\
    "does not fill)"
#: The basins' starts, as their long names say.
_BASIN_STARTS = ("the seeded starts of [basins] (the solver's start, then the base at rest "
                 "at drawn drive phases with the mode at drawn multiples of its steady "
                 "response, with flight every third one dropped from a drawn height)")

#: What a fold curve's value says where there is none.
_NO_FOLD = "NaN (missing) exactly where fold_status is not found"
_NO_END = ("NaN (missing) exactly where fold_end is reached (the curve ran to the end of "
           "the a axis) or not_found (nothing was followed)")

#: What a swept branch's value says where there is none.
_NO_BRANCH = "NaN (missing) exactly where branch_sweep is none"
_NO_STEP = "NaN (missing) exactly where branch_stable is no_step (past the branch's steps)"
_NO_BIFURCATION = ("NaN (missing) exactly where branch_bifurcation_kind is none (past the "
                   "branch's bifurcations)")
_NO_MULTIPLIER = ("NaN (missing) where branch_bifurcation_kind is none (past the branch's "
                  "bifurcations) and where branch_bifurcation_location is not_converged "
                  "with no converged orbit at the recorded point")
#: What the period-doubling curve's value says where there is none.
_NO_DOUBLING = "NaN (missing) exactly where doubling_status is not found"

#: What each located jump's value says where there is none.
_NO_JUMP = "NaN (missing) exactly where jump_bifurcation is no_jump or unlocated"


def solver_output(name: str, field: str, long_name: str, **declared: Any) -> Variable:
    """The result variable ``name`` holding the solution's
    :class:`~study.solvers.steady.SteadyState` field ``field`` at each drive point, with
    ``long_name`` and the other ``declared`` attributes of :class:`Variable`: its dtype
    and units are the field's, as its kernel column declares them
    (:data:`study.solvers.steady.FIELD_UNITS`), and are declared nowhere else."""
    return Variable(name, "point", FIELD_DTYPES[field], FIELD_UNITS[field], long_name,
                    field=field, **declared)


_DECLARED = (
    Variable("mode_gain", "row", "float64", DIMENSIONLESS,
             "amplification |w0^2 G| of the plate's first mode (1 at low frequency)"),
    Variable("mode_phase", "row", "float64", DEGREE,
             "phase lag of the plate's deflection behind the drive"),
    Variable("a_star_plus", "row", "float64", METRE_PER_SECOND_SQUARED,
             "drive acceleration at which forward slips start (paper eq. 5)"),
    Variable("a_star_minus", "row", "float64", METRE_PER_SECOND_SQUARED,
             "drive acceleration at which backward slips start (paper eq. 5)"),
    Variable("lift_off_acceleration", "row", "float64", METRE_PER_SECOND_SQUARED,
             "drive acceleration above which the normal force becomes negative"),
    solver_output("velocity", "velocity",
                  "mean velocity of the steady periodic orbit, positive forward",
                  comment="exactly 0 when static; NaN (missing) where status is lift_off, "
                  "not_converged or friction_paradox", invalid_where="status"),
    solver_output("status", "status", "outcome of the steady-state solver",
                  flags=_STATUS_FLAGS, flag_values=_STATUS_VALUES),
    solver_output("airborne_fraction", "airborne_fraction",
                  "fraction of the steady orbit's period the base spends off the table",
                  comment="with flight only; 0 where the orbit never leaves the table, NaN "
                  "(missing) where status is lift_off, not_converged or friction_paradox",
                  invalid_where="status"),
    solver_output("largest_hop", "largest_hop",
                  "largest height of the base above the table over the steady orbit",
                  comment="with flight only; 0 where the orbit never leaves the table, NaN "
                  "(missing) where status is lift_off, not_converged or friction_paradox",
                  invalid_where="status"),
    solver_output("impacts_per_period", "impacts_per_period",
                  "impacts of the base on the table per drive period on the steady orbit",
                  comment="with flight only; 0 where the orbit never leaves the table, NaN "
                  "(missing) where status is lift_off, not_converged or friction_paradox",
                  invalid_where="status"),
    solver_output("slips_per_period", "slips_per_period",
                  "slip events per drive period on the periodic orbit"),
    solver_output("forward_slip_fraction", "forward_fraction",
                  "fraction of the drive period spent slipping forward"),
    solver_output("backward_slip_fraction", "backward_fraction",
                  "fraction of the drive period spent slipping backward"),
    solver_output("orbit_period", "orbit_period",
                  "period of the steady orbit in drive periods (0: no orbit)"),
    solver_output("nonconvergence", "reason",
                  "why the solver found no periodic orbit",
                  flags=tuple(r.name.lower() for r in NonConvergence),
                  flag_values=tuple(int(r) for r in NonConvergence)),
    solver_output("floquet_multiplier", "floquet_multiplier",
                  "largest modulus of the Floquet multipliers of the steady orbit on the state "
                  "(plate deflection, its rate, sliding velocity)",
                  comment="below 1: the orbit attracts nearby states; where static, the mode's "
                  "free decay over one drive period; NaN (missing) where status is lift_off, "
                  "not_converged or friction_paradox, and for the irregular motions (chaotic, "
                  "quasi_periodic: no orbit)", invalid_where="status",
                  zero_when_static=False, missing_where=_IRREGULAR,
                  flight_long_name="largest modulus of the Floquet multipliers of the steady "
                  "orbit on the state (plate deflection, its rate, sliding velocity, height of "
                  "the base above the table, its rate), flights and impacts included"),
    solver_output("averaged_velocity", "averaged_velocity",
                  "time-averaged velocity of a motion followed on the period map (no stable "
                  "cycle within reach)",
                  comment="the velocity of a chaotic or quasi_periodic point; the partial mean of "
                  "a point not_converged after the most periods allowed (nonconvergence "
                  "average_budget), whose velocity is NaN; NaN (missing) elsewhere"),
    solver_output("velocity_error", "velocity_error",
                  "standard error of the mean velocity",
                  comment="0 for an orbit or a static point (exact); for an averaged motion the "
                  "batch-means standard error of averaged_velocity (95 % confidence half-width: "
                  f"{Z_95:.7g} times it, averaged_velocity_low to averaged_velocity_high); NaN "
                  "(missing) where no velocity was found"),
    Variable("averaged_velocity_low", "point", "float64", METRE_PER_SECOND,
             "lower end of the 95 % confidence interval of the averaged velocity",
             comment=f"averaged_velocity - {Z_95:.7g} velocity_error (the normal quantile: "
             "batch means of at least 32 batches); NaN (missing) where averaged_velocity "
             "is", optional=True),
    Variable("averaged_velocity_high", "point", "float64", METRE_PER_SECOND,
             "upper end of the 95 % confidence interval of the averaged velocity",
             comment=f"averaged_velocity + {Z_95:.7g} velocity_error (the normal quantile: "
             "batch means of at least 32 batches); NaN (missing) where averaged_velocity "
             "is", optional=True),
    solver_output("averaged_periods", "averaged_periods",
                  "drive periods a motion was averaged over (0: an orbit, exact)"),
    solver_output("lyapunov_exponent", "lyapunov_exponent",
                  "largest Lyapunov exponent per drive period",
                  comment="> 0: chaotic (nearby states separate by exp(exponent) per period); "
                  "for an averaged motion from a tangent vector carried through the period "
                  "map's exact Jacobians, saltations included; for an orbit log(floquet "
                  "multiplier) / orbit_period (exact, < 0 when stable); NaN (missing) where "
                  "neither applies"),
    solver_output("lyapunov_error", "lyapunov_error",
                  "standard error of the largest Lyapunov exponent",
                  comment="0 for an orbit (exact); batch means over the averaged periods"),
    Variable("section_delta", "section", "float64", METRE,
             "the mode's deflection at drive phase 0 in consecutive periods of the motion",
             comment="the phase-0 Poincare section: an orbit of period p repeats every p "
             "entries, a quasi-periodic motion fills a curve, a chaotic one a cloud; from "
             "the orbit's fixed point or the irregular motion's last averaged iterate; "
             "NaN (missing) where the point has no motion"),
    Variable("section_delta_rate", "section", "float64", METRE_PER_SECOND,
             "the rate of the mode's deflection at drive phase 0 in consecutive periods",
             comment="as section_delta"),
    Variable("section_speed", "section", "float64", METRE_PER_SECOND,
             "the base's sliding speed at drive phase 0 in consecutive periods",
             comment="as section_delta"),
    Variable("section_gap", "section", "float64", METRE,
             "the base's height above the table at drive phase 0 in consecutive periods",
             comment="0 on the table; as section_delta"),
    Variable("attractor_count", "point", "int32", DIMENSIONLESS,
             "distinct stable outcomes reached from 12 starting states (rest at four drive "
             "phases, the mode at 0, 1 and 2 times its steady response)",
             comment="stable orbits told apart by period and mean velocity, lift-off and "
             "the friction paradox one outcome each; 1 where static; > 1: multistable; "
             "0: no start converged",
             flight_long_name=f"distinct stable outcomes reached from "
             f"{_CONTACT_STARTS + _DROP_STARTS} starting states (rest at four drive "
             f"phases, the mode at 0, 1 and 2 times its steady response; {_DROPS})",
             flight_comment="stable orbits (bouncing ones included) told apart by period "
             "and mean velocity, the friction paradox one outcome; 1 where static; > 1: "
             "multistable (the motion depends on how the structure is put down); 0: no "
             "start converged",
             observable_texts=(("basins", f"attractors reached from {_BASIN_STARTS} and "
                                "from the state a slow sweep down along f settles on "
                                "([basins] sweep_steps)",
                                "exact: every attractor found, also beyond the attractor "
                                "slots (a point with more attractors than [basins] "
                                "max_attractors keeps the first ones reached in its slots, "
                                "their fractions then add up to less than 1); an outcome "
                                "outside the model (lift_off, friction_paradox, "
                                "not_converged) counts as one; > 1: multistable; 0: no "
                                "start drawn"),)),
    Variable("attractor_velocity_spread", "point", "float64", METRE_PER_SECOND,
             "largest minus smallest mean velocity among the stable orbits found",
             comment="0 with a single orbit or none"),
    Variable("attractor_starts_converged", "point", "int32", DIMENSIONLESS,
             "starting states (of 12) that reached a stable orbit, lift-off or the "
             "friction paradox",
             flight_long_name=f"starting states (of {_CONTACT_STARTS + _DROP_STARTS}) "
             "that reached a stable orbit or the friction paradox"),
    Variable("basin_status", "attractor", "int8", DIMENSIONLESS,
             "outcome (study.Status) of the motion on each attractor at the drive point, "
             "the attractors numbered in the order the starts first reach them",
             flags=BASIN_STATUS_FLAGS, flag_values=_BASIN_STATUS_VALUES,
             comment="no_attractor (-1): a slot the point does not fill; an outcome outside "
             "the model (lift_off, friction_paradox, not_converged) is one entry, so "
             "that the fractions add up to 1"),
    Variable("basin_velocity", "attractor", "float64", METRE_PER_SECOND,
             "mean velocity of the motion on each attractor, positive forward",
             comment="exactly 0 when static; time-averaged for a chaotic or "
             "quasi_periodic attractor; NaN (missing) where basin_status is lift_off, "
             "not_converged, friction_paradox or no_attractor"),
    Variable("basin_velocity_error", "attractor", "float64", METRE_PER_SECOND,
             "standard error of the mean velocity on each attractor",
             comment=f"0 for an orbit or a static point (exact); batch means for an "
             f"averaged motion; {_EMPTY_SLOT}, and where there is no velocity"),
    Variable("basin_largest_hop", "attractor", "float64", METRE,
             "largest height of the base above the table over the motion on each "
             "attractor",
             comment=f"0 where the motion never leaves the table; {_EMPTY_SLOT}, and "
             "where there is no motion"),
    Variable("basin_period", "attractor", "int32", DIMENSIONLESS,
             "period of the orbit on each attractor in drive periods",
             comment="0: static, irregular (chaotic, quasi_periodic), no orbit, or a slot "
             "the point does not fill"),
    Variable("basin_multiplier", "attractor", "float64", DIMENSIONLESS,
             "largest modulus of the Floquet multipliers of the orbit on each attractor",
             comment=f"below 1: stable; {_EMPTY_SLOT}, and where there is no orbit"),
    Variable("basin_exponent", "attractor", "float64", DIMENSIONLESS,
             "largest Lyapunov exponent per drive period of the motion on each attractor",
             comment=f"> 0: chaotic; for an orbit log(multiplier) / period; {_EMPTY_SLOT}, "
             "and where neither applies"),
    Variable("basin_fraction", "attractor", "float64", DIMENSIONLESS,
             "basin fraction of each attractor: the share of the starts drawn at the "
             "point that reach it",
             comment="the chance that the structure put down by a start drawn as the "
             "draws are (study_basins_reach) performs this motion, not a share of the "
             "state space; 0 for an attractor only the slow sweep's seeded state reaches; "
             "the fractions of a point add up to 1 (less where attractor_count exceeds "
             f"the slots); {_EMPTY_SLOT}"),
    Variable("basin_fraction_low", "attractor", "float64", DIMENSIONLESS,
             "lower bound of the 95 % Wilson score interval of the basin fraction over "
             "the drawn starts",
             comment="binomial, of starts_drawn trials: an interval over the sampled starts "
             "(study_basins_reach), not over the state space; a motion no draw reaches "
             f"is outside it; {_EMPTY_SLOT}"),
    Variable("basin_fraction_high", "attractor", "float64", DIMENSIONLESS,
             "upper bound of the 95 % Wilson score interval of the basin fraction over "
             "the drawn starts",
             comment="binomial, of starts_drawn trials: an interval over the sampled starts "
             "(study_basins_reach), not over the state space; a motion no draw reaches "
             f"is outside it; {_EMPTY_SLOT}"),
    Variable("default_attractor", "point", "int32", DIMENSIONLESS,
             "the attractor the solver's start ([solver] start, the release by default) "
             "reaches: its index along the attractor dimension",
             comment="the motion velocity and status report; -1: the start was not drawn "
             "(without flight, a state on the table the model cannot hold there)"),
    Variable("starts_drawn", "point", "int32", DIMENSIONLESS,
             f"starts followed at the drive point, of {_BASIN_STARTS}",
             comment="without flight a start on the table that the model cannot hold "
             "there (a negative normal force) is not drawn; the trials of the fractions' "
             "intervals"),
    Variable("velocity_one_way", "point", "float64", METRE_PER_SECOND,
             "mean steady velocity of the paper's one-way model at the same point "
             "(exact solver), for comparison with the two-way velocity",
             comment="exactly 0 when static; NaN (missing) where status_one_way is "
             "lift_off or not_converged", invalid_where="status_one_way"),
    Variable("status_one_way", "point", "int8", DIMENSIONLESS,
             "outcome of the exact solver for the paper's one-way model",
             flags=_STATUS_FLAGS, flag_values=_STATUS_VALUES),
    Variable("velocity_without_flight", "point", "float64", METRE_PER_SECOND,
             "mean steady velocity at the same point by the same method without flight "
             "(the run stops at lift-off), for comparison with the velocity with flight",
             comment="exactly 0 when static; NaN (missing) where status_without_flight is "
             "lift_off, not_converged or friction_paradox",
             invalid_where="status_without_flight"),
    Variable("status_without_flight", "point", "int8", DIMENSIONLESS,
             "outcome of the same method without flight (lift_off where the base would "
             "leave the table)", flags=_STATUS_FLAGS, flag_values=_STATUS_VALUES),
    Variable("jumped", "point", "int8", DIMENSIONLESS,
             "whether the slowly swept motion jumped at this point: the motion the sweep "
             "settles on is not the continuation of the previous point's along its branch "
             "([sweep] protocol)",
             flags=("followed", "jumped"), flag_values=(0, 1),
             comment="the previous point's orbit followed to this drive by pseudo-arclength "
             "continuation folded back or ended on the way, or the carried state settled "
             "on another motion, whatever the velocity does; the doubled orbit of a "
             "period doubling (and a period halving) is followed; the first point of a "
             "run, started by [solver] start, is followed"),
    Variable("jump_bifurcation", "point", "int8", DIMENSIONLESS,
             "the bifurcation at which the motion the slow sweep rode ends before this "
             "point, where the sweep jumped ([sweep] protocol)",
             flags=JUMP_FLAGS, flag_values=JUMP_FLAG_VALUES,
             comment="the previous point's orbit followed along its branch towards this "
             "drive by pseudo-arclength continuation on the exact period map: the first "
             "located bifurcation after which it is no stable orbit going on (a fold, a "
             "lift-off, a non-smooth end; a period doubling, torus, branch point or "
             "grazing after which it is unstable); no_jump where jumped is followed; "
             "unlocated where the sweep jumped but the branch goes on stable to this "
             "drive (the carried state left the orbit's basin) or the motion before has "
             "no orbit (an irregular one)"),
    Variable("jump_f", "point", "float64", HERTZ,
             "drive frequency of the bifurcation where the slow sweep's motion ends",
             comment=f"located on the branch to 1e-10 of the drive; {_NO_JUMP}"),
    Variable("jump_a", "point", "float64", METRE_PER_SECOND_SQUARED,
             "drive acceleration of the bifurcation where the slow sweep's motion ends",
             comment=f"located on the branch to 1e-10 of the drive; {_NO_JUMP}"),
    Variable("jump_velocity", "point", "float64", METRE_PER_SECOND,
             "mean velocity of the orbit the slow sweep rode at the bifurcation where it "
             "ends, positive forward", comment=_NO_JUMP),
    Variable("jump_multiplier_modulus", "point", "float64", DIMENSIONLESS,
             "modulus of the Floquet multiplier that crosses at the bifurcation where the "
             "slow sweep's motion ends",
             comment=f"1 at a fold, a period doubling or a torus; the largest modulus "
             f"where the bifurcation is located by bisection; {_NO_JUMP}"),
    Variable("jump_multiplier_angle", "point", "float64", DEGREE,
             "argument of that Floquet multiplier",
             comment=f"0 at a fold (the multiplier +1), 180 at a period doubling (-1); "
             f"{_NO_JUMP}"),
    Variable("velocity_unswept", "point", "float64", METRE_PER_SECOND,
             "mean steady velocity each point reaches from the declared start alone, "
             "beside a slow sweep ([sweep] protocol): the same study's velocity without "
             "its protocol",
             comment="the same whatever the sweep's direction (no direction dimension); "
             "exactly 0 when static; NaN (missing) where status_unswept is lift_off, "
             "not_converged or friction_paradox", invalid_where="status_unswept"),
    Variable("status_unswept", "point", "int8", DIMENSIONLESS,
             "outcome of the solver from the declared start alone, beside a slow sweep",
             flags=_STATUS_FLAGS, flag_values=_STATUS_VALUES),
    Variable("fold_f", "curve", "float64", HERTZ,
             "drive frequency of the fold of each hop's branch at the drive acceleration: "
             "where a slow sweep along f riding the hop jumps (forward hop: swept up; "
             "backward hop: swept down)",
             comment="each point located on the exact period map to 1e-10 of the drive, "
             "the curve continued from a fold where a slow sweep of the study's f axis "
             "jumped from the hop to the other one, or where none does, from the fold of "
             "the hop's branch followed on past the sweeps (not interpolated; it may lie "
             f"outside the f axis); {_NO_FOLD}"),
    Variable("fold_velocity", "curve", "float64", METRE_PER_SECOND,
             "mean velocity of the hop's orbit at its fold, positive forward",
             comment=_NO_FOLD),
    Variable("fold_status", "curve", "int8", DIMENSIONLESS,
             "whether the hop's fold was located at the drive acceleration, and why not",
             flags=FOLD_STATUS_FLAGS,
             comment="found: fold_f holds it; no_fold: past the curve's cusp (fold_end "
             "vanished), where the hop's branch has no fold; beyond_end: past where the "
             "curve ended at another bifurcation or was lost (fold_end ended or lost), "
             "not followed there; not_found: no slow sweep along the study's f axis "
             "jumped from this hop to the other at a fold at any acceleration and the "
             "hop's branch followed past the sweeps met no fold either, so no curve was "
             "followed"),
    Variable("fold_end", "curve_end", "int8", DIMENSIONLESS,
             "how each hop's fold curve ends towards smaller (below) and larger (above) "
             "drive accelerations",
             flags=FOLD_END_FLAGS, flag_values=FOLD_END_VALUES,
             comment="reached: located up to the a axis's end; vanished: the fold is no "
             "longer met (a cusp, where the coexistence of the two hops is born or dies); "
             "ended: the hop's orbit ceases to exist before the fold (another "
             "bifurcation); lost: the orbit could not be carried to the next acceleration; "
             "not_found: no curve (fold_status not_found)"),
    Variable("fold_end_last", "curve_end", "float64", METRE_PER_SECOND_SQUARED,
             "drive acceleration of the last point where the fold curve is met before "
             "its end: one side of the end's bracket",
             comment=f"bracketed by halving the step to 1e-6 of the acceleration; {_NO_END}"),
    Variable("fold_end_past", "curve_end", "float64", METRE_PER_SECOND_SQUARED,
             "drive acceleration past the fold curve's end, where the fold is not met: "
             "the other side of the end's bracket", comment=_NO_END),
    Variable("doubling_f", "doubling", "float64", HERTZ,
             "drive frequency of the forward hop's period doubling at the drive "
             "acceleration: below its fold in f, where the forward hop of period 1 turns "
             "into one of twice its period (the other edge of where it exists stably)",
             comment="each point located on the exact period map to 1e-10 of the drive "
             "(the multiplier -1), on the forward hop's branch followed down in f from "
             "where a slow sweep up left it at its fold, the curve continued over the a "
             f"axis (not interpolated); {_NO_DOUBLING}", optional=True),
    Variable("doubling_velocity", "doubling", "float64", METRE_PER_SECOND,
             "mean velocity of the forward hop's orbit at its period doubling, positive "
             "forward", comment=_NO_DOUBLING, optional=True),
    Variable("doubling_status", "doubling", "int8", DIMENSIONLESS,
             "whether the forward hop's period doubling was located at the drive "
             "acceleration, and why not", flags=DOUBLING_STATUS_FLAGS,
             comment="found: doubling_f holds it; no_doubling: past where the curve "
             "vanished (the hop's branch meets no period doubling near the last one, as "
             "where it meets a grazing); beyond_end: past where the curve ended at "
             "another bifurcation or was lost, not followed there; not_found: the "
             "forward hop's fold was not found (fold_status), or its branch followed "
             "down in f from there meets no period doubling, so no curve was followed",
             optional=True),
    Variable("frontier_frequency", "frontier", "float64", HERTZ,
             "drive frequency f*(a) where the mean velocity changes sign",
             comment="NaN-padded where an acceleration has fewer branches"),
    Variable("frontier_kind", "frontier", "int8", DIMENSIONLESS,
             "how the velocity changes sign at the frontier", flags=FRONTIER_KINDS),
    Variable("frontier_direction", "frontier", "int8", DIMENSIONLESS,
             "sign of the velocity just above the frontier frequency (0: none)"),
    Variable("frontier_bracket", "frontier", "float64", HERTZ,
             "width of the final bisection bracket of the frontier frequency"),
    Variable("branch_sweep", "branch", "int8", DIMENSIONLESS,
             "the slow sweep whose motion the branch is: swept up or down",
             flags=("none", "up", "down"), flag_values=(-1, 0, 1),
             comment="none: a branch slot the structure does not fill"),
    Variable("branch_start_f", "branch", "float64", HERTZ,
             "drive frequency where the sweep settled on the branch's motion (the first "
             "point of the piece of its run it rode)", comment=_NO_BRANCH),
    Variable("branch_start_a", "branch", "float64", METRE_PER_SECOND_SQUARED,
             "drive acceleration where the sweep settled on the branch's motion",
             comment=_NO_BRANCH),
    Variable("branch_end", "branch", "int8", DIMENSIONLESS,
             "how the branch ends in the sweep's direction",
             flags=("none", *(end.name for end in ENDS)),
             flag_values=(0, *(end.code for end in ENDS)),
             comment="reached: the sweep rode it to the end of the swept axis, or it runs "
             "there; turned_back: it folds and runs back on its unstable part past the "
             "last point the sweep rode; ended: its orbit ceases to exist (a non-smooth "
             "end); not_followed: the motion ridden has no orbit to follow (an irregular "
             "one); none: a slot the structure does not fill"),
    Variable("branch_steps", "branch", "int32", DIMENSIONLESS,
             "steps of the branch (the step slots it fills)"),
    Variable("branch_orbit_period", "branch", "int32", DIMENSIONLESS,
             "period of the branch's orbit in drive periods (0: no orbit)"),
    Variable("branch_bifurcations", "branch", "int32", DIMENSIONLESS,
             "bifurcations located on the branch (the bifurcation slots it fills, at most "
             "their number)"),
    Variable("branch_f", "branch_step", "float64", HERTZ,
             "drive frequency of each step of the branch, in the sweep's direction",
             comment=_NO_STEP),
    Variable("branch_a", "branch_step", "float64", METRE_PER_SECOND_SQUARED,
             "drive acceleration of each step of the branch", comment=_NO_STEP),
    Variable("branch_velocity", "branch_step", "float64", METRE_PER_SECOND,
             "mean velocity of the branch's orbit at each step, positive forward",
             comment=_NO_STEP),
    Variable("branch_stable", "branch_step", "int8", DIMENSIONLESS,
             "whether the branch's orbit attracts its neighbours at each step (every "
             "Floquet multiplier inside the unit circle)",
             flags=("no_step", "unstable", "stable"), flag_values=(-1, 0, 1),
             comment="no_step: a slot past the branch's steps"),
    Variable("branch_largest_multiplier", "branch_step", "float64", DIMENSIONLESS,
             "largest modulus of the Floquet multipliers of the branch's orbit at each "
             "step", comment=_NO_STEP),
    Variable("branch_largest_hop", "branch_step", "float64", METRE,
             "largest gap between the base and the table over the branch's orbit at each "
             "step (0 without flight)", comment=_NO_STEP),
    Variable("branch_bifurcation_kind", "branch_bifurcation", "int8", DIMENSIONLESS,
             "kind of each bifurcation located on the branch, in the branch's order",
             flags=("none", *(kind.name for kind in KINDS)),
             flag_values=(0, *(kind.code for kind in KINDS)),
             comment="none: a slot past the branch's bifurcations; each located by a test "
             "function that changes sign between two steps, to 1e-10 of the drive "
             "(docs/theory/branches.md)"),
    Variable("branch_bifurcation_f", "branch_bifurcation", "float64", HERTZ,
             "drive frequency of the bifurcation", comment=_NO_BIFURCATION),
    Variable("branch_bifurcation_a", "branch_bifurcation", "float64",
             METRE_PER_SECOND_SQUARED, "drive acceleration of the bifurcation",
             comment=_NO_BIFURCATION),
    Variable("branch_bifurcation_velocity", "branch_bifurcation", "float64",
             METRE_PER_SECOND, "mean velocity of the branch's orbit at the bifurcation",
             comment=_NO_BIFURCATION),
    Variable("branch_bifurcation_multiplier_modulus", "branch_bifurcation", "float64",
             DIMENSIONLESS, "modulus of the Floquet multiplier that crosses there",
             comment=_NO_MULTIPLIER),
    Variable("branch_bifurcation_multiplier_angle", "branch_bifurcation", "float64",
             DEGREE, "argument of the Floquet multiplier that crosses there (0: real "
             "positive, 180: real negative)", comment=_NO_MULTIPLIER),
    Variable("branch_bifurcation_step", "branch_bifurcation", "int32", DIMENSIONLESS,
             "the step of the branch before the bifurcation (it lies between this step "
             "and the next)",
             comment="-1: before the branch's first step (where the part traced back "
             "from the last point ridden ended), or a slot past its bifurcations"),
    Variable("branch_bifurcation_location", "branch_bifurcation", "int8", DIMENSIONLESS,
             "how the bifurcation was placed: located to 1e-10 of the drive, or not",
             flags=LOCATION_FLAGS,
             comment="none: a slot past the branch's bifurcations; located: its test "
             "function solved (or its event sequence bisected) to 1e-10 of the drive; "
             "not_converged: the location stopped short (the corrector failed, or the "
             "test function did not come within 1e-9, as at the birth of a doubled "
             "orbit's branch): it lies within the step after branch_bifurcation_step, "
             "its drive and velocity those of the best point found",
             # Files of the branches observable written before the flag lack it.
             optional=True),
)

#: name -> Variable, in the order variables appear in a file.
VARIABLES: dict[str, Variable] = {v.name: v for v in _DECLARED}

"""A solver output is declared once, in its kernel's column table: the result variables
that hold a SteadyState field take their units and dtype from it, and the observables
read them from the solution by that field."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from study.kernels import one_way
from study.kernels.two_way import points
from study.solvers.steady import (
    FIELD_DTYPES,
    FIELD_UNITS,
    STEADY_FIELDS,
    SteadyState,
    declared_units,
)
from study.studies.observables import OBSERVABLES, PointWork, solution_values
from study.studies.variables import VARIABLES, solver_output

TABLES = (one_way.OUTPUT_COLUMNS, points.OUTPUT_COLUMNS)
#: The exact solver's kernel for each coupling: whose columns a study's solution has.
KERNEL_COLUMNS = {"one-way": {name for name, _, _ in one_way.OUTPUT_COLUMNS},
                  "two-way": {name for name, _, _ in points.OUTPUT_COLUMNS}}


def column_units(column: str) -> set[str]:
    return {units for table in TABLES for name, units, _ in table if name == column}


@pytest.mark.parametrize("name", [n for n, v in VARIABLES.items() if v.field])
def test_a_solver_output_has_its_columns_units_and_dtype(name: str) -> None:
    variable = VARIABLES[name]
    column, dtype = STEADY_FIELDS[variable.field]
    assert column_units(column) == {variable.units}
    assert variable.dtype == np.dtype(dtype or np.float64).name
    assert variable.grid == "point"


def test_the_solver_outputs_are_the_fields_the_observables_write() -> None:
    """Every SteadyState field a study's own velocity, diagnostics, Floquet or irregular
    observable writes is declared through its field, not copied by hand."""
    held = {v.field for v in VARIABLES.values() if v.field}
    written = {name for o in OBSERVABLES.values()
               if o.name in ("velocity", "diagnostics", "floquet", "irregular")
               for name in (*o.variables, *o.flight_variables)}
    by_field = {n for n in written if VARIABLES[n].field}
    assert held == set(STEADY_FIELDS)
    assert by_field == {n for n, v in VARIABLES.items() if v.field}


def test_kernels_that_disagree_on_a_columns_units_are_refused() -> None:
    fields = {"largest_hop": ("hop", None)}
    agreeing = ((("hop", "m", "largest gap"),), (("hop", "m", "largest gap"),))
    assert declared_units(fields, agreeing) == {"largest_hop": "m"}
    disagreeing = ((("hop", "m", "largest gap"),), (("hop", "mm", "largest gap"),))
    with pytest.raises(ValueError, match=r"'largest_hop'.*'hop'.*\['m', 'mm'\]"):
        declared_units(fields, disagreeing)
    with pytest.raises(ValueError, match=r"'largest_hop'.*\[\]"):
        declared_units(fields, ((("velocity", "m s-1", "mean"),),))


def test_a_new_output_needs_only_its_column_field_and_variable() -> None:
    """A variable made from a field has the field's units and dtype without stating
    them, and an observable's values are read from the solution by each variable's
    field (a renamed variable, forward_slip_fraction, and nonconvergence <- reason)."""
    variable = solver_output("slip_count", "slips_per_period", "slips per period")
    assert (variable.units, variable.dtype, variable.field) == (
        FIELD_UNITS["slips_per_period"], FIELD_DTYPES["slips_per_period"], "slips_per_period")
    largest_hop = solver_output("hop_height", "largest_hop", "largest hop")
    assert largest_hop.units == "m"

    solution = SteadyState(**{f.name: np.full(2, float(i))
                              for i, f in enumerate(dataclasses.fields(SteadyState))})
    work = PointWork(None, np.zeros(2), np.zeros(2), None)  # type: ignore[arg-type]
    work.__dict__["solution"] = solution  # the solve a task would have done
    read = solution_values(work, ("velocity", "forward_slip_fraction", "nonconvergence"))
    assert list(read) == ["velocity", "forward_slip_fraction", "nonconvergence"]
    assert read["velocity"] is solution.velocity
    assert read["forward_slip_fraction"] is solution.forward_fraction
    assert read["nonconvergence"] is solution.reason


@pytest.mark.parametrize("observable", sorted(OBSERVABLES))
def test_every_kernel_an_observable_runs_on_computes_its_solver_outputs(
        observable: str) -> None:
    """An output that one kernel computes and another does not must be in both tables
    or its observable restricted to the couplings that compute it (flight is two-way
    only): else a study writes a variable its solver left unset."""
    declared = OBSERVABLES[observable]
    couplings = declared.couplings or tuple(KERNEL_COLUMNS)
    for names, flying in ((declared.variables, False), (declared.flight_variables, True)):
        for coupling in ("two-way",) if flying else couplings:
            for name in names:
                field = VARIABLES[name].field
                if field:
                    assert STEADY_FIELDS[field][0] in KERNEL_COLUMNS[coupling], (
                        f"{observable}: {name} ({field}) is not computed by the "
                        f"{coupling} kernel")

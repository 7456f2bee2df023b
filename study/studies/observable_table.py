"""The docs' table of observables (docs/user-guide/specs.md), written from their
declarations in :mod:`study.studies.observables` (``make schemas`` runs it through
docs/generate_tables.py)."""

from __future__ import annotations

from study.studies.observables import OBSERVABLES
from study.studies.variables import GRIDS, VARIABLES

__all__ = ["markdown_table"]


def markdown_table() -> str:
    """The docs' table of observables (docs/user-guide/specs.md), from their
    declarations: name, what it computes, its grid, what it needs of ``[solver]`` and
    the variables it writes (with flight also its flight variables)."""
    grids = {"row": "per `f` (closed form)", "point": "per `(f, a)` (solver)",
             "frontier": "per `a`, `branch` (bisection)",
             "curves": "per `(hop, a)`, `(hop, curve_end)` and `a` (continuation)",
             "branches": "per `branch`, `branch`, `step` and `branch`, `bifurcation` "
             "(continuation)"}
    lines = ["| observable | what it computes | grid | needs | variables |",
             "|---|---|---|---|---|"]
    for name, o in OBSERVABLES.items():
        needs = (f"`[sweep] protocol`{f' and `{o.needs()}`' if o.needs() else ''}: "
                 f"{o.why}" if o.unswept or o.swept
                 else f"`{o.needs()}`: {o.why}" if o.needs_anything
                 else "any method and coupling" if o.grid != "row" else "no solver")
        variables = ", ".join(f"`{v}`" for v in o.variables)
        if o.flight_variables:
            variables += "; with flight also " + ", ".join(f"`{v}`"
                                                           for v in o.flight_variables)
        if o.protocol_variables:
            variables += "; with `[sweep] protocol` also " + ", ".join(
                f"`{v}`" for v in o.protocol_variables)
        if o.requires:
            variables += " (with " + ", ".join(f"`{r}`" for r in o.requires) + ")"
        # The dimensions some of its variables have beyond the drive point's (a phase
        # section's periods, the basins' attractor slots).
        beyond = sorted({d for v in (*o.variables, *o.flight_variables)
                         for d in GRIDS[VARIABLES[v].grid][2:]})
        grid = grids[o.grid] + "".join(f", and `{d}`" for d in beyond)
        lines.append(f"| `{name}` | {_cell(o.summary)} | {grid} | {_cell(needs)} "
                     f"| {variables} |")
    return "\n".join(lines) + "\n"


def _cell(text: str) -> str:
    """``text`` safe in a markdown table cell."""
    return text.replace("|", "\\|").replace("*", "\\*")

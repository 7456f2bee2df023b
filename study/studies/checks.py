"""The study kind's own checks of its result files (:func:`study_problems`, registered
as its validator in :mod:`study.studies.kind`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from study.engine.kinds import ResultFormat
from study.engine.validation.checks import (
    Checker,
    checksum_problems,
    fingerprint_problems,
    identity_problems,
    is_number,
    not_required_checksum,
    parse_embedded,
    provenance_problems,
    provenance_spec_problems,
    same_number,
    same_text,
    size_problems,
)
from study.engine.validation.formats import schema_path
from study.engine.validation.header import (
    RESULT_SCHEMA,
    file_header,
    schema_problems,
    short,
)
from study.engine.validation.reading import StoredFile, read_slab, slabs
from study.model.codes import CURVE_ENDED, CURVE_LOST, CURVE_VANISHED
from study.model.contact import DEFAULT_LIFT_OFF
from study.model.status import INVALID_STATUSES, Status
from study.solvers.basins import NO_ATTRACTOR
from study.solvers.fold_curves import FOUND
from study.studies.layout import method_attributes, variable_dims
from study.studies.observables import variables_of
from study.studies.spec import StudySpec, parse_spec
from study.studies.variables import RESULT_FORMAT, STALE_RESULT_FORMATS, VARIABLES

__all__ = ["declared_flag_problems", "method_problems", "study_problems"]


def _stale_format_problems(meta: StoredFile, written: ResultFormat) -> list[str]:
    """A study file of a format before 0.1.0 that holds a variable whose units changed
    since: its numbers would be misread, so it is refused whole as stale."""
    changed = STALE_RESULT_FORMATS.get(written.number, {})
    held = [f"{name} in {units}" for name, units in changed.items() if name in meta.variables]
    if not held:
        return []  # nothing in it changed units
    now = ", ".join(f"{name} in {VARIABLES[name].units}" for name in changed
                    if name in meta.variables)
    return [f"study result format {written.number} ({', '.join(held)}) is stale: "
            f"this study reads format {RESULT_FORMAT} ({now}); rerun its spec"]


#: Method attributes a file may lack and what their absence means: files written before
#: every result recorded its lift-off law wrote ``study_lift_off`` only with flight, and
#: files written before starts were named have no ``study_start``: their points started
#: by the release.
_ABSENT_MEANS = {"study_lift_off": DEFAULT_LIFT_OFF, "study_start": "release",
                 "study_start_kind": "release"}


def method_problems(attrs: Mapping[str, Any], spec: StudySpec) -> list[str]:
    """The method attributes a file holds that differ from its embedded spec's.

    Every key of :func:`study.studies.layout.method_attributes` that the file has is
    compared with the spec's value (texts as texts, numbers exactly). A key the file
    lacks is no problem here (files of older versions do not have them all; the result
    schema decides which are required), except ``study_lift_off``, whose absence has
    always meant the law ``stop``, and ``study_start`` and ``study_start_kind``, whose
    absence means the release. ``source``, the prose that repeats the other
    attributes, is not compared: its wording may change between versions.

    Parameters
    ----------
    attrs : mapping
        The file's global attributes.
    spec : StudySpec
        The spec embedded in the file.

    Returns
    -------
    list of str
        One message per attribute that differs, naming it and the spec's value.
    """
    problems = []
    for key, expected in method_attributes(spec).items():
        if key == "source":
            continue
        if key not in attrs and key not in _ABSENT_MEANS:
            continue
        value = attrs.get(key, _ABSENT_MEANS.get(key))
        same = (same_text(value, expected) if isinstance(expected, str)
                else same_number(value, expected))
        if not same:
            problems.append(f"{key} differs from the embedded spec ({expected!r})")
    return problems


def study_problems(nc: Any, meta: StoredFile, source: str,
                   written: ResultFormat) -> list[str]:
    attrs = meta.attrs
    stale = _stale_format_problems(meta, written)
    if stale:
        return stale
    # The header by the schema of the format the file was written in.
    problems = [p for p in schema_problems(schema_path(written), file_header(meta))
                if not_required_checksum(p)]
    problems += fingerprint_problems(attrs)
    problems += provenance_problems(attrs, RESULT_SCHEMA)
    too_large = size_problems(meta)
    if too_large:  # reading the values would be pointless, and could take hours
        return problems + too_large
    check = Checker(nc, meta)
    spec, spec_problems = parse_embedded(attrs, source, parse_spec)
    problems += spec_problems
    if spec is not None:
        problems += identity_problems(attrs, spec)
        problems += provenance_spec_problems(attrs, spec, "study")
        problems += method_problems(attrs, spec)
        problems += _study_content_problems(check, meta, spec,
                                            current=written.number == RESULT_FORMAT)
    problems += checksum_problems(nc, meta)
    return problems


def declared_flag_problems(name: str, var: Any, declared: Any, exact: bool) -> list[str]:
    """A flag variable's ``flag_values`` and ``flag_meanings`` against its declaration.

    A file of the current format declares exactly today's flags. A file of an older
    format may declare fewer (statuses are only ever added, never renumbered or given
    another meaning): each of its codes must carry today's meaning of that code.
    """
    flag_values = np.atleast_1d(np.asarray(var.attrs.get("flag_values", [])))
    meanings = var.attrs.get("flag_meanings")
    if exact:
        problems = []
        if (flag_values.dtype != np.dtype(declared.dtype)
                or flag_values.tolist() != list(declared.flag_values)):
            problems.append(f"{name}: flag_values {flag_values.tolist()}; declared "
                            f"{list(declared.flag_values)} ({declared.dtype})")
        if not same_text(meanings, " ".join(declared.flags)):
            problems.append(f"{name}: flag_meanings differ from the declared "
                            f"{' '.join(declared.flags)!r}")
        return problems
    today = dict(zip(declared.flag_values, declared.flags, strict=True))
    words = meanings.split() if isinstance(meanings, str) else []
    if (flag_values.dtype != np.dtype(declared.dtype) or flag_values.ndim != 1
            or len(words) != flag_values.size or not flag_values.size):
        return [f"{name}: flag_values {flag_values.tolist()} and flag_meanings "
                f"{meanings!r} must name each code once ({declared.dtype})"]
    other = [f"{code} {word}" for code, word in zip(flag_values.tolist(), words, strict=True)
             if today.get(code) != word]
    if other or len(set(flag_values.tolist())) != flag_values.size:
        return [f"{name}: flags {', '.join(other) or 'repeated'} differ from the declared "
                f"codes ({', '.join(f'{c} {w}' for c, w in today.items())})"]
    return []


def _study_content_problems(check: Checker, meta: StoredFile, spec: Any,
                            current: bool = True) -> list[str]:
    """Coordinates and variables against the spec and the declarations (a file of an
    older format may declare fewer flags, see :func:`declared_flag_problems`; any file
    may lack an optional variable, :attr:`study.studies.variables.Variable.optional`)."""
    problems = []
    variables = meta.variables
    for axis in spec.axes:
        var = variables.get(axis.name)
        if var is None:
            problems.append(f"coordinate {axis.name!r} of the embedded spec is missing")
        elif var.dims != (axis.name,) or var.type_name != "float64":
            problems.append(f"coordinate {axis.name!r} must be float64 over ({axis.name},)")
        elif not same_text(var.attrs.get("units"), axis.units):
            problems.append(f"coordinate {axis.name!r}: units {var.attrs.get('units')!r}, "
                            f"declared {axis.units!r}")
        elif not check.equals(axis.name, axis.values):
            problems.append(f"coordinate {axis.name!r} differs from the embedded spec")
    structure = spec.canonical.get("structure") if isinstance(spec.canonical, dict) else None
    for name, value in (structure.items() if isinstance(structure, dict) else ()):
        var = variables.get(name)
        if not is_number(value):
            continue  # not a fixed value in the spec layer's form
        if var is None or var.shape != () or var.type_name != "float64":
            problems.append(f"fixed parameter {name!r} must be a float64 scalar")
        elif not check.equals(name, np.array([value], dtype=np.float64)):
            problems.append(f"{name} differs from the embedded spec's {value!r}")
    structure_dims = tuple(axis.name for axis in spec.axes if axis.name not in ("f", "a"))
    wanted = [v for v in variables_of(spec.observables, spec.flight, spec.protocol is not None)
              if not v.optional or v.name in variables]
    wanted_names = {v.name for v in wanted}
    for name in variables:
        if name in VARIABLES and name not in wanted_names:
            problems.append(f"variable {name!r} is not among the spec's observables")
    good: set[str] = set()
    for declared in wanted:
        name = declared.name
        var = variables.get(name)
        if var is None:
            problems.append(f"variable {name!r} asked for by the spec is missing")
            continue
        before = len(problems)
        dims = variable_dims(spec, name, structure_dims)
        if var.dims != dims:
            problems.append(f"{name} has dimensions ({', '.join(var.dims)}); declared "
                            f"({', '.join(dims)})")
        if var.type_name != declared.dtype:
            problems.append(f"{name} is {var.type_name}; declared {declared.dtype}")
        expected = {"units": declared.units,
                    "long_name": declared.texts(spec.flight, spec.observables)[0]}
        for key, value in expected.items():
            if not same_text(var.attrs.get(key), value):
                problems.append(f"{name}: {key} {short(repr(var.attrs.get(key)), 80)}; "
                                f"declared {value!r}")
        if declared.is_flag:
            problems += declared_flag_problems(name, var, declared, exact=current)
        elif "flag_values" in var.attrs or "flag_meanings" in var.attrs:
            problems.append(f"{name} is not a flag variable but has flag attributes")
        if len(problems) == before:
            good.add(name)
    for declared in wanted:
        if declared.name not in good:
            continue  # its values cannot be checked against a wrong layout
        if declared.is_flag:
            # Within the flags the file declares (a subset of today's, for older files).
            written_codes = np.atleast_1d(np.asarray(
                meta.variables[declared.name].attrs["flag_values"]))
            problems += check.flags_in_range(declared.name, written_codes)
        if declared.invalid_where and declared.invalid_where in good:
            problems += check.invalid_where(declared.name, declared.invalid_where,
                                            declared.zero_when_static,
                                            declared.missing_where)
    if getattr(spec, "basins", None) is not None:
        problems += _basins_problems(check, meta, spec, good)
    if {"averaged_velocity", *_VELOCITY_INTERVAL} <= good:
        problems += _interval_problems(check)
    problems += _fold_problems(check, good)
    return problems


#: The fold curves' values and the flag that says where each is NaN, with the codes
#: it holds where they are not (found, and a curve's end that has a bracket).
_FOLD_NAN = {"fold_f": ("fold_status", (FOUND,)),
             "fold_velocity": ("fold_status", (FOUND,)),
             "fold_end_last": ("fold_end", (CURVE_VANISHED, CURVE_ENDED, CURVE_LOST)),
             "fold_end_past": ("fold_end", (CURVE_VANISHED, CURVE_ENDED, CURVE_LOST))}


def _fold_problems(check: Checker, good: set[str]) -> list[str]:
    """The fold curves: each value NaN exactly where its flag says there is none
    (fold_status not found; fold_end reached or not_found)."""
    problems = []
    for name, (flag, held) in _FOLD_NAN.items():
        if name not in good or flag not in good:
            continue
        wrong = sum(int(np.count_nonzero(np.isnan(values) == np.isin(codes, held)))
                    for values, codes in check.slabs(name, flag))
        if wrong:
            named = dict(zip(VARIABLES[flag].flag_values, VARIABLES[flag].flags, strict=True))
            problems.append(f"{name} is NaN exactly where {flag} is not "
                            f"{' or '.join(named[c] for c in held)} ({wrong} values "
                            "disagree)")
    return problems


#: The ends of the averaged velocity's 95 % interval (the irregular observable).
_VELOCITY_INTERVAL = ("averaged_velocity_low", "averaged_velocity_high")


def _interval_problems(check: Checker) -> list[str]:
    """The averaged velocity's interval: NaN exactly where the velocity is, and holding
    it elsewhere."""
    outside = 0
    for mean, low, high in check.slabs("averaged_velocity", *_VELOCITY_INTERVAL):
        missing = np.isnan(mean)
        outside += int(np.count_nonzero(
            (np.isnan(low) != missing) | (np.isnan(high) != missing)
            | (~missing & ~((low <= mean) & (mean <= high)))))
    if not outside:
        return []
    return [f"averaged_velocity_low and averaged_velocity_high are NaN exactly where "
            f"averaged_velocity is, and hold it elsewhere ({outside} points disagree)"]


#: The basins observable's variables: per drive point and attractor, and per point.
_PER_ATTRACTOR = ("basin_status", "basin_velocity", "basin_velocity_error",
                  "basin_largest_hop", "basin_period", "basin_multiplier", "basin_exponent",
                  "basin_fraction", "basin_fraction_low", "basin_fraction_high")
_PER_POINT = ("attractor_count", "default_attractor", "starts_drawn")
#: How far the fractions of a point may add up from 1 (each is a count over the starts
#: drawn, added in double precision).
_FRACTION_SUM = 1e-12


def _basins_problems(check: Checker, meta: StoredFile, spec: Any, good: set[str]
                     ) -> list[str]:
    """The basins observable's layout and values against its ``[basins]``: the file
    records its settings, the attractor dimension has ``max_attractors`` slots numbered
    0..n-1, and at each point the slots filled are the first ``min(attractor_count,
    max_attractors)`` (basin_status no_attractor exactly in the others, where every
    float per attractor is NaN), the fractions are in [0, 1] inside their interval and
    add up to 1 where starts were drawn and every attractor has a slot (to at most 1
    where some has none), no attractor where no start was drawn, at most ``starts``
    starts, the default attractor among those found (or -1), and the velocity is NaN
    exactly where the status has none (or the slot is empty) and 0 where static."""
    settings = spec.basins
    problems = []
    for key, value in settings.canonical().items():
        name = f"study_basins_{key}"
        if key == "sweep_steps" and name not in meta.attrs:
            continue  # written before study 0.5: no seeded state (sweep_steps = 0)
        if name not in meta.attrs:
            problems.append(f"{name} is missing: a study with the observable basins "
                            f"records its [basins] {key} ({value!r})")
    slots = settings.max_attractors
    if meta.dims.get("attractor") != slots:
        return [*problems, f"dimension attractor has {meta.dims.get('attractor')} slots; "
                f"[basins] max_attractors = {slots}"]
    coordinate = meta.variables.get("attractor")
    if coordinate is None or coordinate.dims != ("attractor",) or \
            not check.equals("attractor", np.arange(slots)):
        problems.append(f"coordinate attractor must number the slots 0..{slots - 1}")
    if not all(name in good for name in (*_PER_ATTRACTOR, *_PER_POINT)):
        return problems  # their layout is reported above
    counts: dict[str, int] = {}

    def count(what: str, mask: np.ndarray) -> None:
        counts[what] = counts.get(what, 0) + int(np.count_nonzero(mask))

    shape = meta.variables["attractor_count"].shape
    invalid = [int(s) for s in INVALID_STATUSES] + [NO_ATTRACTOR]
    for index in slabs(shape, 8 * (slots + 1) * len(_PER_ATTRACTOR)):
        read = {name: read_slab(check.nc.variables[name], index, meta.path)
                for name in (*_PER_ATTRACTOR, *_PER_POINT)}
        status = read["basin_status"]
        found, drawn = read["attractor_count"], read["starts_drawn"]
        filled = np.minimum(found, slots)[..., None]
        present = np.arange(slots) < filled
        count("basin_status is no_attractor exactly in the slots after the first "
              "min(attractor_count, max_attractors)", (status != NO_ATTRACTOR) != present)
        for name in _PER_ATTRACTOR:
            if name not in ("basin_status", "basin_period"):
                count(f"{name} is NaN exactly where basin_status is no_attractor",
                      (status == NO_ATTRACTOR) & ~np.isnan(read[name]))
        fraction = read["basin_fraction"]
        low, high = read["basin_fraction_low"], read["basin_fraction_high"]
        count("basin_fraction is in [0, 1], within [basin_fraction_low, "
              "basin_fraction_high], where an attractor fills the slot",
              present & ~((fraction >= 0) & (fraction <= 1) & (low <= fraction)
                          & (fraction <= high)))
        total = np.where(present, fraction, 0.0).sum(axis=-1)
        whole = (drawn > 0) & (found <= slots)
        count("basin_fraction adds up to 1 over the attractors where starts were drawn "
              "(at most 1 where attractor_count exceeds max_attractors)",
              (whole & (np.abs(total - 1.0) > _FRACTION_SUM))
              | ((found > slots) & (total > 1.0 + _FRACTION_SUM)))
        count("attractor_count is 0 exactly where starts_drawn is 0, and starts_drawn at "
              f"most [basins] starts = {settings.starts}",
              ((drawn == 0) != (found == 0)) | (drawn < 0) | (drawn > settings.starts))
        count("default_attractor is -1 or an attractor found",
              (read["default_attractor"] < -1) | (read["default_attractor"] >= found))
        velocity = read["basin_velocity"]
        count("basin_velocity is NaN exactly where basin_status is lift_off, "
              "not_converged, friction_paradox or no_attractor, and 0 where static",
              (np.isnan(velocity) != np.isin(status, invalid))
              | ((status == Status.STATIC) & ~(velocity == 0.0)))
    problems += [f"{what} ({n} points disagree)" for what, n in counts.items() if n]
    return problems

"""Results on disk: the labelled dataset, atomic netCDF files, the chunk store, validation.

Every result file is written to a temporary file in the destination folder,
closed, reopened and validated against ``results_schema/study-result-v1.schema.json``
and only then renamed over the final name: a reader never sees a half-written file.
Completed chunks of a running study are kept, each written the same way, in a
``<result>.partial/`` folder next to the result, with the fingerprint they were
computed under; a resumed run reuses exactly the chunks whose fingerprint matches.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from study.spec import StudySpec
from study.status import NonConvergence, Status
from study.sweep import Chunk, variables_for

# Validation and reading moved to study.validate; re-exported for existing callers.
from study.validate import (  # noqa: F401
    RESULT_SCHEMA,
    RESULT_SCHEMA_PATH,
    SCENE_SCHEMA,
    SCENE_SCHEMA_PATH,
    ResultError,
    describe,
    header,
    open_result,
    seal,
)

__all__ = [
    "RESULT_SCHEMA",
    "ChunkStore",
    "ResultError",
    "build_dataset",
    "describe",
    "open_result",
    "write_atomic",
]


#: units, long_name (and more) of every data variable a study can write.
VARIABLE_ATTRS: dict[str, dict[str, Any]] = {
    "mode_gain": {
        "units": "1",
        "long_name": "amplification |w0^2 G| of the plate's first mode (1 at low frequency)",
    },
    "mode_phase": {
        "units": "rad",
        "long_name": "phase lag of the plate's deflection behind the drive",
    },
    "a_star_plus": {
        "units": "m s-2",
        "long_name": "drive acceleration at which forward slips start (paper eq. 5)",
    },
    "a_star_minus": {
        "units": "m s-2",
        "long_name": "drive acceleration at which backward slips start (paper eq. 5)",
    },
    "lift_off_acceleration": {
        "units": "m s-2",
        "long_name": "drive acceleration above which the normal force becomes negative",
    },
    "velocity": {
        "units": "m s-1",
        "long_name": "mean velocity of the steady periodic orbit, positive forward",
        "comment": "exactly 0 when static; NaN (missing) where status is lift_off, "
        "not_converged or friction_paradox",
    },
    "status": {
        "units": "1",
        "long_name": "outcome of the steady-state solver",
        "flag_values": np.array([s.value for s in Status], dtype=np.int8),
        "flag_meanings": " ".join(s.name.lower() for s in Status),
    },
    "velocity_one_way": {
        "units": "m s-1",
        "long_name": "mean steady velocity of the paper's one-way model at the same point "
        "(exact solver), for comparison with the two-way velocity",
        "comment": "exactly 0 when static; NaN (missing) where status_one_way is lift_off "
        "or not_converged",
    },
    "status_one_way": {
        "units": "1",
        "long_name": "outcome of the exact solver for the paper's one-way model",
        "flag_values": np.array([s.value for s in Status], dtype=np.int8),
        "flag_meanings": " ".join(s.name.lower() for s in Status),
    },
    "slips_per_period": {
        "units": "1",
        "long_name": "slip events per drive period on the periodic orbit",
    },
    "forward_slip_fraction": {
        "units": "1",
        "long_name": "fraction of the drive period spent slipping forward",
    },
    "backward_slip_fraction": {
        "units": "1",
        "long_name": "fraction of the drive period spent slipping backward",
    },
    "orbit_period": {
        "units": "1",
        "long_name": "period of the steady orbit in drive periods (0: no orbit)",
    },
    "nonconvergence": {
        "units": "1",
        "long_name": "why the solver found no periodic orbit",
        "flag_values": np.array([r.value for r in NonConvergence], dtype=np.int8),
        "flag_meanings": " ".join(r.name.lower() for r in NonConvergence),
    },
}

#: Variables of the zero-velocity frontier, over (structure axes..., a, branch).
FRONTIER_ATTRS: dict[str, dict[str, Any]] = {
    "frontier_frequency": {
        "units": "Hz",
        "long_name": "drive frequency f*(a) where the mean velocity changes sign",
        "comment": "NaN-padded where an acceleration has fewer branches",
    },
    "frontier_kind": {
        "units": "1",
        "long_name": "how the velocity changes sign at the frontier",
        "flag_values": np.array([0, 1, 2], dtype=np.int8),
        "flag_meanings": "none crossing jump",
    },
    "frontier_direction": {
        "units": "1",
        "long_name": "sign of the velocity just above the frontier frequency (0: none)",
    },
    "frontier_bracket": {
        "units": "Hz",
        "long_name": "width of the final bisection bracket of the frontier frequency",
    },
}

PAPER_REFERENCE = (
    "T. Barois, A. Boucherie, L. Tadrist and H. Kellay, Controlled locomotion of a "
    "minimal soft structure by stick-slip nonlinearity"
)


# ---------------------------------------------------------------------------
# The dataset


def _coordinate(name: str, values: Any, units: str, long_name: str, dims=None) -> xr.Variable:
    dims = (name,) if dims is None else dims
    return xr.Variable(dims, np.asarray(values, dtype=np.float64),
                       {"units": units, "long_name": long_name})


def build_dataset(
    spec: StudySpec, arrays: dict[str, np.ndarray], attrs: dict[str, Any]
) -> xr.Dataset:
    """Assemble the full arrays of a study into its labelled dataset.

    Parameters
    ----------
    spec : StudySpec
        The study.
    arrays : dict
        Variable name -> full array over (structure axes..., f[, a]).
    attrs : dict
        Global attributes (provenance), added to the standard ones.
    """
    from study.spec import STRUCTURE_PARAMETERS, SWEEPABLE

    coords: dict[str, xr.Variable] = {}
    for axis in spec.axes:
        coords[axis.name] = _coordinate(axis.name, axis.values, axis.units, axis.long_name)
    # The canonical form holds every fixed parameter with its defaults (g, ck = cs)
    # written out, so the file describes the model fully.
    for name, value in spec.canonical["structure"].items():
        units, long_name = SWEEPABLE[name]
        coords[name] = _coordinate(name, value, units, long_name, dims=())
    if spec.mass is not None:
        coords["m0"] = _coordinate("m0", spec.mass.m0, "kg", "mass of the structure", ())
        coords["m1"] = _coordinate("m1", spec.mass.m1, "kg", "resonant (modal) mass", ())
        m_add_axis = spec.axis("m_add")
        if m_add_axis is not None:
            ratios = [spec.mass.mass_ratio(m) for m in m_add_axis.values]
            coords["M"] = _coordinate("M", ratios, "1", STRUCTURE_PARAMETERS["M"][1], ("m_add",))
        else:
            ratio = spec.mass.mass_ratio(spec.fixed.get("m_add", 0.0))
            coords["M"] = _coordinate("M", ratio, "1", STRUCTURE_PARAMETERS["M"][1], ())

    structure_dims = tuple(axis.name for axis in spec.structure_axes)
    data_vars = {}
    for name, (with_a, dtype) in variables_for(spec).items():
        dims = (*structure_dims, "f", "a") if with_a else (*structure_dims, "f")
        var_attrs = dict(VARIABLE_ATTRS[name])
        var_attrs["coverage_content_type"] = (
            "qualityInformation" if "flag_values" in var_attrs else "modelResult"
        )
        data_vars[name] = xr.Variable(dims, arrays[name].astype(dtype, copy=False), var_attrs)
    for name, attrs_ in FRONTIER_ATTRS.items():
        if name in arrays:
            var_attrs = dict(attrs_, coverage_content_type="modelResult")
            data_vars[name] = xr.Variable((*structure_dims, "a", "branch"), arrays[name],
                                          var_attrs)
    for coord in coords.values():
        coord.attrs["coverage_content_type"] = "coordinate"
    dataset = xr.Dataset(data_vars, coords=coords)
    dataset.attrs.update(_standard_attrs(spec))
    dataset.attrs.update(attrs)
    return dataset


def _creator() -> str:
    """Who ran the study: $STUDY_CREATOR, else the login name."""
    import getpass

    try:
        return os.environ.get("STUDY_CREATOR") or getpass.getuser()
    except (KeyError, OSError):
        return "unknown"


def _method_text(spec: StudySpec) -> str:
    """How the velocities were computed, for the file's own description."""
    if spec.method == "exact":
        return (
            "the exact event-driven steady-state solver (closed form between events; "
            "one-way coupling, the paper's model)"
        )
    return (
        "Dormand-Prince 5(4) time integration with events located on the dense output, "
        f"until the orbit repeats ({spec.coupling} coupling"
        + ("; the sliding base also forces the mode)" if spec.coupling == "two-way" else ")")
    )


def _standard_attrs(spec: StudySpec) -> dict[str, Any]:
    return {
        "Conventions": "CF-1.11, ACDD-1.3",
        "title": spec.title,
        "summary": spec.description
        or (
            f"Parameter study '{spec.name}' of vibration-driven stick-slip locomotion: "
            f"{', '.join(spec.observables)} of a soft structure with a resonant plate on a "
            f"vertically shaken table, computed by {_method_text(spec)}."
        ),
        "keywords": "stick-slip, friction, locomotion, resonance, vibration, parameter study",
        "id": f"{spec.name}-{spec.sha256[:16]}",
        "naming_authority": "study",
        "source": f"study: {_method_text(spec)}",
        "study_solver_method": spec.method,
        "study_coupling": spec.coupling,
        "processing_level": "model output",
        "references": PAPER_REFERENCE,
        "standard_name_vocabulary": "CF Standard Name Table v85",
        "comment": "Forces per unit total mass in the table frame; SI units. No CF standard "
        "names exist for these model quantities, so variables carry long_name only.",
        "acknowledgement": "Model of " + PAPER_REFERENCE,
        "creator_name": _creator(),
        "study_result_schema": RESULT_SCHEMA,
        "study_name": spec.name,
        "study_spec": spec.text,
        "study_spec_path": spec.path,
        "study_spec_sha256": spec.sha256,
    }


# ---------------------------------------------------------------------------
# Writing


def _encoding(dataset: xr.Dataset) -> dict[str, dict[str, Any]]:
    encoding = {}
    for name, var in dataset.variables.items():
        enc: dict[str, Any] = {}
        # CF: coordinates have no fill value; NaN marks the points without a velocity.
        if var.dtype.kind == "f" and name not in dataset.coords:
            enc["_FillValue"] = np.nan
        else:
            enc["_FillValue"] = None
        if var.ndim >= 2:
            enc.update(zlib=True, complevel=1, shuffle=True)
        encoding[name] = enc
    return encoding


def write_atomic(dataset: xr.Dataset, path: str | Path) -> Path:
    """Write a result file so that ``path`` is never half-written.

    Writes ``dataset`` to a temporary file in the same folder, closes it, seals it
    (content checksum, then validation: :func:`study.validate.seal`), then renames
    it over ``path`` (atomic on POSIX).

    Raises
    ------
    ResultError
        If the written file does not validate; ``path`` is then left untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(handle)
    temporary = Path(temporary)
    # mkstemp makes the file private (0600); a result is for sharing: follow the umask.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o666 & ~umask)
    try:
        dataset.to_netcdf(temporary, engine="netcdf4", format="NETCDF4",
                          encoding=_encoding(dataset))
        seal(temporary)  # the content checksum, then validation
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)
    return path


# ---------------------------------------------------------------------------
# Chunks of a running study


class ChunkStore:
    """Completed chunks of one study run, kept for resuming.

    Parameters
    ----------
    folder : pathlib.Path
        ``<result>.partial``.
    fingerprint : str
        Spec and code fingerprint of the run: chunks stored under another
        fingerprint are discarded, never reused.
    """

    MANIFEST = "manifest.json"

    def __init__(self, folder: Path, fingerprint: str) -> None:
        self.folder = Path(folder)
        self.fingerprint = fingerprint
        manifest = self._read_manifest()
        if manifest is not None and manifest.get("fingerprint") != fingerprint:
            shutil.rmtree(self.folder)
            manifest = None
        self.folder.mkdir(parents=True, exist_ok=True)
        self.history: list[str] = [] if manifest is None else list(manifest.get("history", []))
        self.reused = 0 if manifest is None else len(self.completed())

    def _read_manifest(self) -> dict[str, Any] | None:
        try:
            return json.loads((self.folder / self.MANIFEST).read_text())
        except (OSError, ValueError):
            return None

    def _write_json(self, name: str, payload: dict[str, Any]) -> None:
        target = self.folder / name
        temporary = target.with_suffix(".tmp")
        temporary.write_text(json.dumps(payload, indent=1))
        os.replace(temporary, target)

    def start_run(self, history_line: str) -> None:
        """Record this program run in the study's history."""
        self.history.append(history_line)
        self._write_json(self.MANIFEST, {"fingerprint": self.fingerprint,
                                         "history": self.history})

    def _chunk_path(self, number: int) -> Path:
        return self.folder / f"chunk-{number:07d}.npz"

    def completed(self) -> set[int]:
        """Numbers of the chunks already stored."""
        done = set()
        for item in self.folder.glob("chunk-*.npz"):
            try:
                done.add(int(item.stem.split("-")[1]))
            except (IndexError, ValueError):
                continue
        return done

    def save(self, chunk: Chunk, arrays: dict[str, np.ndarray]) -> None:
        """Store one chunk atomically (temporary file, then rename)."""
        target = self._chunk_path(chunk.number)
        temporary = target.with_name(target.name + ".tmp")
        with open(temporary, "wb") as stream:
            np.savez(stream, **arrays)
        os.replace(temporary, target)

    def load(self, chunk: Chunk) -> dict[str, np.ndarray]:
        """Read one stored chunk."""
        with np.load(self._chunk_path(chunk.number)) as data:
            return {name: data[name] for name in data.files}

    def remove(self) -> None:
        """Delete the partial results (after the final file is in place)."""
        shutil.rmtree(self.folder, ignore_errors=True)


def assemble(spec: StudySpec, chunks: Iterable[Chunk], store: ChunkStore) -> dict[str, np.ndarray]:
    """Full arrays of every variable from the stored chunks."""
    structure_shape = tuple(len(axis) for axis in spec.structure_axes)
    n_f = len(spec.axis("f"))
    n_a = len(spec.axis("a")) if spec.axis("a") is not None else 0
    arrays = {}
    for name, (with_a, dtype) in variables_for(spec).items():
        shape = (*structure_shape, n_f, n_a) if with_a else (*structure_shape, n_f)
        arrays[name] = np.empty(shape, dtype=dtype)
    for chunk in chunks:
        data = store.load(chunk)
        for name, array in arrays.items():
            array[(*chunk.structure_index, slice(chunk.f_start, chunk.f_stop))] = data[name]
    return arrays

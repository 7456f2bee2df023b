"""Results on disk: one writer per file, written as values arrive, never half-written.

A result file is written to a temporary file in the destination folder, block by
block as values arrive (chunked, compressed netCDF-4 variables: memory never holds
the whole result), then closed, sealed (a content checksum, then streaming
validation) and only then renamed over the final name: a reader never sees a
half-written file, and a failed write leaves the previous result intact. One
process at a time writes a given result (:func:`exclusive`); temporaries left by
a killed writer are removed by the next writer of the same file.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from study.observables import variables_of
from study.spec import SPEC_SCHEMA_PATH, SpecError, parse_spec
from study.status import INVALID_STATUSES, Status

__all__ = [
    "RESULT_SCHEMA",
    "GridWriter",
    "ResultError",
    "StoreBusy",
    "StoreError",
    "clean_temporaries",
    "commit",
    "describe",
    "exclusive",
    "file_attributes",
    "new_temporary",
    "open_result",
    "rewrite_attributes",
    "validate_dataset",
    "write_atomic",
]

RESULT_SCHEMA = "study-result-v1"
RESULT_SCHEMA_PATH = SPEC_SCHEMA_PATH.parent / f"{RESULT_SCHEMA}.schema.json"
#: Result files of steering scenes (study.scene): trajectories, calibrations, plans.
SCENE_SCHEMA = "study-scene-v1"
SCENE_SCHEMA_PATH = SPEC_SCHEMA_PATH.parent / f"{SCENE_SCHEMA}.schema.json"

PAPER_REFERENCE = (
    "T. Barois, A. Boucherie, L. Tadrist and H. Kellay, Controlled locomotion of a "
    "minimal soft structure by stick-slip nonlinearity"
)


class ResultError(ValueError):
    """A result file that is unreadable, foreign, outdated or inconsistent."""


# ---------------------------------------------------------------------------
# Validation


@cache
def result_schema() -> dict[str, Any]:
    """The JSON schema of result-file headers (``results_schema/study-result-v1...``)."""
    return json.loads(RESULT_SCHEMA_PATH.read_text())


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def header(dataset: xr.Dataset) -> dict[str, Any]:
    """The dataset's structure as plain JSON data: what the result schema validates."""
    variables = {}
    for name, var in dataset.variables.items():
        variables[str(name)] = {
            "dims": list(var.dims),
            "dtype": str(var.dtype),
            "attrs": {k: _jsonable(v) for k, v in var.attrs.items()},
        }
    return {
        "attrs": {k: _jsonable(v) for k, v in dataset.attrs.items()},
        "dims": {str(k): int(v) for k, v in dataset.sizes.items()},
        "variables": variables,
    }


def validate_dataset(dataset: xr.Dataset, source: str = "dataset") -> None:
    """Check a result dataset against the result schema and its own provenance.

    Raises
    ------
    ResultError
        Naming the file (``source``) and every problem found.
    """
    import jsonschema

    attrs = dataset.attrs
    if "study_result_schema" not in attrs:
        raise ResultError(
            f"{source}: not a study result file (no 'study_result_schema' attribute; "
            f"global attributes: {', '.join(sorted(attrs)) or 'none'})"
        )
    if attrs["study_result_schema"] == SCENE_SCHEMA:
        _validate_scene(dataset, source)
        return
    if attrs["study_result_schema"] != RESULT_SCHEMA:
        raise ResultError(
            f"{source}: written with result schema {attrs['study_result_schema']!r}; this "
            f"version of study reads {RESULT_SCHEMA!r}. Rerun its study to rewrite it."
        )
    validator = jsonschema.Draft202012Validator(result_schema())
    problems = [
        f"{'/'.join(map(str, e.absolute_path)) or 'file'}: {e.message}"
        for e in sorted(validator.iter_errors(header(dataset)), key=lambda e: str(e.path))
    ]
    try:
        spec = parse_spec(str(attrs["study_spec"]), f"{source} (embedded spec)")
    except (SpecError, KeyError) as err:
        problems.append(f"embedded study spec does not parse: {err}")
    else:
        if spec.sha256 != attrs.get("study_spec_sha256"):
            problems.append("study_spec_sha256 does not match the embedded spec")
        for axis in spec.axes:
            if axis.name not in dataset.coords or not np.array_equal(
                dataset[axis.name].values, axis.values
            ):
                problems.append(f"coordinate {axis.name!r} differs from the embedded spec")
        wanted = [v.name for v in variables_of(spec.observables)]
        for name in wanted:
            if name not in dataset.data_vars:
                problems.append(f"variable {name!r} asked for by the spec is missing")
    try:
        json.loads(attrs.get("provenance", ""))
    except ValueError:
        problems.append("global attribute 'provenance' is not a JSON document")
    for v_name, s_name in (("velocity", "status"), ("velocity_one_way", "status_one_way")):
        if v_name not in dataset or s_name not in dataset:
            continue
        velocity = dataset[v_name].values
        status = dataset[s_name].values
        flagged = np.isin(status, INVALID_STATUSES)
        mismatched = int(np.count_nonzero(np.isnan(velocity) != flagged))
        if mismatched:
            problems.append(
                f"{v_name} must be NaN exactly where {s_name} is lift_off, not_converged or "
                "friction_paradox; "
                f"{mismatched} points disagree"
            )
        if np.any(velocity[status == Status.STATIC] != 0.0):
            problems.append(f"{v_name} is not 0 where {s_name} is static")
    if problems:
        problems = list(dict.fromkeys(problems))  # two schema branches may see one fault
        raise ResultError(f"{source}: invalid study result:\n  " + "\n  ".join(problems))


def _validate_scene(dataset: xr.Dataset, source: str) -> None:
    """Check a steering-scene result against its schema and its embedded spec."""
    import jsonschema

    from study.scene import SceneError, parse_scene

    schema = json.loads(SCENE_SCHEMA_PATH.read_text())
    validator = jsonschema.Draft202012Validator(schema)
    problems = [
        f"{'/'.join(map(str, e.absolute_path)) or 'file'}: {e.message}"
        for e in sorted(validator.iter_errors(header(dataset)), key=lambda e: str(e.path))
    ]
    attrs = dataset.attrs
    if not problems:
        try:
            spec = parse_scene(str(attrs["study_spec"]), f"{source} (embedded spec)")
        except SceneError as err:
            problems.append(f"embedded spec: {err}")
        else:
            if spec.sha256 != attrs["study_spec_sha256"]:
                problems.append("study_spec_sha256 does not match the embedded spec")
            if spec.kind != attrs["study_scene_kind"]:
                problems.append("study_scene_kind does not match the embedded spec")
    for name, var in dataset.data_vars.items():
        if var.dtype.kind == "f" and "units" not in var.attrs:
            problems.append(f"{name} has no units")
    if problems:
        raise ResultError(f"{source}: invalid steering scene result:\n  " + "\n  ".join(problems))


def open_result(path: str | Path) -> xr.Dataset:
    """Open and validate a result file, loaded into memory (the file is closed).

    Raises
    ------
    ResultError
        For a missing, truncated, foreign, outdated or inconsistent file.
    """
    path = Path(path)
    if not path.is_file():
        raise ResultError(f"{path}: no such file")
    try:
        with xr.open_dataset(path, engine="netcdf4", mask_and_scale=True) as dataset:
            dataset = dataset.load()
    except Exception as err:  # netCDF4 raises OSError, RuntimeError, ValueError...
        raise ResultError(
            f"{path}: not a readable netCDF file (truncated or corrupt?): {err}"
        ) from None
    validate_dataset(dataset, str(path))
    return dataset


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

    Writes ``dataset`` to a temporary file in the same folder, closes it, reopens
    and validates it, then renames it over ``path`` (atomic on POSIX).

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
        open_result(temporary)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)
    return path


# ---------------------------------------------------------------------------
# Reading for people


def describe(dataset: xr.Dataset, path: str = "") -> str:
    """A readable summary of a result: what was swept, what is inside, where it came from."""
    attrs = dataset.attrs
    provenance = json.loads(attrs.get("provenance", "{}"))
    run = provenance.get("run", {})
    package = provenance.get("package", {})
    lines = [f"{path or attrs.get('study_name')}: {attrs.get('title')}"]
    lines.append(f"  study {attrs.get('study_name')!r}, spec sha256 "
                 f"{attrs.get('study_spec_sha256', '')[:16]}, schema "
                 f"{attrs.get('study_result_schema')}")
    for name, size in dataset.sizes.items():
        if name not in dataset.coords:
            lines.append(f"  dim {name:>7}: {size:6d}")
            continue
        coord = dataset[name]
        if coord.dtype.kind in "USO":
            lines.append(f"  axis {name:>6}: {', '.join(map(str, coord.values))}")
            continue
        lines.append(
            f"  axis {name:>6}: {size:6d} values, {float(coord.min()):.6g} .. "
            f"{float(coord.max()):.6g} {coord.attrs.get('units', '')}"
        )
    for name, coord in dataset.coords.items():
        if coord.ndim == 1 and name not in dataset.dims:
            lines.append(
                f"  {name} along {coord.dims[0]}: "
                + ", ".join(f"{v:.6g}" for v in coord.values)
                + f" {coord.attrs.get('units', '')}"
            )
    fixed = [f"{name}={float(dataset[name]):.6g}" for name in dataset.coords
             if dataset[name].ndim == 0]
    if fixed:
        lines.append("  fixed: " + ", ".join(fixed))
    for name, var in dataset.data_vars.items():
        lines.append(f"  {name} {var.dims} [{var.attrs.get('units', '')}]: "
                     f"{var.attrs.get('long_name', '')}")
    if "status" in dataset:
        values, counts = np.unique(dataset["status"].values, return_counts=True)
        total = counts.sum()
        parts = [f"{Status(int(v)).name.lower()} {c / total:.1%}" for v, c in zip(values, counts,
                                                                               strict=True)]
        lines.append("  status: " + ", ".join(parts))
    lines.append(
        f"  made by study {package.get('version')} (git {str(package.get('git_commit'))[:12]}"
        f"{', dirty' if package.get('git_dirty') is True else ''}) on {run.get('host')}, "
        f"{run.get('started_utc')} .. {run.get('finished_utc')} "
        f"({run.get('wall_seconds', float('nan')):.2f} s, scheduler {run.get('scheduler')}, "
        f"{run.get('workers')} workers)"
    )
    for line in str(attrs.get("history", "")).splitlines():
        lines.append(f"  history: {line}")
    return "\n".join(lines)


# ---------------------------------------------------------------------------
# Writing as values arrive


class StoreError(RuntimeError):
    """A result cannot be written (disk full, no permission...); one line, file named."""


def _store_error(target: Path, err: OSError) -> StoreError:
    reason = err.strerror or str(err)
    return StoreError(f"{target}: cannot write the result ({reason}); any previous result "
                      "is unchanged and computed values are kept for the next run")


@contextmanager
def exclusive(output: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``output`` for the whole run (one writer per file).

    Raises
    ------
    StoreBusy
        If another process holds it; its message names the holder.
    """
    import fcntl

    lock_path = output.with_name(f".{output.name}.lock")
    try:
        lock = open(lock_path, "a+")
    except OSError as err:
        raise _store_error(output, err) from None
    with lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.seek(0)
            holder = lock.read().strip() or "another process"
            raise StoreBusy(
                f"{output}: another run is writing this result ({holder}); wait for it "
                "to finish, or stop it: its computed values are kept and reused"
            ) from None
        lock.seek(0)
        lock.truncate()
        lock.write(f"pid {os.getpid()}")
        lock.flush()
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


class StoreBusy(RuntimeError):
    """Another process is writing the same result file."""


def new_temporary(output: Path) -> Path:
    """A fresh temporary file next to ``output`` (same file system: rename is atomic),
    readable as the umask allows (a result is for sharing)."""
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
        handle, name = tempfile.mkstemp(prefix=f".{output.name}.", suffix=".tmp",
                                        dir=output.parent)
    except OSError as err:
        raise _store_error(output, err) from None
    os.close(handle)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(name, 0o666 & ~umask)
    return Path(name)


def clean_temporaries(output: Path) -> int:
    """Remove temporaries of ``output`` left by killed runs (call under :func:`exclusive`)."""
    removed = 0
    for path in output.parent.glob(f".{output.name}.*.tmp"):
        try:
            path.unlink()
            removed += 1
        except OSError:
            continue
    return removed


def _seal(path: Path) -> None:
    open_result(path)


def commit(temporary: Path, output: Path) -> Path:
    """Seal and validate ``temporary``, then rename it over ``output`` (atomic).

    On any failure ``temporary`` is removed and ``output`` is left as it was.
    """
    try:
        _seal(temporary)
        os.replace(temporary, output)
    except OSError as err:
        raise _store_error(output, err) from None
    finally:
        temporary.unlink(missing_ok=True)
    return output


def file_attributes(path: Path) -> dict[str, Any] | None:
    """Global attributes of a netCDF file (metadata only), or None if unreadable."""
    import netCDF4

    if not path.is_file():
        return None
    try:
        with netCDF4.Dataset(path, "r") as dataset:
            return {name: dataset.getncattr(name) for name in dataset.ncattrs()}
    except Exception:  # netCDF4 raises OSError, RuntimeError, ... for a bad file
        return None


def rewrite_attributes(output: Path, attrs: dict[str, Any]) -> Path:
    """Replace global attributes of ``output`` without touching its data (atomic)."""
    import netCDF4

    temporary = new_temporary(output)
    try:
        shutil.copyfile(output, temporary)
        with netCDF4.Dataset(temporary, "a") as dataset:
            for name, value in attrs.items():
                dataset.setncattr(name, value)
    except OSError as err:
        temporary.unlink(missing_ok=True)
        raise _store_error(output, err) from None
    return commit(temporary, output)


class GridWriter:
    """A result file being written block by block (netCDF-4, HDF5 chunks = blocks).

    Parameters
    ----------
    path : pathlib.Path
        The temporary file (see :func:`new_temporary`).
    attrs : dict
        Global attributes.
    target : pathlib.Path, optional
        The result file the temporary becomes (named in error messages).
    """

    def __init__(self, path: Path, attrs: dict[str, Any], target: Path | None = None) -> None:
        import netCDF4

        self.path = path
        self.target = path if target is None else target
        try:
            self.dataset = netCDF4.Dataset(path, "w", format="NETCDF4")
        except OSError as err:
            raise _store_error(self.target, err) from None
        self.dataset.set_auto_mask(False)
        self.dataset.setncatts(attrs)

    def coordinate(self, name: str, dims: tuple[str, ...], values: Any,
                   attrs: dict[str, Any]) -> None:
        """A coordinate variable (a dimension of its own if ``dims == (name,)``)."""
        values = np.asarray(values)
        if dims == (name,):
            self.dataset.createDimension(name, values.size)
        var = self.dataset.createVariable(name, values.dtype, dims)
        var.setncatts(attrs)
        var[...] = values

    def dimension(self, name: str, size: int) -> None:
        """A dimension without a coordinate variable."""
        self.dataset.createDimension(name, size)

    def variable(self, name: str, dims: tuple[str, ...], dtype: str, attrs: dict[str, Any],
                 chunks: tuple[int, ...]) -> None:
        """A data variable, compressed, in HDF5 chunks of ``chunks``."""
        dtype_ = np.dtype(dtype)
        # CF: NaN marks the points without a value; integer flags have no fill value.
        fill = np.nan if dtype_.kind == "f" else False
        var = self.dataset.createVariable(name, dtype_, dims, zlib=True, complevel=1,
                                          shuffle=True, chunksizes=chunks, fill_value=fill)
        # Every write covers whole chunks, written once: with a cache too small for any
        # chunk, HDF5 compresses and writes each chunk during ``write`` (while the
        # workers compute the next ones) instead of holding up to the default 64 MiB
        # per variable and compressing it all in ``close``, after the last chunk, when
        # nothing overlaps. (A size of 0 would mean "keep the default" to netCDF.)
        var.set_var_chunk_cache(size=1, nelems=1, preemption=1.0)
        var.setncatts(attrs)

    def write(self, name: str, index: tuple[Any, ...], values: np.ndarray) -> None:
        """Write ``values`` at ``index`` of variable ``name`` (whole chunks of a data
        variable, each once: partial chunks are read, changed and compressed again)."""
        try:
            self._put(name, index, values)
        except OSError as err:
            raise _store_error(self.target, err) from None

    def _put(self, name: str, index: tuple[Any, ...], values: np.ndarray) -> None:
        self.dataset.variables[name][index] = values

    def read(self, name: str, index: tuple[Any, ...]) -> np.ndarray:
        """Read back part of a variable."""
        return np.asarray(self.dataset.variables[name][index])

    def set_attributes(self, attrs: dict[str, Any]) -> None:
        """Add or replace global attributes."""
        self.dataset.setncatts(attrs)

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self.dataset.isopen():
            try:
                self.dataset.close()
            except OSError as err:
                raise _store_error(self.target, err) from None

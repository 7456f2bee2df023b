"""Run a steering scene: compute it (:mod:`study.scene`), add provenance, write it.

:mod:`study.scene` parses and computes; this module crosses into the store (locks,
atomic writes, the result schema) and the provenance, so that computing a scene
never depends on how results are kept. (To be folded into the one runner of
studies and scenes.)
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import xarray as xr

from study.provenance import (
    environment,
    git_state,
    package_version,
    scene_code_sha256,
    scene_fingerprint,
    utc_now,
)
from study.runner import exclusive
from study.scene import SceneSpec, load_scene, scene_dataset
from study.store import PAPER_REFERENCE, SCENE_SCHEMA, write_atomic

__all__ = ["provenance_attrs", "run_scene", "scene_result", "scene_up_to_date"]


def provenance_attrs(spec: SceneSpec, started_utc: str, finished_utc: str,
                     wall_seconds: float) -> dict[str, Any]:
    """The ACDD and provenance attributes of a scene result computed by this code.

    Parameters
    ----------
    spec : SceneSpec
        The scene.
    started_utc, finished_utc : str
        When the computation started and ended (ISO 8601, UTC).
    wall_seconds : float
        How long it took [s].
    """
    git = git_state()
    fingerprint = scene_fingerprint(spec.sha256)
    provenance = {
        "result_schema": SCENE_SCHEMA,
        "scene": {"name": spec.name, "kind": spec.kind, "spec_path": spec.path,
                  "spec_sha256": spec.sha256, "canonical_spec": spec.canonical},
        "code": {"code_sha256": scene_code_sha256(), "fingerprint": fingerprint},
        "package": {"name": "study", "version": package_version(), **git},
        "environment": environment(),
        "run": {"started_utc": started_utc, "finished_utc": finished_utc,
                "wall_seconds": wall_seconds},
    }
    return {
        "Conventions": "CF-1.11, ACDD-1.3",
        "id": f"{spec.name}-{spec.sha256[:16]}",
        "naming_authority": "study",
        "processing_level": "model output",
        "references": PAPER_REFERENCE,
        "history": f"{finished_utc} study run {spec.path}",
        "date_created": finished_utc,
        "study_result_schema": SCENE_SCHEMA,
        "study_spec": spec.text,
        "study_spec_path": spec.path,
        "study_spec_sha256": spec.sha256,
        "study_code_sha256": scene_code_sha256(),
        "study_fingerprint": fingerprint,
        "study_version": package_version(),
        "git_commit": str(git["git_commit"]),
        "git_dirty": str(git["git_dirty"]).lower(),
        "provenance": json.dumps(provenance, sort_keys=True),
    }


def scene_result(spec: SceneSpec) -> xr.Dataset:
    """Compute a scene and return its result dataset, provenance included."""
    started = time.perf_counter()
    started_utc = utc_now()
    dataset = scene_dataset(spec)
    finished_utc = utc_now()
    provenance = provenance_attrs(spec, started_utc, finished_utc,
                                  time.perf_counter() - started)
    # Provenance first, then what the scene says of itself (the order ncdump shows).
    dataset.attrs = {"Conventions": provenance.pop("Conventions"), **dataset.attrs,
                     **provenance}
    return dataset


def scene_up_to_date(spec: SceneSpec, output: Path) -> bool:
    """True if ``output`` holds this scene computed by the current code."""
    if not output.is_file():
        return False
    try:
        with xr.open_dataset(output, engine="netcdf4") as dataset:
            return dataset.attrs.get("study_fingerprint") == scene_fingerprint(spec.sha256)
    except Exception:  # unreadable: recompute
        return False


def run_scene(spec: SceneSpec | str | Path, output: str | Path, *, force: bool = False
              ) -> tuple[Path, bool, float]:
    """Compute a scene and write its result atomically.

    Returns
    -------
    (path, up_to_date, wall_seconds)
    """
    started = time.perf_counter()
    if not isinstance(spec, SceneSpec):
        spec = load_scene(spec)
    output = Path(output)
    if not force and scene_up_to_date(spec, output):
        output.touch()
        return output, True, time.perf_counter() - started
    output.parent.mkdir(parents=True, exist_ok=True)
    # One writer per result file (the write itself is atomic: temporary, check, rename).
    with exclusive(output):
        write_atomic(scene_result(spec), output)
    return output, False, time.perf_counter() - started

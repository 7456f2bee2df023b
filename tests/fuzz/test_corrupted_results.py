"""Seeded corruption fuzz of sealed result files of every kind (study.engine.validation).

Variants of sealed files (three studies, one steering scene) get random global
attribute edits and deletions, variable attribute edits, value edits, dtype and
dimension changes, dropped variables, byte truncations and byte flips. Every
outcome must be a :class:`ResultError`, or the acceptance of a file whose content
checksum and guarded attributes are those of the original; every accepted file can
be described and loaded, and a few are drawn.

Guarded global attributes: the identity, hashes and fingerprint, the embedded spec
(compared as the spec it parses to: comments in it may change), the attributes a
scene repeats from its spec (``disk_*``, ``integrator_*``, ``start_*``), and the
provenance's result schema, code hashes, package version and what it repeats of
the spec (which may be left out, not changed). Point counts in
the provenance are checked for consistency only (computed + reused == points).
Free text (summary, history, comment, keywords...), dates, git state, the spec's
path, the rest of the provenance and a trajectory's run summary attributes
(``study_outcome``, ``study_end_time``, ``study_steps``, ``study_slips``: type
checked only) may change without a refusal. Variable attributes are covered by
the content checksum.

Run by ``make fuzz`` (CI runs it); not part of ``make test``.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import string
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np
import pytest

from study.engine.validation import (
    ResultError,
    content_sha256,
    describe,
    open_result,
    read_attributes,
    validate_file,
)
from study.figures import draw_figure
from study.scenes.scene_spec import parse_scene
from study.studies.spec import parse_spec
from tests.support.reliability import record
from tests.support.sealed_results import make_sealed_results, rewrite

pytestmark = pytest.mark.fuzz

#: The seed (CI uses the default; set STUDY_FUZZ_SEED to explore others).
SEED = int(os.environ.get("STUDY_FUZZ_SEED", "20261122"))
#: Variants of each result kind (studies: shared by the three study files).
PER_KIND = 800
KINDS = {"study": ("velocity", "thresholds", "swept-q"), "scene": ("steering",)}
#: Figures drawn for the first accepted variants of these files (about 1 s each).
FIGURES = {"velocity": "velocity-curves", "steering": "steering"}
DRAWN_PER_FILE = 2

GUARDED = ("study_result_schema", "study_name", "study_scene_kind", "study_spec_sha256",
           "study_code_sha256", "study_fingerprint", "study_content_sha256",
           "study_solver_method", "study_coupling", "study_version", "title")
GUARDED_PREFIXES = ("disk_", "integrator_", "start_")
FREE_TEXT = ("summary", "comment", "history", "keywords", "source", "references")


# ---------------------------------------------------------------------------
# Mutations: each writes a damaged copy of `source` to `target` and names what it did


def _random_text(rng: np.random.Generator, size: int = 8) -> str:
    alphabet = string.ascii_letters + string.digits + " _-.:{}[]\"'\\#=\n\u00e9\u2603"
    return "".join(rng.choice(list(alphabet), size=size))


def _mutate_text(rng: np.random.Generator, text: str) -> str:
    operation = rng.integers(6)
    position = int(rng.integers(len(text) + 1))
    if operation == 0 and text:  # replace one character
        position = min(position, len(text) - 1)
        return text[:position] + _random_text(rng, 1) + text[position + 1:]
    if operation == 1:  # insert
        return text[:position] + _random_text(rng, int(rng.integers(1, 4))) + text[position:]
    if operation == 2 and text:  # delete
        return text[:position] + text[position + 1:]
    if operation == 3:  # truncate
        return text[:position]
    if operation == 4:  # swap two words
        words = text.split(" ")
        if len(words) > 1:
            i, j = rng.choice(len(words), size=2, replace=False)
            words[i], words[j] = words[j], words[i]
        return " ".join(words)
    return _random_text(rng, int(rng.integers(0, 20)))


def _random_number(rng: np.random.Generator) -> Any:
    return [0, -1, 1, 99, 1e300, math.nan, float(rng.normal()), np.int8(5)][rng.integers(8)]


def _copy(source: Path, target: Path) -> Path:
    return Path(shutil.copyfile(source, target))


def _pick(rng: np.random.Generator, items: list[Any]) -> Any:
    return items[int(rng.integers(len(items)))]


def attribute_edit(rng, source: Path, target: Path) -> str:
    _copy(source, target)
    with netCDF4.Dataset(target, "a") as nc:
        name = _pick(rng, sorted(nc.ncattrs()))
        if rng.random() < 0.25:
            name = _pick(rng, ["provenance", "study_spec", "study_fingerprint",
                               "study_content_sha256", "study_code_sha256", name])
        value = nc.getncattr(name)
        operation = int(rng.integers(6))
        if operation == 0:
            nc.delncattr(name)
            return f"delete {name}"
        if operation == 5:  # an array where one value belongs
            nc.setncattr(name, _pick(rng, [np.array([1, 2]), ["a", "b"], np.zeros(3)]))
            return f"array {name}"
        if operation == 1:
            nc.setncattr(name, _random_number(rng))
            return f"number {name}"
        if operation == 2:
            nc.setncattr(name, value)
            return f"same {name}"
        nc.setncattr(name, _mutate_text(rng, str(value)))
        return f"text {name}"


def free_text_edit(rng, source: Path, target: Path) -> str:
    _copy(source, target)
    with netCDF4.Dataset(target, "a") as nc:
        name = _pick(rng, [n for n in FREE_TEXT if n in nc.ncattrs()])
        nc.setncattr(name, _random_text(rng, 30))
    return f"free text {name}"


def _leaves(document: Any, path: tuple = ()) -> list[tuple]:
    if isinstance(document, dict) and document:
        return [p for key, value in document.items() for p in _leaves(value, (*path, key))]
    return [path]


def provenance_edit(rng, source: Path, target: Path) -> str:
    _copy(source, target)
    with netCDF4.Dataset(target, "a") as nc:
        document = json.loads(nc.getncattr("provenance"))
        path = _pick(rng, _leaves(document))
        parent = document
        for key in path[:-1]:
            parent = parent[key]
        operation = int(rng.integers(4))
        if operation == 0:
            del parent[path[-1]]
        elif operation == 1:
            parent[path[-1]] = _pick(rng, [None, [], {}, "x", -1, 1.5, True])
        elif operation == 2:
            parent[path[-1]] = _mutate_text(rng, str(parent[path[-1]]))
        else:
            document["run"].update(points=10, points_computed=int(rng.integers(12)),
                                   points_reused=int(rng.integers(12)))
        nc.setncattr("provenance", json.dumps(document))
    return f"provenance {'/'.join(path)} ({operation})"


def variable_attribute_edit(rng, source: Path, target: Path) -> str:
    _copy(source, target)
    with netCDF4.Dataset(target, "a") as nc:
        var = nc[_pick(rng, sorted(nc.variables))]
        names = sorted(a for a in var.ncattrs() if a != "_FillValue")
        operation = int(rng.integers(6))
        if operation == 4 and names:
            name = _pick(rng, names)
            var.setncattr(name, _pick(rng, [np.array([1, 2]), ["a", "b"], np.zeros(3)]))
            return f"{var.name}.{name}: array"
        if operation == 0 or not names:
            var.setncattr("units" if rng.random() < 0.5 else "extra", "furlong")
            return f"{var.name}: add"
        name = _pick(rng, names)
        value = var.getncattr(name)
        if operation == 1:
            var.delncattr(name)
        elif operation == 2:
            var.setncattr(name, _mutate_text(rng, str(value)))
        elif operation == 3 and isinstance(value, np.ndarray):
            var.setncattr(name, value[::-1].copy() if value.size > 1 else value + 1)
        else:
            var.setncattr(name, value)
            return f"{var.name}.{name}: same"
        return f"{var.name}.{name}: {operation}"


def value_edit(rng, source: Path, target: Path) -> str:
    _copy(source, target)
    with netCDF4.Dataset(target, "a") as nc:
        nc.set_auto_maskandscale(False)
        var = nc[_pick(rng, sorted(nc.variables))]
        if var.size == 0:
            return f"{var.name}: empty"
        index = np.unravel_index(int(rng.integers(var.size)), var.shape)
        if var.dtype is str:
            var[index] = _random_text(rng, 3)
            return f"{var.name}: text"
        old = np.asarray(var[...])[index]
        choice = int(rng.integers(7))
        if choice == 0:
            new = old
        elif choice == 6 and var.dtype.kind == "f":
            var[...] = np.asarray(var[...]) * 1000.0
            return f"{var.name}: x1000"
        else:
            new = [0, 99, -1, old * 1000 if var.dtype.kind == "f" else old + 1,
                   math.nan if var.dtype.kind == "f" else 127, 127][choice - 1]
        if var.shape == ():
            var.assignValue(np.asarray(new).astype(var.dtype))
        else:
            var[index] = np.asarray(new).astype(var.dtype)
        return f"{var.name}[{index}]: {'same' if choice == 0 else choice}"


def structure_edit(rng, source: Path, target: Path) -> str:
    with netCDF4.Dataset(source) as nc:
        variables = {name: (var.dimensions, var.dtype) for name, var in nc.variables.items()}
        dims = sorted(nc.dimensions)
    operation = int(rng.integers(4))
    name = _pick(rng, sorted(variables))
    if operation == 0:
        rewrite(source, target, drop=(name,))
        return f"drop {name}"
    if operation == 1 and variables[name][1] is not str:
        new = _pick(rng, ["float32", "float64", "int8", "int16", "int32", "int64"])
        rewrite(source, target, dtypes={name: new})
        return f"{name} as {new}"
    several = [n for n, (d, _) in variables.items() if len(d) >= 2]
    if operation == 2 and several:
        name = _pick(rng, sorted(several))
        order = tuple(int(i) for i in rng.permutation(len(variables[name][0])))
        rewrite(source, target, transpose={name: order})
        return f"transpose {name} {order}"
    dim = _pick(rng, dims)
    rewrite(source, target, rename_dims={dim: dim + "_"})
    return f"rename dimension {dim}"


def truncation(rng, source: Path, target: Path) -> str:
    data = source.read_bytes()
    size = int(rng.integers(len(data)))
    target.write_bytes(data[:size])
    return f"truncate to {size}"


def byte_flips(rng, source: Path, target: Path) -> str:
    data = bytearray(source.read_bytes())
    count = int(rng.integers(1, 9))
    for _ in range(count):
        data[int(rng.integers(len(data)))] ^= int(rng.integers(1, 256))
    target.write_bytes(bytes(data))
    return f"flip {count} bytes"


MUTATIONS: list[tuple[Callable[..., str], float]] = [
    (attribute_edit, 0.20), (free_text_edit, 0.05), (provenance_edit, 0.08),
    (variable_attribute_edit, 0.13), (value_edit, 0.16), (structure_edit, 0.10),
    (truncation, 0.08), (byte_flips, 0.20),
]


# ---------------------------------------------------------------------------
# The oracle


def _spec_identity(attrs: dict[str, Any]) -> tuple:
    parse = parse_scene if "study_scene_kind" in attrs else parse_spec
    spec = parse(attrs["study_spec"], "embedded")
    return spec.sha256, spec.name, spec.title


def _provenance_identity(attrs: dict[str, Any]) -> tuple:
    document = json.loads(attrs["provenance"])
    section = document.get("scene" if "study_scene_kind" in attrs else "study", {})
    # What it repeats of the spec may be left out, not changed.
    spec = {key: section[key] for key in ("name", "spec_sha256", "kind", "canonical_spec")
            if key in section}
    return document["result_schema"], document["code"], document["package"]["version"], spec


def guarded(attrs: dict[str, Any]) -> dict[str, Any]:
    """What an accepted file must share with its original."""
    kept = {k: attrs.get(k) for k in GUARDED}
    kept.update({k: v for k, v in attrs.items() if k.startswith(GUARDED_PREFIXES)})
    kept["spec"] = _spec_identity(attrs)
    kept["provenance"] = _provenance_identity(attrs)
    return kept


def _kept(key: str, value: Any, original: Any) -> bool:
    if key == "provenance":
        spec = value[-1]
        return (str(value[:-1]) == str(original[:-1])
                and all(original[-1].get(k) == v for k, v in spec.items()))
    return str(value) == str(original)


@pytest.fixture(scope="module")
def sealed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return make_sealed_results(tmp_path_factory.mktemp("sealed"))


def test_corrupted_results_are_refused_or_unchanged(sealed, tmp_path: Path) -> None:
    rng = np.random.default_rng(SEED)
    functions = [m for m, _ in MUTATIONS]
    weights = np.array([w for _, w in MUTATIONS])
    originals = {name: (content_sha256(path), guarded(read_attributes(path)))
                 for name, path in sealed.items()}
    outcomes: dict[str, Counter] = {kind: Counter() for kind in KINDS}
    failures: list[str] = []
    drawn: Counter = Counter()
    by_mutation: Counter = Counter()
    accepted_labels: list[str] = []
    number = 0
    for kind, names in KINDS.items():
        for i in range(PER_KIND):
            name = names[i % len(names)]
            mutation = functions[rng.choice(len(functions), p=weights / weights.sum())]
            number += 1
            # A new file each time: after a failed open the netCDF library keeps the
            # damaged file's handle, and would serve it again for the same inode.
            target = tmp_path / f"{number:05d}-{name}.nc"
            with np.errstate(all="ignore"):  # x1000 may overflow, NaN cast to int...
                label = f"{name} #{i}: {mutation(rng, sealed[name], target)}"
            try:
                validate_file(target)
            except ResultError as err:
                outcomes[kind]["refused"] += 1
                by_mutation[mutation.__name__, "refused"] += 1
                if "not a readable netCDF file" in str(err):
                    outcomes[kind]["refused unreadable"] += 1
                elif "content differs" in str(err):
                    outcomes[kind]["refused content"] += 1
                target.unlink()
                continue
            except Exception as err:
                failures.append(f"{label}: validate_file raised {type(err).__name__}: {err}")
                continue
            outcomes[kind]["accepted"] += 1
            by_mutation[mutation.__name__, "accepted"] += 1
            accepted_labels.append(label)
            checksum, attributes = originals[name]
            try:
                if content_sha256(target) != checksum:
                    failures.append(f"{label}: accepted with changed content")
                now = guarded(read_attributes(target))
                changed = {k for k in {*now, *attributes}
                           if not _kept(k, now.get(k), attributes.get(k))}
                if changed:
                    failures.append(f"{label}: accepted with changed {sorted(changed)}")
                assert isinstance(describe(target), str)
                dataset = open_result(target)
                if name in FIGURES and drawn[name] < DRAWN_PER_FILE:
                    drawn[name] += 1
                    draw_figure(FIGURES[name], dataset, tmp_path / f"figure-{number}")
            except Exception as err:
                failures.append(f"{label}: accepted, then {type(err).__name__}: {err}")
            target.unlink()
    summary = {kind: dict(counts) for kind, counts in outcomes.items()}
    print(f"\ncorrupted result files: {summary}; figures drawn: {dict(drawn)}")
    print("by mutation: " + ", ".join(f"{m} {o} {n}" for (m, o), n in sorted(by_mutation.items())))
    if os.environ.get("STUDY_FUZZ_VERBOSE"):
        print("accepted:\n  " + "\n  ".join(accepted_labels))
    assert not failures, f"{len(failures)} failures of {number}:\n" + "\n".join(failures[:30])
    for kind, counts in outcomes.items():
        assert counts["refused"] + counts["accepted"] == PER_KIND
        # Both outcomes occur, so both paths were exercised.
        assert counts["refused"] >= PER_KIND // 2, (kind, counts)
        assert counts["accepted"] >= 10, (kind, counts)
    assert drawn == {name: DRAWN_PER_FILE for name in FIGURES}
    record("tests/fuzz/test_corrupted_results.py",
           "result files: attribute, value, dtype and byte corruptions, refused or unchanged",
           cases=number, faults=number,
           results_checked=sum(c["accepted"] for c in outcomes.values()))

"""Code fingerprints of result kinds, derived from the import graph of the package.

A result is stale when anything that can change its numbers changed. Which modules can
is read from the code itself, not from a hand-kept list: starting from the entry modules
of a result kind, the ``study.*`` imports are followed statically (with :mod:`ast`, so no
module is imported and no kernel compiled) through module-level and function-level
imports, absolute and relative ones, ``from study.x import y`` where ``y`` is a submodule
or a name, and ``importlib.import_module("study.x")`` with a literal name. The
``__init__`` of every package on the way to an imported module counts too, since it runs
on import. Every module reached is hashed with its name, together with the versions of
the libraries that compile and run the kernels (numpy, numba, llvmlite), the Python
version, the machine architecture and the JSON schema files that the spec layer reads.

Over-inclusion is safe (a result is recomputed once too often); under-inclusion is not.
Imports that only a running program knows (``importlib.import_module(variable)``) are
not followed: the computing modules must not use them.

``python -m study.engine.fingerprint [KIND]`` prints the closure and the hash of a result kind.
"""

from __future__ import annotations

import argparse
import ast
import hashlib
import platform
import sys
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from functools import cache, lru_cache
from importlib import metadata
from pathlib import Path

from study.engine.kinds import RESULT_KINDS, kind_named

__all__ = [
    "RESULT_KIND_ENTRIES",
    "CodeFingerprint",
    "code_fingerprint",
    "import_closure",
    "result_code_sha256",
]

PACKAGE = "study"

class _KindEntries(Mapping[str, tuple[str, ...]]):
    """A live view of the registered kinds' entry modules (kinds register on ``import
    study``, after this module may have been imported)."""

    def __getitem__(self, kind: str) -> tuple[str, ...]:
        return RESULT_KINDS[kind].entry_modules

    def __iter__(self) -> Iterator[str]:
        return iter(RESULT_KINDS)

    def __len__(self) -> int:
        return len(RESULT_KINDS)


#: The modules whose import closure decides the numbers of each result kind: kind name
#: -> entry modules (declared where each kind registers, :mod:`study.engine.kinds`).
RESULT_KIND_ENTRIES: Mapping[str, tuple[str, ...]] = _KindEntries()

# Libraries whose version can change computed values (the kernels are compiled by
# numba through llvmlite; numpy does the vectorised parts).
LIBRARIES = ("numpy", "numba", "llvmlite")


@dataclass(frozen=True)
class CodeFingerprint:
    """The hash of the code behind a result kind, and what went into it.

    Attributes
    ----------
    sha256 : str
        Hex digest over the modules' names and sources, the library versions and the
        schema files.
    modules : tuple of str
        Sorted names of every ``study.*`` module hashed (``"study"`` is the package's
        ``__init__``).
    libraries : dict of str to str
        Versions of numpy, numba and llvmlite (``"not installed"`` if missing), of
        Python (``"python"``) and the machine architecture (``"machine"``).
    schemas : tuple of str
        The JSON schema files hashed, as paths relative to the package's parent folder.
    """

    sha256: str
    modules: tuple[str, ...]
    libraries: dict[str, str] = field(hash=False)
    schemas: tuple[str, ...] = ()


def _package_root() -> Path:
    """The folder of the ``study`` package that is running (source tree or wheel).

    This module sits one folder below it, so ``study.__file__``'s folder is found without importing
    anything.
    """
    return Path(__file__).resolve().parents[1]


def _source_path(root: Path, name: str) -> Path | None:
    """The source file of module ``name`` under package folder ``root``, if it exists."""
    parts = name.split(".")
    if parts[0] != PACKAGE:
        return None
    base = root.joinpath(*parts[1:])
    if (base / "__init__.py").is_file():
        return base / "__init__.py"
    module = base.with_suffix(".py")
    if len(parts) > 1 and module.is_file():
        return module
    return None


def _with_parents(name: str) -> list[str]:
    """``a.b.c`` and the packages whose ``__init__`` runs when it is imported."""
    parts = name.split(".")
    return [".".join(parts[: i + 1]) for i in range(len(parts))]


def _literal_import(node: ast.Call) -> str | None:
    """The module of ``importlib.import_module("x")`` or ``__import__("x")``, if literal."""
    func = node.func
    called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
    if called not in ("import_module", "__import__") or not node.args:
        return None
    first = node.args[0]
    if isinstance(first, ast.Constant) and isinstance(first.value, str):
        return first.value
    return None


@lru_cache(maxsize=512)
def _raw_imports(source: bytes, name: str, is_package: bool) -> tuple[tuple[str, ...], ...]:
    """Absolute names a module imports: ``(module, *names imported from it)`` each.

    Keyed by the source itself (parsing dominates the cost), so an edited file is parsed
    again and an unchanged one is not.
    """
    tree = ast.parse(source, filename=f"<{name}>")
    found: list[tuple[str, ...]] = []
    for node in ast.walk(tree):  # every statement, at module level or inside functions
        if isinstance(node, ast.Import):
            found.extend((alias.name,) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                # Relative to the package the module sits in (itself, for an __init__).
                package = name.split(".")
                if not is_package:
                    package = package[:-1]
                package = package[: len(package) - (node.level - 1)]
                base = ".".join([*package, *([node.module] if node.module else [])])
            else:
                base = node.module or ""
            found.append((base, *(alias.name for alias in node.names)))
        elif isinstance(node, ast.Call):
            literal = _literal_import(node)
            if literal is not None:
                found.append((literal,))
    return tuple(found)


def _imported_names(name: str, path: Path, root: Path) -> set[str]:
    """Every ``study.*`` module that module ``name`` (source at ``path``) may import."""
    found: set[str] = set()
    for base, *names in _raw_imports(path.read_bytes(), name, path.name == "__init__.py"):
        found.add(base)
        # ``from pkg import y``: y is a submodule, or a name defined in pkg.
        found.update(
            f"{base}.{y}" for y in names if _source_path(root, f"{base}.{y}") is not None
        )
    return {
        module
        for imported in found
        if imported == PACKAGE or imported.startswith(PACKAGE + ".")
        for module in _with_parents(imported)
    }


def import_closure(entry_modules: tuple[str, ...], root: Path | None = None) -> tuple[str, ...]:
    """Sorted names of every ``study.*`` module that importing the entries may run.

    Parameters
    ----------
    entry_modules : tuple of str
        Dotted names of ``study.*`` modules, e.g. ``("study.studies.sweep",)``.
    root : Path, optional
        The ``study`` package folder to read; default: the one that is running.

    Returns
    -------
    tuple of str
        The entries, every module they import (transitively, at any depth of the
        source) and the packages on the way to each of them.

    Raises
    ------
    ValueError
        If an entry, or a ``study.*`` module imported on the way, has no source file.
    """
    root = _package_root() if root is None else Path(root)
    seen: set[str] = set()
    pending = [m for entry in entry_modules for m in _with_parents(entry)]
    while pending:
        name = pending.pop()
        if name in seen:
            continue
        path = _source_path(root, name)
        if path is None:
            # Either a name that is not a study module, or a broken import: refusing
            # is safer than a fingerprint that silently misses code.
            raise ValueError(f"no source for module {name!r} under {root}")
        seen.add(name)
        pending.extend(_imported_names(name, path, root) - seen)
    return tuple(sorted(seen))


def _library_versions() -> dict[str, str]:
    versions = {}
    for library in LIBRARIES:
        try:
            versions[library] = metadata.version(library)
        except metadata.PackageNotFoundError:
            versions[library] = "not installed"
    versions["python"] = platform.python_version()
    versions["machine"] = platform.machine()
    return versions


def _schema_files(root: Path) -> list[Path]:
    """The JSON schemas the spec layer reads: package data, else the repository's copy."""
    for folder in (root / "schemas", root.parent / "results_schema"):
        if folder.is_dir():
            return sorted(folder.glob("*.json"))
    return []


def _fingerprint(entry_modules: tuple[str, ...], root: Path) -> CodeFingerprint:
    modules = import_closure(entry_modules, root)
    libraries = _library_versions()
    schemas = _schema_files(root)
    digest = hashlib.sha256(b"study-code-fingerprint-v1\n")

    def update(kind: str, label: str, content: bytes) -> None:
        # Length-prefixed, so that no two different inputs give the same byte stream.
        digest.update(f"{kind} {label} {len(content)}\n".encode())
        digest.update(content)

    for name in modules:
        update("module", name, _source_path(root, name).read_bytes())
    for library, version in sorted(libraries.items()):
        update("library", library, version.encode())
    for path in schemas:
        update("schema", path.name, path.read_bytes())
    return CodeFingerprint(
        sha256=digest.hexdigest(),
        modules=modules,
        libraries=libraries,
        schemas=tuple(f"{path.parent.name}/{path.name}" for path in schemas),
    )


@cache
def _running_fingerprint(entry_modules: tuple[str, ...]) -> CodeFingerprint:
    # The running code does not change under a process: computed once per entry tuple.
    return _fingerprint(entry_modules, _package_root())


def code_fingerprint(
    entry_modules: tuple[str, ...], root: Path | None = None
) -> CodeFingerprint:
    """The fingerprint of the code that importing ``entry_modules`` runs.

    Parameters
    ----------
    entry_modules : tuple of str
        Dotted names of ``study.*`` modules.
    root : Path, optional
        A ``study`` package folder to read instead of the running one (e.g. a scratch
        copy). Results for an explicit ``root`` are not memoised, since its files may
        change; those for the running package are, per entry tuple.

    Returns
    -------
    CodeFingerprint
    """
    entry_modules = tuple(entry_modules)
    if root is None:
        return _running_fingerprint(entry_modules)
    return _fingerprint(entry_modules, Path(root).resolve())


def _entries(kind: str) -> tuple[str, ...]:
    return kind_named(kind).entry_modules


def result_code_sha256(kind: str, root: Path | None = None) -> str:
    """The code hash of result kind ``kind`` (``"study"``, ``"scene"``, ``"fit"``, ...).

    Raises
    ------
    study.engine.kinds.UnknownKind
        If ``kind`` is not a registered kind (a :class:`ValueError`).
    """
    return code_fingerprint(_entries(kind), root).sha256


def main(argv: list[str] | None = None) -> int:
    """``python -m study.engine.fingerprint [KIND]``: the modules and hash of result kinds."""
    parser = argparse.ArgumentParser(
        prog="python -m study.engine.fingerprint",
        description="The modules whose source decides the numbers of each result kind, "
        "and the code hash stored in its result files.",
    )
    parser.add_argument("kind", nargs="?", choices=sorted(RESULT_KIND_ENTRIES),
                        help="result kind (default: all)")
    args = parser.parse_args(argv)
    kinds = [args.kind] if args.kind else sorted(RESULT_KIND_ENTRIES)
    for kind in kinds:
        entries = RESULT_KIND_ENTRIES[kind]
        fp = code_fingerprint(entries)
        print(f"{kind}: {fp.sha256}")
        print(f"  entries: {', '.join(entries)}")
        print(f"  modules ({len(fp.modules)}):")
        for name in fp.modules:
            print(f"    {name}")
        print("  libraries: " + ", ".join(f"{k} {v}" for k, v in fp.libraries.items()))
        print("  schemas: " + (", ".join(fp.schemas) or "none"))
    return 0


if __name__ == "__main__":
    sys.exit(main())

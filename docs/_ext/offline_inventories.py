"""Intersphinx inventories written from the installed packages, so the build needs no network.

Intersphinx resolves a reference such as ``xarray.Dataset`` through the target project's
``objects.inv``, which it normally downloads. The machines that build these docs (a
developer's, CI's) reach the package registries only, so a download would fail and, with
``-W``, fail the build. Instead, :func:`write_inventories` writes one inventory per
project from the *installed* packages (numpy, xarray, dask, distributed and the Python
standard library): every public name of the modules our pages and docstrings use,
placed where that project's own documentation puts it (its URL layout, e.g.
``reference/generated/numpy.linspace.html#numpy.linspace``). ``conf.py`` passes each file
as the local inventory of its ``intersphinx_mapping`` entry, so intersphinx reads the
file and never fetches; the links in the built pages point at the real sites.

A name absent from the installed version of a package is absent from its inventory, and
its reference stays plain text, as it would with the project's own inventory.
"""

from __future__ import annotations

import builtins
import importlib
import inspect
import sys
import zlib
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from types import ModuleType

__all__ = ["PROJECTS", "Entry", "inventory_bytes", "write_inventories"]

#: One inventory line: (name, domain:role, uri relative to the project's base URL), and for
#: a label its title.
Entry = tuple[str, str, str] | tuple[str, str, str, str]


def _public(module: ModuleType) -> list[str]:
    names = getattr(module, "__all__", None)
    if names is None:
        names = [n for n in dir(module) if not n.startswith("_")]
    return sorted(n for n in names if hasattr(module, n) and not n.startswith("_"))


def _role(obj: object) -> str:
    if inspect.isclass(obj):
        return "py:exception" if issubclass(obj, BaseException) else "py:class"
    if inspect.ismodule(obj):
        return "py:module"
    if callable(obj):
        return "py:function"
    return "py:data"


def _members(cls: type, prefix: str, page: Callable[[str], str]) -> Iterator[Entry]:
    """Public methods and properties of a class, each on the page ``page(full name)``."""
    for name, value in inspect.getmembers(cls):
        if name.startswith("_"):
            continue
        full = f"{prefix}.{name}"
        role = "py:property" if isinstance(value, property) else (
            "py:method" if callable(value) else "py:attribute")
        yield full, role, page(full)


# --- numpy: https://numpy.org/doc/stable/ -------------------------------------------

def _numpy() -> Iterator[Entry]:
    import numpy
    import numpy.typing

    def generated(full: str) -> str:
        return f"reference/generated/{full}.html#{full}"

    yield "numpy", "py:module", "reference/index.html#module-numpy"
    for name in _public(numpy):
        obj = getattr(numpy, name)
        full = f"numpy.{name}"
        if inspect.ismodule(obj):
            continue
        if inspect.isclass(obj) and issubclass(obj, numpy.generic):
            # Scalar types are documented together on one page.
            yield full, "py:class", f"reference/arrays.scalars.html#{full}"
        elif isinstance(obj, float | int):
            yield full, "py:data", f"reference/constants.html#{full}"
        else:
            yield full, _role(obj), generated(full)
    yield from _members(numpy.ndarray, "numpy.ndarray", generated)
    for name in ("ArrayLike", "DTypeLike", "NDArray"):
        yield f"numpy.typing.{name}", "py:data", f"reference/typing.html#numpy.typing.{name}"
    # The glossary terms and labels numpydoc's parameter types link to (``array_like``,
    # ``scalar``).
    for term in ("array_like", "array", "broadcast", "dtype", "ndarray", "ufunc", "view"):
        yield term, "std:term", f"glossary.html#term-{term}"
    yield "arrays.scalars", "std:label", "reference/arrays.scalars.html#arrays-scalars", "Scalars"


# --- xarray: https://docs.xarray.dev/en/stable/ -------------------------------------

def _xarray() -> Iterator[Entry]:
    import xarray

    def generated(full: str) -> str:
        return f"generated/{full}.html#{full}"

    yield "xarray", "py:module", "api.html#module-xarray"
    for name in _public(xarray):
        obj = getattr(xarray, name)
        if inspect.ismodule(obj):
            continue
        full = f"xarray.{name}"
        yield full, _role(obj), generated(full)
    for cls in (xarray.Dataset, xarray.DataArray, xarray.Variable):
        yield from _members(cls, f"xarray.{cls.__name__}", generated)


# --- dask: https://docs.dask.org/en/stable/ -----------------------------------------

def _dask() -> Iterator[Entry]:
    import dask
    import dask.array

    yield "dask", "py:module", "api.html#module-dask"
    for name in ("compute", "persist", "delayed", "visualize", "config.set", "config.get"):
        yield f"dask.{name}", "py:function", f"api.html#dask.{name}"
    yield "dask.array", "py:module", "array-api.html#module-dask.array"
    for name in _public(dask.array):
        obj = getattr(dask.array, name)
        if inspect.ismodule(obj):
            continue
        full = f"dask.array.{name}"
        yield full, _role(obj), f"generated/{full}.html#{full}"


# --- distributed: https://distributed.dask.org/en/stable/ ---------------------------

def _distributed() -> Iterator[Entry]:
    import distributed

    yield "distributed", "py:module", "api.html#module-distributed"
    for name in _public(distributed):
        obj = getattr(distributed, name)
        if inspect.ismodule(obj):
            continue
        uri = f"api.html#distributed.{name}"
        yield f"distributed.{name}", _role(obj), uri
        # The same objects, as users import them (``from dask.distributed import ...``).
        yield f"dask.distributed.{name}", _role(obj), uri
        if inspect.isclass(obj) and name in ("Client", "LocalCluster", "Future"):
            yield from _members(obj, f"distributed.{name}",
                                lambda full: f"api.html#{full}")


# --- Python: https://docs.python.org/3/ ---------------------------------------------

#: Standard-library modules whose public names our pages and docstrings may use.
STDLIB = ("argparse", "collections.abc", "concurrent.futures", "csv", "dataclasses",
          "datetime", "enum", "functools", "io", "itertools", "json", "math", "os",
          "os.path", "pathlib", "shutil", "subprocess", "sys", "tempfile", "textwrap",
          "tomllib", "typing", "warnings")

#: Built-in types documented with the standard types, not among the built-in functions.
_STDTYPES = {"bytearray", "bytes", "dict", "frozenset", "list", "memoryview", "range",
             "set", "str", "tuple"}


def _python() -> Iterator[Entry]:
    for name in dir(builtins):
        if name.startswith("_"):
            continue
        obj = getattr(builtins, name)
        if inspect.isclass(obj) and issubclass(obj, BaseException):
            yield name, "py:exception", f"library/exceptions.html#{name}"
        elif name in _STDTYPES:
            yield name, "py:class", f"library/stdtypes.html#{name}"
        elif inspect.isclass(obj):
            yield name, "py:class", f"library/functions.html#{name}"
        elif callable(obj):
            yield name, "py:function", f"library/functions.html#{name}"
    for name in ("None", "True", "False", "Ellipsis", "NotImplemented"):
        yield name, "py:data", f"library/constants.html#{name}"
    # The glossary terms and labels numpydoc's parameter types link to (``bool``,
    # ``iterable``, ``sequence``).
    yield ("bltin-boolean-values", "std:label", "library/stdtypes.html#bltin-boolean-values",
           "Boolean Type - bool")
    for term in ("iterable", "iterator", "sequence", "mapping", "generator", "callable",
                 "path-like object", "file object", "hashable"):
        yield term, "std:term", f"glossary.html#term-{term.replace(' ', '-')}"
    for module_name in STDLIB:
        module = importlib.import_module(module_name)
        page = f"library/{module_name}.html"
        yield module_name, "py:module", f"{page}#module-{module_name}"
        for name in _public(module):
            obj = getattr(module, name)
            if inspect.ismodule(obj):
                continue
            full = f"{module_name}.{name}"
            yield full, _role(obj), f"{page}#{full}"
        if module_name == "pathlib":
            def on_page(full: str) -> str:
                return f"library/pathlib.html#{full}"

            yield from _members(module.Path, "pathlib.Path", on_page)
            yield from _members(module.PurePath, "pathlib.PurePath", on_page)


#: name -> (base URL of its documentation, the entries of its inventory).
PROJECTS: dict[str, tuple[str, Callable[[], Iterable[Entry]]]] = {
    "python": ("https://docs.python.org/3/", _python),
    "numpy": ("https://numpy.org/doc/stable/", _numpy),
    "xarray": ("https://docs.xarray.dev/en/stable/", _xarray),
    "dask": ("https://docs.dask.org/en/stable/", _dask),
    "distributed": ("https://distributed.dask.org/en/stable/", _distributed),
}


def _version(project: str) -> str:
    if project == "python":
        return f"{sys.version_info.major}.{sys.version_info.minor}"
    return str(getattr(importlib.import_module(project), "__version__", ""))


def inventory_bytes(project: str, entries: Iterable[Entry]) -> bytes:
    """An inventory (Sphinx's ``objects.inv``, version 2) holding ``entries``."""
    header = (f"# Sphinx inventory version 2\n# Project: {project}\n"
              f"# Version: {_version(project)}\n"
              "# The remainder of this file is compressed using zlib.\n")
    seen: set[tuple[str, str]] = set()
    lines = []
    for name, role, uri, *title in entries:
        if (name, role) in seen:
            continue
        seen.add((name, role))
        priority = -1 if role.startswith("std:") else 1
        lines.append(f"{name} {role} {priority} {uri} {title[0] if title else '-'}\n")
    return header.encode() + zlib.compress("".join(lines).encode())


def write_inventories(folder: str | Path) -> dict[str, tuple[str, str]]:
    """Write ``FOLDER/NAME.inv`` for every project; the ``intersphinx_mapping`` to use."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    mapping = {}
    for project, (url, entries) in PROJECTS.items():
        path = folder / f"{project}.inv"
        data = inventory_bytes(project, entries())
        if not path.exists() or path.read_bytes() != data:
            path.write_bytes(data)
        mapping[project] = (url, str(path))
    return mapping

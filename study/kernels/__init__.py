"""Numba kernels: loops only, called through the validating wrappers of :mod:`study.solvers`.

Numba's on-disk cache (``cache=True``) checks only the source file of the function it
compiled, not the kernels that function calls in other files: after an edit of
``two_way/event_search.py`` alone, the cached ``two_way/orbit.py`` would go on running
the old search. Every kernel's cache entry is therefore stamped with a hash of all the
kernel sources (and of the status codes and contact-law codes they read), so an edit of
any of them compiles every kernel afresh, wherever numba keeps its cache (beside the sources, in
``NUMBA_CACHE_DIR`` or in the user-wide folder).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

from numba.core import caching, types

KERNELS_DIR = Path(__file__).resolve().parent

#: The sources whose code the compiled kernels hold: every module of this folder, the
#: status codes, the contact laws' codes and the statistical constants (numba bakes
#: module-level numbers in as constants).
KERNEL_SOURCES = (*sorted(KERNELS_DIR.rglob("*.py")),
                  KERNELS_DIR.parent / "model" / "codes.py",
                  KERNELS_DIR.parent / "model" / "contact.py",
                  KERNELS_DIR.parent / "model" / "statistics.py")


def kernel_sources_sha256(sources: tuple[Path, ...] = KERNEL_SOURCES) -> str:
    """SHA-256 of the kernel sources, each file's path (relative to the package) and bytes."""
    digest = hashlib.sha256()
    root = KERNELS_DIR.parent
    for path in sources:
        digest.update(str(path.relative_to(root)).encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


KERNEL_SOURCES_SHA256 = kernel_sources_sha256()


class _KernelStamp:
    """Cache locator mixin: only for this folder's files; the stamp adds the hash of all
    kernel sources to numba's stamp of the one file."""

    @classmethod
    def from_function(cls, py_func: Any, py_file: str) -> Any:
        if not Path(py_file).resolve().is_relative_to(KERNELS_DIR):
            return None
        return super().from_function(py_func, py_file)  # type: ignore[misc]

    def get_source_stamp(self) -> Any:
        return (super().get_source_stamp(), KERNEL_SOURCES_SHA256)  # type: ignore[misc]


def _stamped(locator: type) -> type:
    return type(f"Kernel{locator.__name__}", (_KernelStamp, locator), {})


# Numba asks its locator classes in order and takes the first that serves a function;
# the stamped ones go first, in numba's own order (a folder the user chose, beside the
# source, user-wide). A numba without this hook keeps its own stamp.
_LOCATORS = getattr(caching.CacheImpl, "_locator_classes", None)
if isinstance(_LOCATORS, list) and not any(c.__name__.startswith("Kernel")
                                            for c in _LOCATORS):
    _LOCATORS[:0] = [_stamped(c) for c in (caching.UserProvidedCacheLocator,
                                           caching.InTreeCacheLocator,
                                           caching.UserWideCacheLocator)]


# One compiled specialisation per kernel signature, not one per constant argument.
# Numba types a constant passed from one kernel to another (``fly(..., True)``,
# ``record(log, t, 4, y)``) as a literal and compiles the callee again for each value:
# on a fresh clone ``fly`` was compiled 4 times, ``_pass`` and ``_deferred_cycle`` 4,
# ``run`` 3, and such copies took 64 s of the 202 s that ``hysteresis-flight`` spent
# compiling. A call from a kernel to a kernel of this package is therefore typed by its
# arguments' types alone (``types.unliteral``), as a call from Python is; the values
# stay runtime arguments, so every result is bit for bit the same (the compare of every
# workflow's file, issue 46). Calls into any other package's numba code are untouched.
_KERNEL_PACKAGE = __name__ + "."


def _typed_by_type(get_call_type: Any) -> Any:
    def get_call_type_by_type(self: Any, context: Any, args: Any, kws: Any) -> Any:
        if getattr(self.dispatcher.py_func, "__module__", "").startswith(_KERNEL_PACKAGE):
            args = tuple(types.unliteral(a) for a in args)
            kws = {key: types.unliteral(value) for key, value in kws.items()}
        return get_call_type(self, context, args, kws)

    get_call_type_by_type.typed_by_type = True  # type: ignore[attr-defined]
    return get_call_type_by_type


if not getattr(types.Dispatcher.get_call_type, "typed_by_type", False):
    types.Dispatcher.get_call_type = _typed_by_type(types.Dispatcher.get_call_type)

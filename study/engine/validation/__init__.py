"""Validation and reading of result files of every kind, streaming, split by concern.

A result file is a netCDF-4 file with a global attribute ``study_result_schema`` that
names its kind (:mod:`study.engine.kinds`): a parameter study (``study-result-v1``), a
steering scene (``study-scene-v1``), a fit (``study-fit-v1``) or a design
(``study-design-v1``).

- :mod:`~study.engine.validation.reading`: metadata and values in slabs of at most
  :data:`SLAB_BYTES` (memory does not grow with the file), :func:`read_attributes`;
- :mod:`~study.engine.validation.checksums`: :func:`content_sha256`;
- :mod:`~study.engine.validation.header`: :func:`header` and the result schemas;
- :mod:`~study.engine.validation.checks`: checks every kind shares (fingerprint,
  provenance, flags, sizes, checksum, embedded spec);
- :mod:`~study.engine.validation.files`: :func:`validate_file` (every problem in one
  :class:`ResultError`; each kind's own checks are its registered validator, kept
  with the kind), :func:`seal` (record the checksum in a fresh file, then validate it:
  the writer calls it before the atomic rename) and :func:`open_result`;
- :mod:`~study.engine.validation.formats`: which format a file was written in, the
  refusal of a format newer than this version, and :func:`file_format_note` for an
  older one;
- :mod:`~study.engine.validation.describe`: :func:`describe` for people.

The public names are importable from here.
"""

from study.engine.validation.checksums import CONTENT_ATTRIBUTE, content_sha256
from study.engine.validation.describe import describe
from study.engine.validation.files import open_result, seal, validate_file
from study.engine.validation.formats import file_format_note
from study.engine.validation.header import (
    DESIGN_SCHEMA,
    DESIGN_SCHEMA_PATH,
    FIT_SCHEMA,
    FIT_SCHEMA_PATH,
    PROVENANCE_SCHEMA_PATH,
    RESULT_SCHEMA,
    RESULT_SCHEMA_PATH,
    SCENE_SCHEMA,
    SCENE_SCHEMA_PATH,
    header,
)
from study.engine.validation.reading import SLAB_BYTES, ResultError, read_attributes

__all__ = [
    "CONTENT_ATTRIBUTE",
    "DESIGN_SCHEMA",
    "DESIGN_SCHEMA_PATH",
    "FIT_SCHEMA",
    "FIT_SCHEMA_PATH",
    "PROVENANCE_SCHEMA_PATH",
    "RESULT_SCHEMA",
    "RESULT_SCHEMA_PATH",
    "SCENE_SCHEMA",
    "SCENE_SCHEMA_PATH",
    "SLAB_BYTES",
    "ResultError",
    "content_sha256",
    "describe",
    "file_format_note",
    "header",
    "open_result",
    "read_attributes",
    "seal",
    "validate_file",
]

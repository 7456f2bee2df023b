"""The engine stage, what every result kind runs on: spec files, the kind registry, the
contact laws as attributes, the runner, executors, cache, store, fingerprint,
provenance and validation. The kinds themselves (:mod:`study.studies`, the scenes,
fits and designs) sit above it and register with :mod:`study.engine.kinds`."""

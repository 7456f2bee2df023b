"""The engine stage: specs, the kind registry, observables, the sweep, the runner,
executors, cache, store, fingerprint, provenance and validation."""

"""The study result kind: a parameter study's spec (types, TOML parsing, cross-key
rules, schema, size guard, canonical form), its observables and variables, how its grid
is cut into chunks and swept, its file layout, validation and upgrades, and
:func:`study.compute_map`. It registers itself with the engine's registry
(:mod:`study.engine.kinds`) as the scenes, fits and designs do."""

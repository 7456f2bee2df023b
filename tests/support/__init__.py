"""Helpers shared by the test tiers (not tests themselves).

* :mod:`tests.support.flight_points`: the kernels' mode table of a drive point with
  flight, for tests that call the flight kernels directly.
* :mod:`tests.support.reliability`: the counts of what the fuzz and property tiers try,
  for the reliability page (``python -m tests.support.reliability COUNTS.json``).
* :mod:`tests.support.sealed_results`: small sealed result files of every kind, for the
  validation tests and the corrupted-results fuzz tier.
"""

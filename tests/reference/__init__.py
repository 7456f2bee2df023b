"""Independent references (oracles) the tests and benchmarks compare ``study`` against.

Each shares no code with the ``study`` solver it checks: every formula is re-derived.

* :mod:`tests.reference.one_way_exact`: the exact one-way steady velocity, event-driven
  closed form in mpmath (40 digits).
* :mod:`tests.reference.integrator`: the single-plate model integrated by scipy's
  ``solve_ivp`` (one-way and two-way coupling).
* :mod:`tests.reference.planar`: the planar (steering) model, scipy Radau/DOP853.
* :mod:`tests.reference.two_way_exact`: the exact two-way steady orbit in mpmath, with
  its cached points (``data/two_way_reference.json``).
* :mod:`tests.reference.flight`: the two-way model with flight and impacts, event-driven
  ``solve_ivp`` (DOP853, rtol 1e-12) with its own Darboux-Keller impact law; steady
  motions from rest, from stillness or from a drop. Its cached points
  (``data/flight_points.json``) are written by :mod:`tests.reference.make_flight_points`.
* :mod:`tests.reference.rigid_block`: the ``M -> 0`` limit with flight, a rigid block on
  a shaken table with plastic landings, in closed form.
"""

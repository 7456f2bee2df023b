"""Exact event-driven periodic orbits with the mode as a state: either coupling.

State ``z = (delta, d delta/dt, v)`` at time ``t`` and a contact mode: stick (0),
forward slip (+1), backward slip (-1). Per unit total mass, table frame, drive
``A = a cos(w t)``; ``c = w0/Q``, ``k = w0^2``. In every contact mode the mode obeys a
linear ODE with constant coefficients and harmonic forcing (docs/theory/two-way.md)::

    stick:         delta'' + c delta' + k delta = A cos(alpha)
    slip s:   D_s delta'' + c delta' + k delta = A (cos(alpha) - s ck sin(alpha))
                                                 + s ck g sin(alpha)
    D_s = 1 - M sin(alpha) (sin(alpha) + s ck cos(alpha))        (two-way)
    D_s = 1 and the stick's forcing                               (one-way)

    slip s:   v' = -K_s delta'' - s ck g + s ck A,    K_s = M (sin(alpha) + s ck cos(alpha))

so between events ``delta`` is a particular harmonic (plus a constant) plus a damped
homogeneous part ``h = E(t - t0) h0`` (closed form, any damping), and ``v`` is
``v0 - K_s (delta' - delta'_0)`` plus a sinusoid and a linear term.

Events are the first zero of a function ``phi(t) < 0`` (release ``s tau - cs n``
in a stick, ``-s v`` in a slip, ``-n`` for lift-off). ``phi`` is a sinusoid plus a
linear part plus a functional of ``h``; its second derivative is bounded on the
rest of the piece by ``|sinusoid| w^2 + ||l A^2|| sqrt(k h^2 + D h'^2)`` (the energy
of a damped oscillator never grows). From ``t`` no zero can occur before the first
root of ``phi + phi' s + bound s^2 / 2``: stepping by that amount never skips an event
(grazing contacts included) and converges quadratically onto a simple root.

The steady orbit is the fixed point of the period map ``z(0) -> z(N T)``, found by
Newton's method on ``P^N(z) - z`` with the exact Jacobian: the flow's matrix
exponential between events and a saltation matrix at each event. The Floquet
multipliers are the eigenvalues of that Jacobian at the fixed point.

The modules, each importing only those above it:

- :mod:`~study.kernels.two_way.modes`: the per-point table of the three contact modes;
- :mod:`~study.kernels.two_way.propagation`: the closed-form flow within one mode;
- :mod:`~study.kernels.two_way.event_search`: the first event of a piece;
- :mod:`~study.kernels.two_way.orbit`: a run over events, with its Jacobian;
- :mod:`~study.kernels.two_way.newton`: Newton's method on the period map;
- :mod:`~study.kernels.two_way.cycles`: the periodic orbit reached from a state;
- :mod:`~study.kernels.two_way.flight`: with the lift-off law ``flight``, a run on the
  state ``(delta, delta', v, h, h')``: the flight mode (the free oscillator of the two
  bodies, the gap ``h`` in closed form), take-off past the gap's triple zero, the
  impact's search and law (:mod:`study.kernels.impact`), and the 5x5 Jacobian;
- :mod:`~study.kernels.two_way.flight_orbit`: Newton's method and the cycle search on
  that state (a section in the middle of the longest stretch without events);
- :mod:`~study.kernels.two_way.points`: one drive point's orbit, and its drivers (with
  flight, a point past the stick's lift-off threshold is solved with flight first, any
  other with the contact model first, and with flight where that ends LIFT_OFF), each
  point from the start the drivers are given (:mod:`study.kernels.start`: the release,
  the switch-on or a drop);
- :mod:`~study.kernels.two_way.attractors`: the multistability check, and its drivers
  (with flight, drops among the starts).

:mod:`study.solvers.exact` validates, allocates and calls the drivers.
"""

"""A slow sweep decides a stuck structure static in closed form where it provably stays
stuck (:func:`study.kernels.two_way.points.stays_static`).

Checked against the exact stuck motion computed here independently in plain numpy (the
mode's particular response plus its free decay, in closed form), whose release
functions are sampled over many periods: wherever the test says "stays static", no
release ever happens. And the sweep that uses it ends static at a = 0, where following
the decaying mode from the carried state once reported a quasi-periodic motion.
"""

from __future__ import annotations

import numpy as np
import pytest

import study
from study.kernels import structure_vector as sv
from study.kernels.two_way.modes import N_MODE, mode_table
from study.kernels.two_way.points import stays_static
from study.solvers.protocol import slow_sweep
from study.solvers.structure_constants import past_lift_off, structure_vector

PAPER = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
M_TO_1 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
#: Periods of the stuck motion sampled, and samples a period.
PERIODS = 40
SAMPLES = 400


def _stuck_releases(vector, omega, a, delta0, rate0, t0=0.0):
    """Largest release function ``s tau - cs n`` [m s-2] over both signs, sampled over
    :data:`PERIODS` periods of the stuck motion from ``(delta0, rate0)`` at time ``t0``
    [s]: ``delta'' + c delta' + k delta = a cos(alpha) cos(w t)`` solved in closed
    form."""
    c = vector[sv.DAMPING]
    k = vector[sv.STIFFNESS]
    force = a * vector[sv.COS_ALPHA]
    response = force / (k - omega**2 + 1j * c * omega)
    since = np.linspace(0.0, PERIODS * 2.0 * np.pi / omega, PERIODS * SAMPLES + 1)
    t = t0 + since
    phasor = response * np.exp(1j * omega * t)
    particular, particular_rate = phasor.real, (1j * omega * phasor).real
    decay0 = delta0 - phasor[0].real
    decay_rate0 = rate0 - (1j * omega * phasor[0]).real
    damped = np.sqrt(k - 0.25 * c * c)
    b = (decay_rate0 + 0.5 * c * decay0) / damped
    envelope = np.exp(-0.5 * c * since)
    cos_d, sin_d = np.cos(damped * since), np.sin(damped * since)
    decay = envelope * (decay0 * cos_d + b * sin_d)
    decay_rate = envelope * ((b * damped - 0.5 * c * decay0) * cos_d
                             - (decay0 * damped + 0.5 * c * b) * sin_d)
    delta, rate = particular + decay, particular_rate + decay_rate
    drive = a * np.cos(omega * t)
    acceleration = drive * vector[sv.COS_ALPHA] - c * rate - k * delta
    m, cs = vector[sv.MASS_RATIO], vector[sv.STATIC_FRICTION]
    sa, ca = vector[sv.SIN_ALPHA], vector[sv.COS_ALPHA]
    base = -cs * vector[sv.GRAVITY] + cs * drive
    return max(np.max(-m * (s * sa + cs * ca) * acceleration + base) for s in (1.0, -1.0))


def _steady(vector, omega, a, t=0.0):
    """The steady stick response ``(delta, delta')`` [m, m s-1] at time ``t`` [s]."""
    response = a * vector[sv.COS_ALPHA] / (vector[sv.STIFFNESS] - omega**2
                                           + 1j * vector[sv.DAMPING] * omega)
    phasor = response * np.exp(1j * omega * t)
    return phasor.real, (1j * omega * phasor).real


@pytest.mark.parametrize("structure", [PAPER, M_TO_1], ids=["M=0.08", "M=0.99"])
def test_a_state_said_to_stay_static_never_releases(structure):
    """Random drives, start times and stuck states (the steady response of a
    neighbouring drive, as a sweep carries, or a random perturbation of it, as a start
    on a multiple of the response): every one the test accepts stays stuck over 40
    periods of the exact motion; and it accepts and refuses some."""
    rng = np.random.default_rng(20261128)
    vector = structure_vector(structure, "two-way")
    table = np.zeros((3, N_MODE))
    state = np.zeros(5)
    accepted = refused = 0
    for _ in range(300):
        f = rng.uniform(5.0, 30.0)
        a = rng.uniform(0.0, 8.0)
        omega = 2.0 * np.pi * f
        if past_lift_off(structure, np.array([f]), np.array([a]))[0]:
            continue
        mode_table(vector, omega, a, table)
        # the steady response at a drive up to 10 % away, then perturbed
        t0 = rng.choice([0.0, rng.uniform(0.0, 1.0 / f)])
        near = _steady(vector, 2.0 * np.pi * f * rng.uniform(0.9, 1.1),
                       a * rng.uniform(0.9, 1.1), t0)
        spread = rng.choice([0.0, 0.1, 1.0, 3.0])
        state[0] = near[0] * (1.0 + spread * rng.normal())
        state[1] = near[1] * (1.0 + spread * rng.normal())
        if stays_static(vector, omega, a, table, state, t0):
            accepted += 1
            largest = _stuck_releases(vector, omega, a, state[0], state[1], t0)
            assert largest <= 0.0, (f, a, t0, state[:2], largest)
        else:
            refused += 1
    assert accepted >= 50
    assert refused >= 20


def test_a_state_off_the_table_or_sliding_is_not_decided():
    vector = structure_vector(PAPER, "two-way")
    table = np.zeros((3, N_MODE))
    omega, a = 2.0 * np.pi * 20.0, 1.0
    mode_table(vector, omega, a, table)
    state = np.zeros(5)
    state[0], state[1] = _steady(vector, omega, a)
    assert stays_static(vector, omega, a, table, state, 0.0)
    for slot, value in ((2, 1e-3), (3, 1e-4), (4, 1e-3)):
        moved = state.copy()
        moved[slot] = value
        assert not stays_static(vector, omega, a, table, moved, 0.0)


@pytest.mark.parametrize("structure,flight,a", [
    (PAPER, False, np.linspace(0.0, 4.0, 21)),
    (M_TO_1, True, np.linspace(0.0, 4.0, 21)),
    (PAPER, False, np.array([0.0, 9.0])),
    (M_TO_1, True, np.array([0.0, 9.0])),
], ids=["M=0.08", "M=0.99 flight", "M=0.08 from sliding", "M=0.99 flight from hopping"])
def test_a_sweep_down_to_rest_ends_static(structure, flight, a):
    """Swept down, the last point (a = 0, the table still) is static at every frequency,
    as the unswept solver says: every motion dissipates to rest, whether the sweep
    arrives stuck (a fine grid) or from sliding and hopping (one step down from
    9 m s-2, which once ended QUASI_PERIODIC near 20 Hz)."""
    f = np.linspace(5.0, 30.0, 41)
    if a[-1] > 5.0:
        moving = slow_sweep(structure, f, a[1:], along="a", flight=flight).state
        assert np.sum(moving.velocity != 0.0) >= 10
    swept = slow_sweep(structure, f, a, along="a", direction="down", flight=flight)
    assert np.all(swept.state.status[:, 0] == study.Status.STATIC)
    assert np.all(swept.state.velocity[:, 0] == 0.0)
    unswept = study.steady_state(structure, f, np.zeros_like(f), coupling="two-way",
                                 flight=flight)
    assert np.all(unswept.status == study.Status.STATIC)


@pytest.mark.parametrize("start", ["switch-on", study.Drop(0.002, 0.25)])
def test_every_start_on_a_still_table_comes_to_rest(start):
    """At a = 0 every start ends static (a drop at 20 Hz once ended QUASI_PERIODIC: the
    search measured its distances by the drive's vanishing scales)."""
    f = np.array([5.0, 13.0, 20.0, 27.0])
    found = study.steady_state(M_TO_1, f, np.zeros_like(f), coupling="two-way",
                               flight=True, start=start)
    assert np.all(found.status == study.Status.STATIC)
    assert np.all(found.velocity == 0.0)


def test_a_start_that_provably_stays_stuck_is_the_static_point():
    """Below the stick's thresholds the switch-on (the mode at rest, off its response)
    is decided static in closed form where it provably stays stuck, and followed
    elsewhere; either way the answer is the point's static row where the motion stays
    stuck, as the motion followed from the same start finds (the same rows as the
    release's static points)."""
    f = np.linspace(8.0, 28.0, 21)
    a = np.full_like(f, 1.5)
    switched = study.steady_state(PAPER, f, a, coupling="two-way", start="switch-on")
    released = study.steady_state(PAPER, f, a, coupling="two-way")
    assert np.all(released.status == study.Status.STATIC)
    assert np.all(switched.status == study.Status.STATIC)
    assert np.array_equal(switched.floquet_multiplier, released.floquet_multiplier)

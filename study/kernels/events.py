"""Event location on a Dormand-Prince step's dense output, shared by the integrators.

A model gives its event functions through a numba function::

    values_at(theta, model, mode, t, h, dense, drive_args, ystate, values, rates)

which fills ``values[j]`` (event function ``j``, positive while nothing happens) and
``rates[j]`` (its time derivative) at ``t + theta h`` from the dense output, using
``ystate`` as scratch for the state there. In a slip (``mode != STICK``) event 0 is
the slip end: the twist's projection, zero at a slip's start and triggered at
``<= 0``; every other event is triggered at ``< 0``. An event that cannot happen in a
mode keeps a positive constant value and a zero rate.

Each event function is sampled at ``samples`` points per step *and* watched at its
minima (where its rate changes sign from negative to positive), so an event far
shorter than a step is not missed; a bracketed event is refined by the Illinois
method to ``xtol`` (a fraction of the step). Times ``t`` and ``h`` in s, ``theta``
in units of the step.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from study.model.codes import STICK

# Bisection-safeguarded Illinois iterations per event (each halves the bracket at worst
# every other step): enough for any tolerance down to the rounding of t.
MAX_ROOT_ITERATIONS = 200


@njit(cache=True, nogil=True, inline="always")
def refine(values_at, model, which, lo, hi, mode, t, h, dense, drive_args, ystate, values,
           rates, xtol):
    """Illinois iteration on event ``which`` over ``[lo, hi]`` (clear at ``lo``,
    triggered at ``hi``); returns the triggered end of a bracket narrower than ``xtol``.
    """
    values_at(lo, model, mode, t, h, dense, drive_args, ystate, values, rates)
    f_lo = values[which]
    values_at(hi, model, mode, t, h, dense, drive_args, ystate, values, rates)
    f_hi = values[which]
    side = 0
    for _ in range(MAX_ROOT_ITERATIONS):
        if hi - lo <= xtol:
            break
        if f_lo - f_hi > 0.0 and math.isfinite(f_lo - f_hi):
            mid = lo + (hi - lo) * f_lo / (f_lo - f_hi)
        else:
            mid = 0.5 * (lo + hi)
        # Keep the iterate inside the bracket and away from its ends.
        width = hi - lo
        mid = min(max(mid, lo + 0.01 * width), hi - 0.01 * width)
        values_at(mid, model, mode, t, h, dense, drive_args, ystate, values, rates)
        f_mid = values[which]
        triggered = f_mid <= 0.0 if which == 0 and mode != STICK else f_mid < 0.0
        if triggered:
            hi = mid
            f_hi = f_mid
            if side == -1:
                f_lo *= 0.5
            side = -1
        else:
            lo = mid
            f_lo = f_mid
            if side == 1:
                f_hi *= 0.5
            side = 1
    return hi


@njit(cache=True, nogil=True, inline="always")
def minimum(values_at, model, which, lo, hi, mode, t, h, dense, drive_args, ystate, values,
            rates, xtol):
    """Bisection for the zero of event ``which``'s rate (negative at ``lo``, positive at
    ``hi``): the position of the event function's minimum on ``[lo, hi]``."""
    for _ in range(MAX_ROOT_ITERATIONS):
        if hi - lo <= xtol:
            break
        mid = 0.5 * (lo + hi)
        values_at(mid, model, mode, t, h, dense, drive_args, ystate, values, rates)
        if rates[which] < 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@njit(cache=True, nogil=True, inline="always")
def first_event(values_at, model, mode, t, h, dense, drive_args, samples, xtol, fresh,
                ystate, values, rates, prev_values, prev_rates):
    """Earliest event in the step: ``(which, theta)`` or ``(-1, 1.0)``.

    ``values``, ``rates``, ``prev_values`` and ``prev_rates`` have one entry per event.
    The slip-end function is zero at the start of a slip, where it rises: at a
    ``fresh`` slip's start it counts as clear, so a slip shorter than one sample
    interval still ends. After a tangential touch (a slip end followed by a slip the
    same way) the first interval is not watched, which stops a rounding-level root
    from repeating.
    """
    count = values.shape[0]
    best_which = -1
    best_theta = 2.0
    values_at(0.0, model, mode, t, h, dense, drive_args, ystate, prev_values, prev_rates)
    theta_prev = 0.0
    for j in range(1, samples + 1):
        theta = j / samples
        values_at(theta, model, mode, t, h, dense, drive_args, ystate, values, rates)
        for which in range(count):
            before = prev_values[which]
            after = values[which]
            slip_end = which == 0 and mode != STICK
            now_triggered = after <= 0.0 if slip_end else after < 0.0
            was_clear = before > 0.0 if slip_end else before >= 0.0
            if slip_end and j == 1 and fresh:
                was_clear = True
            root_hi = -1.0
            if was_clear and now_triggered:
                root_hi = theta
            elif was_clear and prev_rates[which] < 0.0 and rates[which] > 0.0:
                # Both ends clear but the function dips in between: look at its minimum.
                theta_min = minimum(values_at, model, which, theta_prev, theta, mode, t, h,
                                    dense, drive_args, ystate, values, rates, xtol)
                values_at(theta_min, model, mode, t, h, dense, drive_args, ystate, values,
                          rates)
                dip = values[which]
                if (dip <= 0.0) if slip_end else (dip < 0.0):
                    root_hi = theta_min
                # Restore the sample at theta for the next sub-interval.
                values_at(theta, model, mode, t, h, dense, drive_args, ystate, values, rates)
            if root_hi >= 0.0:
                root = refine(values_at, model, which, theta_prev, root_hi, mode, t, h, dense,
                              drive_args, ystate, values, rates, xtol)
                if root < best_theta:
                    best_theta = root
                    best_which = which
                values_at(theta, model, mode, t, h, dense, drive_args, ystate, values, rates)
        if best_which >= 0:
            return best_which, best_theta
        for which in range(count):
            prev_values[which] = values[which]
            prev_rates[which] = rates[which]
        theta_prev = theta
    return -1, 1.0


@njit(cache=True, nogil=True)
def record(log, t, kind, y):
    """Append event ``kind`` at ``t`` [s] with state ``y`` to ``log`` (an
    :class:`study.kernels.event_loop.EventLog`) while ``log.count[0]`` is below its
    capacity; ``log.count[0]`` counts every event, recorded or not."""
    j = log.count[0]
    if j < log.t.shape[0]:
        log.t[j] = t
        log.kind[j] = kind
        for i in range(y.shape[0]):
            log.y[j, i] = y[i]
    log.count[0] = j + 1


@njit(cache=True, nogil=True)
def workspace(count):
    """Scratch of :func:`first_event` for ``count`` events: ``(values, rates,
    prev_values, prev_rates)``."""
    return np.empty(count), np.empty(count), np.empty(count), np.empty(count)

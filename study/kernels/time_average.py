"""Time averages of an irregular motion: the mean of per-period values with its
standard error by batch means, and the largest Lyapunov exponent from a tangent vector
carried through the period map's exact Jacobians.

Shared by every exact solver whose period map has no stable cycle within reach: the
motion from the solver's start is followed on the map, a transient discarded, and each
period's values (the displacement over the period, the log-growth of the tangent
vector, ...) stored; the averages follow from them.

Batch means: the ``n`` values are cut into batches of ``b`` consecutive periods; the
standard error of the mean is the standard deviation of the batch means over the
square root of their number. ``b`` starts at 1 and doubles while successive batch means
are correlated (lag-1 autocorrelation above :data:`BATCH_CORRELATION`) and at least
:data:`MIN_BATCHES` batches remain: correlated periods would make the error too small.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

# Z_95: the confidence half-width is it times the standard error (the batch means
# number at least MIN_BATCHES).
from study.model.statistics import Z_95

#: Batch means whose lag-1 autocorrelation is at most this are taken as independent.
BATCH_CORRELATION = 0.1
#: The fewest batches a standard error is computed from.
MIN_BATCHES = 32

# --- following an irregular motion on a period map ------------------------------------
#: Periods of the map's iteration discarded before its time averages start: the cycles
#: the search finds are found earlier on every workflow, and a chaotic motion's
#: 1000-period mean from the start already lies within 0.6 % of its long-run mean.
DISCARDED_PERIODS = 100
#: Periods over which the tangent vector, carried from the first iterate, aligns with
#: the most expanding direction before its growth counts towards the running exponent.
TANGENT_SETTLING = 20
#: The averages are examined every this many periods, once at least MIN_AVERAGED.
AVERAGE_CHECK = 64
MIN_AVERAGED = 256
#: Standard errors by which an exponent must exceed 0 to be positive (the motion is
#: chaotic), or fall below it to be negative (a stable cycle the search may still find).
EXPONENT_SIGMAS = 3.0
#: A motion is quasi-periodic once its exponent is clearly (EXPONENT_SIGMAS errors)
#: below this [1 per drive period]: nearby states separate by less than 3 % a period.
#: An exponent neither clearly positive nor clearly below it is averaged on (its error
#: falls as the periods grow), to the averaging budget at most.
EXPONENT_ZERO = 0.03
#: Before the averages start, the running exponent is examined after EARLY_EXPONENT
#: periods past the tangent's settling, then every EARLY_CHECK: once it exceeds 0 by
#: EARLY_SIGMAS standard errors, the cycle search tries only close returns within
#: CHAOTIC_DETECTION (the iterates converging onto a cycle after a chaotic transient),
#: not every near return of a chaotic motion (each a failing Newton search).
EARLY_EXPONENT = 32
EARLY_CHECK = 16
EARLY_SIGMAS = 1.0
CHAOTIC_DETECTION = 1e-6
#: The near returns of a chaotic motion not tried at once are kept, at most this many
#: (then they are tried), and tried in the order they came before any later one: a
#: cycle the iterates converge onto after a chaotic transient is then found from the
#: same iterate, with the same bits, as by a search that tries every near return.
DEFERRED_TRIES = 256
#: After OUT_OF_REACH_AFTER averaged periods, a motion whose mean would need more than
#: OUT_OF_REACH times the averaging budget to reach the tolerance (the periods grow as
#: the square of the half-width's ratio to it) is given up at once: not converged
#: (AVERAGE_BUDGET) with its partial averages, without spending the budget.
OUT_OF_REACH_AFTER = 1024
OUT_OF_REACH = 4.0

#: Slots of an irregular motion's averages (:func:`examine`'s ``stats``): mean velocity
#: [m s-1], its standard error [m s-1], periods averaged, the largest Lyapunov exponent
#: [1 per drive period] and its standard error, the averages per period of slips,
#: forward and backward slip time [s], time in flight [s] and impacts, the largest hop
#: [m] over the averaged periods, then the last iterate's state (from S_STATE on).
S_VELOCITY = 0
S_VELOCITY_ERROR = 1
S_PERIODS = 2
S_EXPONENT = 3
S_EXPONENT_ERROR = 4
S_SLIPS = 5
S_FORWARD = 6
S_BACKWARD = 7
S_AIRBORNE = 8
S_IMPACTS = 9
S_HOP = 10
S_STATE = 11

#: The record of a motion followed on a period map: each averaged period's velocity
#: [m s-1], the tangent's log-growth of every period [1], the sums of the per-period
#: statistics (slips, forward and backward slip time, time in flight, impacts; the
#: largest hop), the tangent vector and scratch space of the state's size.
Irregular = namedtuple("Irregular", ("velocities", "growths", "sums", "tangent", "grown"))


@njit(cache=True, nogil=True, error_model="numpy")
def _batch_statistics(values, n, length):
    """Mean, variance (ddof 1) and lag-1 autocorrelation of the means of the
    ``n // length`` batches of ``length`` values of ``values[:n]``."""
    batches = n // length
    total = 0.0
    for i in range(batches * length):
        total += values[i]
    mean = total / (batches * length)
    square = 0.0
    lagged = 0.0
    previous = 0.0
    for k in range(batches):
        s = 0.0
        for i in range(k * length, (k + 1) * length):
            s += values[i]
        d = s / length - mean
        square += d * d
        if k > 0:
            lagged += d * previous
        previous = d
    variance = square / max(batches - 1, 1)
    correlation = lagged / square if square > 0.0 else 0.0
    return variance, correlation


@njit(cache=True, nogil=True, error_model="numpy")
def mean_and_error(values, n):
    """Mean of ``values[:n]`` and its standard error by batch means.

    Parameters
    ----------
    values : numpy.ndarray of float64
        Per-period values (any unit), at least ``n`` of them.
    n : int
        How many to average (at least :data:`MIN_BATCHES`).

    Returns
    -------
    mean, error, length : float, float, int
        The mean of all ``n`` values, its standard error (same unit; 0 when the batch
        means do not vary, as over a cycle whose period divides the batch length) and
        the batch length used (periods).
    """
    total = 0.0
    for i in range(n):
        total += values[i]
    mean = total / n
    length = 1
    while True:
        variance, correlation = _batch_statistics(values, n, length)
        if correlation <= BATCH_CORRELATION or n // (2 * length) < MIN_BATCHES:
            break
        length *= 2
    batches = n // length
    return mean, math.sqrt(variance / batches), length


@njit(cache=True, nogil=True, error_model="numpy")
def new_irregular(scales, max_average_periods):
    """An empty :data:`Irregular` record for a state of natural sizes ``scales``, room
    for ``max_average_periods`` averaged periods."""
    n = scales.shape[0]
    return Irregular(np.empty(max_average_periods),
                     np.empty(DISCARDED_PERIODS + max_average_periods),
                     np.zeros(S_STATE - S_SLIPS), scales / math.sqrt(n), np.empty(n))


@njit(cache=True, nogil=True, error_model="numpy")
def tangent_growth(jac, scales, irregular):
    """Carry the record's tangent vector (unit norm in the natural sizes ``scales``)
    through a period's Jacobian ``jac``, renormalised; returns the log of its growth
    (the period's contribution to the largest Lyapunov exponent)."""
    tangent = irregular.tangent
    grown = irregular.grown
    n = tangent.shape[0]
    norm = 0.0
    for i in range(n):
        x = 0.0
        for j in range(n):
            x += jac[i, j] * tangent[j]
        grown[i] = x
        norm += (x / scales[i]) ** 2
    norm = math.sqrt(norm)
    if not norm > 0.0 or not math.isfinite(norm):
        # The period collapsed the tangent (a stick across it): a fresh direction.
        for i in range(n):
            tangent[i] = scales[i] / math.sqrt(n)
        return -np.inf if norm == 0.0 else np.nan
    for i in range(n):
        tangent[i] = grown[i] / norm
    return math.log(norm)


@njit(cache=True, nogil=True, error_model="numpy")
def looks_chaotic(irregular, iteration):
    """Whether, after iterate ``iteration`` (0-based) before the averages start, the
    running exponent is examined and found above 0 by :data:`EARLY_SIGMAS` errors."""
    settled = iteration + 1 - TANGENT_SETTLING
    if settled < EARLY_EXPONENT or settled % EARLY_CHECK != 0:
        return False
    exponent, error, _ = mean_and_error(irregular.growths[TANGENT_SETTLING:], settled)
    return exponent - EARLY_SIGMAS * error > 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def record_period(irregular, recorded, displacement, period, slips, forward, backward,
                  airborne, impacts, hop):
    """Record averaged period ``recorded`` (0-based): its displacement [m] over the
    drive period ``period`` [s], slips, slip times [s], time in flight [s], impacts
    and largest hop [m]."""
    irregular.velocities[recorded] = displacement / period
    sums = irregular.sums
    sums[0] += slips
    sums[1] += forward
    sums[2] += backward
    sums[3] += airborne
    sums[4] += impacts
    sums[5] = max(sums[5], hop)


@njit(cache=True, nogil=True, error_model="numpy")
def examine(irregular, averaged, tolerance, stats):
    """The averages of the first ``averaged`` recorded periods into ``stats`` (``S_*``
    slots); returns whether the velocity's 95 % half-width is within ``tolerance``
    [m s-1], whether the exponent is clearly positive, whether clearly negative and
    whether clearly below :data:`EXPONENT_ZERO`."""
    mean, error, _ = mean_and_error(irregular.velocities, averaged)
    exponent, exponent_error, _ = mean_and_error(
        irregular.growths[DISCARDED_PERIODS:], averaged)
    stats[S_VELOCITY] = mean
    stats[S_VELOCITY_ERROR] = error
    stats[S_PERIODS] = averaged
    stats[S_EXPONENT] = exponent
    stats[S_EXPONENT_ERROR] = exponent_error
    for k in range(S_SLIPS, S_HOP):
        stats[k] = irregular.sums[k - S_SLIPS] / averaged
    stats[S_HOP] = irregular.sums[S_HOP - S_SLIPS]
    positive = exponent - EXPONENT_SIGMAS * exponent_error > 0.0
    negative = not exponent + EXPONENT_SIGMAS * exponent_error >= 0.0
    bounded = exponent + EXPONENT_SIGMAS * exponent_error < EXPONENT_ZERO
    return Z_95 * error <= tolerance, positive, negative, bounded


@njit(cache=True, nogil=True, error_model="numpy")
def settles(averaged, max_average_periods, iteration, max_map_iterations, within, chaotic,
            negative, bounded):
    """Whether an irregular motion is reported after ``averaged`` periods (examined:
    ``within``, ``chaotic``, ``negative``, ``bounded`` from :func:`examine`) at iterate
    ``iteration``: its mean must be within the tolerance, and then it is chaotic, or its
    exponent is clearly below :data:`EXPONENT_ZERO` and the cycle search's budget is
    spent (quasi-periodic: before, the iterates may still approach a stable cycle the
    search finds), or the averaging's budget is spent (the exponent's interval says how
    clear its class is)."""
    if not within:
        return False
    if chaotic or averaged == max_average_periods:
        return True
    # Not chaotic: the iterates may still be on a long transient to a stable cycle that
    # the search would find, as release 0.2.0's did (a period-2 orbit with multiplier
    # 0.51 reached after hundreds of irregular-looking periods): reported once the
    # cycle search's budget is spent, as quasi-periodic when the exponent says so.
    return iteration + 1 >= max_map_iterations and (bounded or negative)


@njit(cache=True, nogil=True, error_model="numpy")
def out_of_reach(averaged, max_average_periods, stats, tolerance):
    """Whether the mean examined into ``stats`` after ``averaged`` periods would need
    more than :data:`OUT_OF_REACH` times ``max_average_periods`` to come within
    ``tolerance`` [m s-1] (projected from its standard error, which falls as the square
    root of the periods)."""
    if averaged < OUT_OF_REACH_AFTER:
        return False
    # (Called only once the cycle search's budget is spent: a motion whose mean is out of
    # reach may still settle on a stable cycle before.)
    ratio = Z_95 * stats[S_VELOCITY_ERROR] / tolerance
    return averaged * ratio * ratio > OUT_OF_REACH * max_average_periods


@njit(cache=True, nogil=True, error_model="numpy")
def examined(averaged, max_average_periods):
    """Whether the averages are examined after ``averaged`` recorded periods."""
    return averaged >= MIN_AVERAGED and (averaged % AVERAGE_CHECK == 0
                                         or averaged == max_average_periods)

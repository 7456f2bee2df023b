"""The event loop shared by the time integrators: Dormand-Prince steps with event location.

The loop made by :func:`make_loop` advances a model from ``state.clock[0]`` to
``t_stop`` through a drive schedule, one Dormand-Prince step (:mod:`study.kernels.dopri`)
at a time, locates the first event of each step on its dense output
(:mod:`study.kernels.events`), writes the requested output samples, and lets the model
decide what an event does. What is model-specific comes in as :class:`Hooks`, numba
functions the model names. :func:`make_loop` makes the loop for them: a closure that calls
them directly, compiled as a callee of the model's cached entry function (numba's cache
holds the entry with the loop; a cached function that takes the hooks as arguments, or
that builds a tuple holding them, or is itself a closure, would be compiled again in
every process). The single-plate model (:mod:`study.kernels.integrator`) and the planar disk
(:mod:`study.kernels.planar_integrator`) each give theirs.

The loop's arguments are named records (namedtuples of arrays and numbers):
:class:`Segments` (the drive), :class:`State` (state carried in and out),
:class:`StepControl` (accuracy and budgets), :class:`Samples` (output) and
:class:`EventLog` (recorded events). ``model`` is whatever the hooks need (a tuple).

What a vanishing normal force does is the model's ``take_off`` hook (:class:`Hooks`):
by default the lift-off law ``stop`` (:data:`study.model.contact.LAWS`, the planar
model's), which records the event and ends the run with ``RUN_LIFT_OFF``; the single
plate's hook follows the law ``flight`` too (it switches to a flight mode and goes on).

Times in s; state components in the model's units.
"""

from __future__ import annotations

import math
from collections import namedtuple

from numba import njit

from study.kernels.dopri import (
    dense_output,
    error_norm,
    growth_factor,
    shrink_factor,
    table_drive,
)
from study.kernels.dopri import workspace as step_workspace
from study.kernels.events import first_event, record
from study.kernels.events import workspace as event_workspace
from study.model.codes import EVENT_LIFT_OFF, RUN_BUDGET, RUN_DONE, RUN_LIFT_OFF, STICK

#: After a take-off the next step is tried at this fraction of the last one: a flight
#: starts on a triple zero of the gap (``h = h' = h'' = 0``), and a short first step
#: resolves a short hop (near a grazing take-off, one of 1e-18 m); the controller
#: regrows the step five-fold a step.
TAKE_OFF_STEP = 1e-3

#: The drive schedule: segment ``j`` starts at ``t0[j]`` [s] with phase ``phase0[j]``
#: [rad] and drives ``amplitude[j] cos(phase)`` [m s-2] at ``omega[j]`` [rad s-1]
#: until ``end[j]`` [s].
Segments = namedtuple("Segments", "t0 omega amplitude phase0 end")

#: The state carried in and out: ``y`` (the model's state vector), ``mode`` (1 entry,
#: the contact mode) and ``clock = (t [s], next step size to try [s])``.
State = namedtuple("State", "y mode clock")

#: Accuracy and budgets: relative and absolute tolerance [1], per-component ``scale``
#: of the absolute one (the model's units), ``fixed_step`` [s] (> 0: steps on the grid
#: ``t_start + k fixed_step`` without error control), ``max_step`` [s], ``xtol_time``
#: (width of an event's bracket [s]), ``samples`` (event samples per step) and
#: ``max_steps`` (steps of one call).
StepControl = namedtuple(
    "StepControl", "rtol atol scale fixed_step max_step xtol_time samples max_steps")

#: Output samples at the sorted times ``t`` [s]: the state (rows of ``y``) and contact
#: ``mode``; ``count`` (1 entry) is the next sample to write.
Samples = namedtuple("Samples", "t y mode count")

#: Recorded events: time ``t`` [s], ``kind`` (an ``EVENT_*`` code) and state ``y``;
#: ``count`` (1 entry) counts every event, recorded or beyond the capacity.
EventLog = namedtuple("EventLog", "t kind y count")


@njit(cache=True, nogil=True)
def stop_at_lift_off(model, mode, t, drive, y, events, stats):
    """The default ``take_off`` hook, the lift-off law ``stop``: record the event and end
    the run with ``RUN_LIFT_OFF``."""
    record(events, t, EVENT_LIFT_OFF, y)
    return mode, False, RUN_LIFT_OFF


#: What is model-specific, as numba functions (``model`` is the caller's tuple, ``mode``
#: the contact mode, ``drive`` the table's acceleration [m s-2] and ``rate`` ``-dA/dt``):
#:
#: ``restart(model, mode, fresh, t, drive, rate, y, k0, values, rates, events, stats)
#: -> (mode, fresh, code)``
#:     At the start and after every event or segment end: the mode at rest may release
#:     (``fresh`` marks a slip that starts from rest), a mode with no solution returns
#:     its ``RUN_*`` code; fills the event functions at ``t`` and the FSAL stage ``k0``.
#: ``prepare(model, mode, t, drive_args, y, k0, events) -> code``
#:     Before each step (``RUN_DONE`` to go on).
#: ``step(model, mode, t, h, y, k, drive_args, y_new, err, dense, tmp)``
#:     One Dormand-Prince step, as :func:`study.kernels.dopri.step` with the model's
#:     right-hand side.
#: ``values_at``
#:     The event functions on the dense output (:mod:`study.kernels.events`).
#: ``hold(model, mode, before, state)``
#:     Restores the components ``mode`` keeps fixed in ``state`` from ``before`` (a
#:     sample or an event's state taken from the dense output).
#: ``account(mode, duration, stats)``
#:     Adds ``duration`` [s] spent in ``mode`` to ``stats``.
#: ``accepted(model, mode, y) -> mode``
#:     After a step without an event.
#: ``transition(model, mode, which, t, drive, y, events, stats) -> (mode, fresh)``
#:     What event ``which`` (not lift-off) does at ``t`` to the state ``y``.
#: ``at_rest(y) -> bool``
#:     Whether the state has no slip velocity (a slip from it is fresh).
#: ``take_off(model, mode, t, drive, y, events, stats) -> (mode, fresh, code)``
#:     Where the normal force turns negative (the event ``lift_off``, or a restart with a
#:     negative normal force): records the event and returns ``RUN_LIFT_OFF`` to stop
#:     (:func:`stop_at_lift_off`, the default), or a mode that goes on and ``RUN_DONE``.
#:
#: ``events`` is the number of event functions and ``lift_off`` the index of the normal
#: force among them.
Hooks = namedtuple(
    "Hooks",
    "restart prepare step values_at hold account accepted transition at_rest events lift_off "
    "take_off",
    defaults=(stop_at_lift_off,),
)


@njit(cache=True, nogil=True, inline="always")
def _stop(state, mode, t, code):
    """Leave ``mode`` and ``t`` in ``state`` and return ``code``."""
    state.mode[0] = mode
    state.clock[0] = t
    return code


def make_loop(hooks):
    """The event loop for a model's :class:`Hooks`: a numba function
    ``loop(model, segments, state, t_stop, control, samples, events, stats)``, to be
    called from the model's module-level cached function.

    The factory is long because the loop it returns is: one compiled loop of steps,
    event location and mode changes whose dozen local values carry from one step to the
    next; cut into functions, they would travel as arguments through every call.
    """
    restart = hooks.restart
    prepare = hooks.prepare
    step = hooks.step
    values_at = hooks.values_at
    hold = hooks.hold
    account = hooks.account
    accepted = hooks.accepted
    transition = hooks.transition
    at_rest = hooks.at_rest
    count = hooks.events
    lift_off = hooks.lift_off
    take_off = hooks.take_off

    @njit(nogil=True)
    def loop(model, segments, state, t_stop, control, samples, events, stats):
        """Integrate from ``state.clock[0]`` to ``t_stop`` (within the segments), in place.

        With ``control.fixed_step > 0`` steps end on the grid ``t_start + k fixed_step`` (and
        at events); otherwise the step is adapted to the tolerances. ``state`` carries the
        state in and out (a run can be continued by another call). ``stats`` accumulates
        ``steps`` (entry 0), ``rejected`` steps (1) and what the hooks add.

        Returns a ``RUN_*`` code.
        """
        # The records' fields as locals, once: read in the loop they would be taken out
        # of their tuples (and their reference counts touched) on every step.
        y = state.y
        seg_t0, seg_omega, seg_a, seg_phase0, seg_end = segments
        rtol, atol, scale, fixed_step, max_step, xtol_time, n_samples, max_steps = control
        out_t, out_y, out_mode, out_count = samples
        n = y.shape[0]
        k, y_new, err, dense, tmp, ystate = step_workspace(n)
        values, rates, prev_values, prev_rates = event_workspace(count)
        mode = state.mode[0]
        t = state.clock[0]
        t_origin = t
        h = state.clock[1]
        seg = 0
        while seg < seg_end.shape[0] - 1 and t >= seg_end[seg]:
            seg += 1
        need_rhs = True
        fresh = mode != STICK and at_rest(y)
        steps = 0
        while t < t_stop:
            if steps >= max_steps:
                return _stop(state, mode, t, RUN_BUDGET)
            while seg < seg_end.shape[0] - 1 and t >= seg_end[seg]:
                seg += 1
                need_rhs = True
            drive_args = (seg, seg_t0, seg_omega, seg_a, seg_phase0)
            if need_rhs:
                drive, rate = table_drive(t, seg, seg_t0, seg_omega, seg_a, seg_phase0)
                mode, fresh, code = restart(model, mode, fresh, t, drive, rate, y, k[0],
                                                  values, rates, events, stats)
                if code != RUN_DONE:
                    return _stop(state, mode, t, code)
                if values[lift_off] < 0.0:
                    mode, fresh, code = take_off(model, mode, t, drive, y, events, stats)
                    if code != RUN_DONE:
                        return _stop(state, mode, t, code)
                    h *= TAKE_OFF_STEP
                    # The new mode's event functions and first stage.
                    mode, fresh, code = restart(model, mode, fresh, t, drive, rate, y, k[0],
                                                values, rates, events, stats)
                    if code != RUN_DONE:
                        return _stop(state, mode, t, code)
                need_rhs = False
            # Steps end on segment ends, the stop time and never exceed the cap.
            limit = min(t_stop, seg_end[seg])
            if fixed_step > 0.0:
                # Fixed steps stay on a grid anchored at the call's start time: after an
                # event the step ends on the next grid point, so every drive period is cut
                # the same way and a periodic orbit repeats exactly.
                grid = math.floor((t - t_origin) / fixed_step * (1.0 + 1e-12)) + 1.0
                h = t_origin + grid * fixed_step - t
                if h < 1e-9 * fixed_step:
                    h += fixed_step
            h = min(h, max_step)
            last = False
            if t + 1.01 * h >= limit:
                h = limit - t
                last = True
            if h <= 0.0:
                t = limit
                continue
            code = prepare(model, mode, t, drive_args, y, k[0], events)
            if code != RUN_DONE:
                return _stop(state, mode, t, code)
            step(model, mode, t, h, y, k, drive_args, y_new, err, dense, tmp)
            steps += 1
            stats[0] += 1.0
            if fixed_step <= 0.0:
                norm = error_norm(err, y, y_new, scale, rtol, atol)
                if not norm <= 1.0:
                    stats[1] += 1.0
                    h *= shrink_factor(norm)
                    if h < 1e-14 * max(abs(t), max_step):
                        return _stop(state, mode, t, RUN_BUDGET)
                    continue
                factor = growth_factor(norm)
            else:
                factor = 1.0
            which, theta = first_event(
                values_at, model, mode, t, h, dense, drive_args, n_samples, xtol_time / h,
                fresh, ystate, values, rates, prev_values, prev_rates,
            )
            t_end = t + theta * h if which >= 0 else t + h
            if last and which < 0:
                t_end = limit
            # Output samples inside the accepted part of the step.
            while out_count[0] < out_t.shape[0] and out_t[out_count[0]] <= t_end:
                j = out_count[0]
                dense_output((out_t[j] - t) / h, h, dense, ystate)
                hold(model, mode, y, ystate)
                for i in range(n):
                    out_y[j, i] = ystate[i]
                out_mode[j] = mode
                out_count[0] += 1
            account(mode, t_end - t, stats)
            if which < 0:
                for i in range(n):
                    y[i] = y_new[i]
                    k[0, i] = k[6, i]
                t = t_end
                h *= factor
                fresh = False
                mode = accepted(model, mode, y)
                continue
            dense_output(theta, h, dense, ystate)
            hold(model, mode, y, ystate)
            for i in range(n):
                y[i] = ystate[i]
            t = t_end
            need_rhs = True
            drive, rate = table_drive(t, seg, seg_t0, seg_omega, seg_a, seg_phase0)
            if which == lift_off:
                mode, fresh, code = take_off(model, mode, t, drive, y, events, stats)
                if code != RUN_DONE:
                    return _stop(state, mode, t, code)
                h *= TAKE_OFF_STEP
                continue
            mode, fresh = transition(model, mode, which, t, drive, y, events, stats)
        state.clock[1] = h
        return _stop(state, mode, t, RUN_DONE)

    return loop

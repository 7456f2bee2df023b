"""The planar model: reduction to the 1-D solvers, symmetries, the slaved direction,
validation and flagged lift-off."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from study.kernels import planar_integrator as kernel
from study.model.disk import Disk, Plate
from study.model.status import Status
from study.model.structure import Structure
from study.scenes.planar_model import periodic_motion, rest_state
from study.solvers.exact import steady_state
from study.solvers.integrator import IntegratorSettings, Schedule, simulate
from study.solvers.planar import simulate_planar

R = 0.02
PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08}


def _one_plate_disk(ck=None, direction=0.0):
    plate = Plate(**PAPER, direction=direction, attachment=(R * math.cos(math.radians(
        direction)), R * math.sin(math.radians(direction))), name="head")
    return Disk(radius=R, plates=(plate,), cs=0.25, ck=ck)


def _two_plate_disk():
    head = Plate(**PAPER, direction=0.0, attachment=(R, 0.0), name="head")
    tail = Plate(f0=7.7, Q=10.0, alpha=64.0, M=0.08, direction=-90.0, attachment=(-R, 0.0),
                 name="tail")
    return Disk(radius=R, plates=(head, tail), cs=0.25)


@pytest.mark.parametrize(("f", "a", "ck"), [(14.2, 7.0, None), (15.2, 7.0, None),
                                            (14.5, 9.0, None), (14.0, 6.0, 0.2)])
def test_one_plate_along_the_heading_is_the_1d_model(f, a, ck):
    """Transient from rest, against study.solvers.integrator.simulate; no rotation at all."""
    disk = _one_plate_disk(ck)
    structure = Structure(**PAPER, cs=0.25, ck=ck)
    schedule = Schedule(np.array([f, f + 0.5]), np.array([a, a]), np.array([12 / f, 8 / f]))
    times = np.linspace(0.0, float(schedule.ends[-1]), 81)
    tight = IntegratorSettings(tolerance=1e-11)
    planar = simulate_planar(disk, schedule, output_times=times, settings=tight)
    line = simulate(structure, schedule, output_times=times, settings=tight)
    assert planar.outcome == line.outcome == "completed"
    scale = structure.g / (2 * math.pi * f) ** 2
    assert_allclose(planar.x, line.x, rtol=0, atol=1e-8 * scale)
    assert_allclose(planar.vx, line.v, rtol=0, atol=1e-7 * scale * 2 * math.pi * f)
    assert np.all(planar.y == 0.0) and np.all(planar.heading == 0.0)


@pytest.mark.parametrize(("f", "a"), [(14.2, 7.0), (15.2, 7.0), (14.6, 7.0), (13.0, 8.5)])
def test_one_plate_steady_speed_is_the_exact_solvers(f, a):
    disk = _one_plate_disk()
    structure = Structure(**PAPER, cs=0.25)
    motion = periodic_motion(disk, f, a, settings=IntegratorSettings(tolerance=1e-11))
    exact = float(steady_state(structure, f, a).velocity)
    assert_allclose(motion.forward_speed, exact, rtol=1e-7, atol=1e-12)
    assert motion.lateral_speed == 0.0 and motion.turn_rate == 0.0


def test_a_plate_pointing_anywhere_moves_the_disk_along_its_direction():
    """Rotating the plate (and its attachment on the line through the centre) rotates
    the motion: the body frame is not special."""
    straight = periodic_motion(_one_plate_disk(), 14.2, 7.0)
    turned = periodic_motion(_one_plate_disk(direction=37.0), 14.2, 7.0)
    angle = math.radians(37.0)
    assert_allclose(
        [turned.forward_speed, turned.lateral_speed],
        [straight.forward_speed * math.cos(angle), straight.forward_speed * math.sin(angle)],
        rtol=1e-7, atol=1e-12,
    )
    assert abs(turned.turn_rate) < math.degrees(1e-12)  # degree s-1


def test_mirrored_disk_mirrors_the_motion():
    disk = _two_plate_disk()
    head, tail = disk.plates
    mirror = replace(disk, plates=(head, replace(tail, direction=90.0)))
    for f in (7.2, 8.2, 14.2):
        a, b = periodic_motion(disk, f, 7.0), periodic_motion(mirror, f, 7.0)
        assert_allclose([b.forward_speed, b.lateral_speed, b.turn_rate],
                        [a.forward_speed, -a.lateral_speed, -a.turn_rate],
                        rtol=1e-6, atol=1e-12)


def test_the_path_rotates_with_the_initial_heading():
    """The pose and the heading are in degree (as everywhere in the API)."""
    disk = _two_plate_disk()
    schedule = Schedule(np.array([14.2, 8.2]), np.array([7.0, 7.0]), np.array([1.0, 1.0]))
    base = simulate_planar(disk, schedule, output_times=[1.0, 2.0])
    turn = 63.0  # degree
    state = rest_state(disk, (0.0, 0.0, turn))
    assert state[2] == turn
    rotated = simulate_planar(disk, schedule, initial_state=state, output_times=[1.0, 2.0])
    c, s = math.cos(math.radians(turn)), math.sin(math.radians(turn))
    assert_allclose(rotated.x, c * base.x - s * base.y, rtol=0, atol=1e-9)
    assert_allclose(rotated.y, s * base.x + c * base.y, rtol=0, atol=1e-9)
    assert_allclose(rotated.heading - turn, base.heading, rtol=0, atol=math.degrees(1e-9))
    assert_allclose(rotated.final_state[2], rotated.heading[-1], rtol=0, atol=0)


def test_angles_are_in_degrees_at_the_boundary():
    """A run started spinning at 90 degree s-1 reports its heading, spin, final state
    and the steady turn rate in degree (s-1); the kernel's rad never leak out."""
    disk = _two_plate_disk()
    state = rest_state(disk)
    state[5] = 90.0  # spin [degree s-1]: a slide from a pure spin, no drive
    run = simulate_planar(disk, Schedule.constant(14.2, 0.0, 1e-4), initial_state=state,
                          output_times=[0.0, 1e-4], settings=IntegratorSettings(tolerance=1e-12))
    assert run.spin[0] == 90.0
    # It slows at most by ck g / c per second [rad s-2]: after 1e-4 s still ~90 degree s-1.
    assert 89.0 < run.spin[1] < 90.0
    assert_allclose(run.heading[1], 0.5 * (run.spin[0] + run.spin[1]) * 1e-4, rtol=1e-3)
    assert run.final_state[5] == run.spin[-1] and run.final_state[2] == run.heading[-1]
    motion = periodic_motion(disk, 8.2, 7.0)
    rad_per_s = motion.turn_rate * math.pi / 180
    # The README's right turn, -0.512 rad s-1 = -29.3 degree s-1.
    assert_allclose(motion.turn_rate, -29.3, rtol=0.01)
    assert_allclose(rad_per_s, -0.512, rtol=0.01)


def test_slaving_converges():
    """The onset's slaved direction costs an error of order slaving^2 (measured)."""
    disk = _two_plate_disk()
    tight = IntegratorSettings(tolerance=1e-12)
    reference = periodic_motion(disk, 8.2, 7.0, settings=tight, slaving=1e-6).turn_rate
    errors = [abs(periodic_motion(disk, 8.2, 7.0, settings=tight, slaving=s).turn_rate
                  - reference) / abs(reference) for s in (1e-2, 1e-3, 1e-4)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-7


@settings(max_examples=200, deadline=None, derandomize=True)
@given(
    w=st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3).filter(
        lambda w: math.hypot(*w) > 1e-3),
    n=st.floats(0.5, 20.0),
    ck=st.floats(0.05, 1.0),
    kappa=st.floats(0.2, 5.0),
)
# Roots next to a pole, once found by hypothesis: solved for the distance to the pole.
@example(w=[0.0, 1.5485261058550724e-10, 0.25], n=1.0, ck=1.0, kappa=2.0)
@example(w=[0.0, 1.0, 1.1695444993889148e-230], n=3.0, ck=1.0, kappa=0.5)
def test_slaved_direction_is_a_fixed_point_of_the_twist_direction(w, n, ck, kappa):
    """K (W - ck n u) is parallel to u, |u| = 1, and u points into W's orthant."""
    disk = np.array([ck, ck, 9.8, 1.0, 1.0 / kappa, 0.0])
    wrench = np.array([*w, 0.0, 0.0, 0.0])
    u = np.empty(3)
    lam = kernel._slaved_direction(disk, n, wrench, u)
    k = np.array([1.0, 1.0, kappa])
    acceleration = k * (np.array(w) - ck * n * u)
    assert_allclose(np.linalg.norm(u), 1.0, rtol=1e-12)
    assert_allclose(acceleration, lam * u, rtol=0, atol=1e-9 * (np.linalg.norm(w) + ck * n))
    assert np.all(u * np.array(w) >= -1e-12)


def test_slaved_direction_with_isotropic_inertia_is_the_wrench_direction():
    disk = np.array([0.25, 0.25, 9.8, 1.0, 1.0, 0.0])
    wrench = np.array([3.0, -4.0, 1.0, 0.0, 0.0, 0.0])
    u = np.empty(3)
    lam = kernel._slaved_direction(disk, 9.8, wrench, u)
    size = np.linalg.norm(wrench[:3])
    assert_allclose(u, wrench[:3] / size, rtol=1e-13)
    assert_allclose(lam, size - 0.25 * 9.8, rtol=1e-13)


def test_lift_off_stops_the_run_and_is_flagged():
    disk = _two_plate_disk()
    # n = g - a > 0 at the start; the plates' growing response drives it below 0.
    run = simulate_planar(disk, Schedule.constant(14.44, 9.8, 2.0))
    assert run.outcome == "lift_off" and 0.0 < run.end_time < 2.0
    assert run.time.size > 0 and run.time[-1] <= run.end_time
    motion = periodic_motion(disk, 14.44, 9.8)
    assert motion.status == Status.LIFT_OFF and math.isnan(motion.forward_speed)


def test_steady_plate_states_start_without_a_transient():
    """Started on their steady response, the plates' state repeats after one period."""
    disk = _two_plate_disk()
    f, a = 8.2, 1.0  # below threshold: the disk stays stuck, only the plates move
    state = rest_state(disk, drive=(f, a))
    run = simulate_planar(disk, Schedule.constant(f, a, 1 / f), initial_state=state,
                          output_times=[1 / f], settings=IntegratorSettings(tolerance=1e-12))
    assert_allclose(run.final_state[7:], state[7:], rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize(
    ("build", "words"),
    [
        (lambda: Plate(f0=14.44, Q=-1.0, alpha=64.0, M=0.08), ("Q", "> 0")),
        (lambda: Plate(f0=14.44, Q=17.5, alpha=95.0, M=0.08), ("alpha", "[0, 90]")),
        (lambda: Plate(f0=14.44, Q=17.5, alpha=64.0, M=0.08, attachment=(1.0,)),
         ("attachment",)),
        (lambda: Disk(radius=-0.01, plates=(Plate(**PAPER),), cs=0.25), ("radius",)),
        (lambda: Disk(radius=0.02, plates=(Plate(**{**PAPER, "M": 0.7}),
                                            Plate(**{**PAPER, "M": 0.7})), cs=0.25),
         ("sum", "> 1")),
        (lambda: Disk(radius=0.02, plates=(Plate(**PAPER),), cs=0.25, ck=0.3), ("ck",)),
        (lambda: Disk(radius=0.02, plates=(), cs=0.25), ("plates",)),
    ],
)
def test_bad_parameters_are_refused_by_name(build, words):
    with pytest.raises(ValueError) as error:
        build()
    for word in words:
        assert word in str(error.value)


def test_bad_run_arguments_are_refused():
    disk = _two_plate_disk()
    schedule = Schedule.constant(14.2, 7.0, 1.0)
    with pytest.raises(ValueError, match="initial_state must be 11"):
        simulate_planar(disk, schedule, initial_state=np.zeros(4))
    with pytest.raises(ValueError, match="heading_noise"):
        simulate_planar(disk, schedule, heading_noise=-1.0)
    with pytest.raises(ValueError, match="fixed steps"):
        simulate_planar(disk, schedule, settings=IntegratorSettings(steps_per_period=64))
    with pytest.raises(ValueError, match="output_times"):
        simulate_planar(disk, schedule, output_times=[0.5, 2.0])
    with pytest.raises(ValueError, match=r"slaving .* allowed: \(0, 0.1\]"):
        simulate_planar(disk, schedule, slaving=0.0)


def test_contact_margins_match_the_simulated_plates():
    """Rim and normal margins against n and the tilting moment computed from the plate
    states of a simulated run (the plates do not feel the disk: any run will do)."""
    from study.scenes.planar_model import contact_margins

    disk = _two_plate_disk()  # head plate at the rim
    f, a = 14.2, 7.0
    state = rest_state(disk, drive=(f, a))
    times = np.linspace(0.0, 1.0 / f, 4097)
    run = simulate_planar(disk, Schedule.constant(f, a, 1.0 / f), initial_state=state,
                          output_times=times, settings=IntegratorSettings(tolerance=1e-12))
    drive = a * np.cos(2 * math.pi * f * run.time)
    normal = disk.g - drive
    moment = np.zeros((2, times.size))
    for i, plate in enumerate(disk.plates):
        w0 = 2 * math.pi * plate.f0
        tilt = math.radians(plate.alpha)
        delta, rate = run.plate_states[:, i, 0], run.plate_states[:, i, 1]
        vertical = plate.M * math.cos(tilt) * (
            drive * math.cos(tilt) - w0 / plate.Q * rate - w0**2 * delta)
        normal = normal + vertical
        moment += np.outer(plate.attachment, vertical)
    rim = np.min(normal * R / 4 - np.hypot(*moment)) / (disk.g * R / 4)
    expected = contact_margins(disk, f, a, samples=4096)
    assert_allclose(expected, [rim, np.min(normal) / disk.g], rtol=1e-6, atol=1e-9)
    assert expected[0] < 0.0 < expected[1]  # the rim lifts, the disk does not
    # Clamped at the centre, the head plate no longer tilts the disk.
    head, tail = disk.plates
    centred = replace(disk, plates=(replace(head, attachment=(0.0, 0.0)), tail))
    assert contact_margins(centred, f, a)[0] > 0.0

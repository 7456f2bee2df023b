"""Two-way coupled plates on the planar disk: reduction to the single-plate two-way
integrator, the limit M -> 0, the friction paradox and the scene option."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from study.model.disk import Disk, Plate, describe_disk
from study.model.status import Status
from study.model.structure import Structure
from study.scenes.planar_model import periodic_motion
from study.scenes.scene_spec import SceneError, load_scene, parse_scene
from study.solvers.integrator import IntegratorSettings, Schedule, integrated_steady_state, simulate
from study.solvers.planar import EVENT_KINDS, simulate_planar

R = 0.02
PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08}
TIGHT = IntegratorSettings(tolerance=1e-11)


def _one_plate_disk(coupling, ck=None, **plate):
    head = Plate(**{**PAPER, **plate}, direction=0.0, attachment=(R, 0.0), name="head")
    return Disk(radius=R, plates=(head,), cs=0.25, ck=ck, coupling=coupling)


def _two_plate_disk(coupling, M=0.08):
    head = Plate(**{**PAPER, "M": M}, direction=0.0, attachment=(R / 4, 0.0), name="head")
    tail = Plate(f0=7.7, Q=10.0, alpha=64.0, M=M, direction=-90.0, attachment=(-R, 0.0),
                 name="tail")
    return Disk(radius=R, plates=(head, tail), cs=0.25, coupling=coupling)


@pytest.mark.parametrize(("f", "a"), [(14.2, 7.0), (15.2, 7.0), (14.6, 7.0), (13.0, 8.5)])
def test_one_plate_two_way_steady_speed_is_the_1d_two_way_integrators(f, a):
    """Same mean velocity as study.solvers.integrator's two-way model (which waits for the mode's
    transient the same way); no rotation at all. Two-way changes it (by 49 % at 14.2 Hz)."""
    motion = periodic_motion(_one_plate_disk("two-way"), f, a, settings=TIGHT,
                             max_periods=2000)
    line = integrated_steady_state(Structure(**PAPER, cs=0.25), f, a, coupling="two-way",
                                   settings=TIGHT)
    assert motion.status == int(line.status) == Status.STICK_SLIP
    assert_allclose(motion.forward_speed, float(line.velocity), rtol=1e-6)
    assert motion.lateral_speed == 0.0 and motion.turn_rate == 0.0


@pytest.mark.parametrize(("f", "a", "ck"), [(14.2, 7.0, None), (15.2, 7.0, None),
                                            (14.0, 6.0, 0.2)])
def test_one_plate_two_way_transient_is_the_1d_two_way_model(f, a, ck):
    """From rest, the position, velocity and the plate's mode on the 1-D two-way x(t)."""
    disk = _one_plate_disk("two-way", ck)
    structure = Structure(**PAPER, cs=0.25, ck=ck)
    schedule = Schedule(np.array([f, f + 0.5]), np.array([a, a]), np.array([12 / f, 8 / f]))
    times = np.linspace(0.0, float(schedule.ends[-1]), 81)
    planar = simulate_planar(disk, schedule, output_times=times, settings=TIGHT)
    line = simulate(structure, schedule, output_times=times, settings=TIGHT,
                    coupling="two-way")
    assert planar.outcome == line.outcome == "completed"
    scale = structure.g / (2 * math.pi * f) ** 2
    assert_allclose(planar.x, line.x, rtol=0, atol=1e-8 * scale)
    assert_allclose(planar.vx, line.v, rtol=0, atol=1e-7 * scale * 2 * math.pi * f)
    assert_allclose(planar.plate_states[:, 0, 0], line.delta, rtol=0, atol=1e-8 * scale)
    assert np.all(planar.y == 0.0) and np.all(planar.heading == 0.0)
    one_way = simulate_planar(replace(disk, coupling="one-way"), schedule,
                              output_times=times, settings=TIGHT)
    assert np.max(np.abs(one_way.x - planar.x)) > 1e-3 * np.max(np.abs(planar.x))


def test_two_way_tends_to_one_way_as_the_plates_get_light():
    """The plates act on the disk through M: a sliding disk's two-way and one-way motions
    differ by O(M) relative (a tenth of M, a tenth of the gap) and agree to rounding as
    M -> 0. The modes themselves keep feeling the sliding base at any M (the 1-D model's
    ``- x'' sin(alpha)``): their gap does not vanish."""
    schedule = Schedule.constant(8.2, 7.0, 0.15)
    start = np.zeros(7 + 4)
    start[3], start[4], start[5] = 0.03, 0.01, 1.0   # sliding at the start [m s-1, rad s-1]
    gaps, mode_gaps = [], []
    for M in (1e-3, 1e-4, 1e-12):
        runs = [simulate_planar(_two_plate_disk(c, M), schedule, initial_state=start,
                                settings=TIGHT) for c in ("one-way", "two-way")]
        assert [r.outcome for r in runs] == ["completed", "completed"]
        pose = np.stack([np.stack([r.x, r.y, r.heading * R]) for r in runs])
        gaps.append(np.max(np.abs(pose[1] - pose[0])) / np.max(np.abs(pose[0])))
        modes = np.stack([r.plate_states[:, :, 0] for r in runs])
        mode_gaps.append(np.max(np.abs(modes[1] - modes[0])) / np.max(np.abs(modes[0])))
    assert 0.05 < gaps[1] / gaps[0] < 0.2, gaps
    assert gaps[2] < 1e-9, gaps
    assert_allclose(mode_gaps[2], mode_gaps[0], rtol=0.05)
    assert mode_gaps[2] > 0.01


def test_two_way_calibration_commands_stay_on_their_sides():
    """The four commands keep their meaning with two-way plates (README, Steering)."""
    disk = _two_plate_disk("two-way")
    forward, backward, left, right = (periodic_motion(disk, f, 7.0)
                                      for f in (14.2, 15.2, 7.2, 8.2))
    assert forward.forward_speed > 0 > backward.forward_speed
    assert left.turn_rate > 0 > right.turn_rate


def test_friction_paradox_stops_the_run_and_is_flagged():
    """A steep, heavy plate: D = 1 - M sin(alpha) (sin(alpha) + ck cos(alpha)) < 0 for a
    slip along the plate, as in the single-plate two-way model."""
    kwargs = {"M": 1.0, "alpha": 85.0}
    structure = Structure(**{**PAPER, **kwargs}, cs=0.25)
    schedule = Schedule.constant(14.2, 7.0, 1.0)
    assert simulate(structure, schedule, coupling="two-way").outcome == "friction_paradox"
    disk = _one_plate_disk("two-way", **kwargs)
    run = simulate_planar(disk, schedule, max_events=10_000)
    assert run.outcome == "friction_paradox" and run.end_time < 1.0
    assert EVENT_KINDS[int(run.event_kind[-1])] == "friction_paradox"
    motion = periodic_motion(disk, 14.2, 7.0)
    assert motion.status == Status.FRICTION_PARADOX and math.isnan(motion.forward_speed)
    assert simulate_planar(replace(disk, coupling="one-way"), schedule).outcome == "completed"


def test_coupling_is_checked_and_described():
    with pytest.raises(ValueError, match="coupling = 'both' must be one of"):
        _one_plate_disk("both")
    assert "coupling" not in describe_disk(_one_plate_disk("one-way"))
    assert describe_disk(_one_plate_disk("two-way"))["coupling"] == "two-way"


def test_scene_specs_take_the_coupling():
    one_way = load_scene("workflows/steering-calibration.toml")
    two_way = load_scene("workflows/steering-calibration-two-way.toml")
    assert one_way.disk.coupling == "one-way" and two_way.disk.coupling == "two-way"
    assert replace(two_way.disk, coupling="one-way") == one_way.disk
    assert one_way.sha256 != two_way.sha256
    text = one_way.text.replace('cs = 0.25 ', 'coupling = "three-way"\ncs = 0.25 ', 1)
    with pytest.raises(SceneError, match="coupling"):
        parse_scene(text, "bad.toml")

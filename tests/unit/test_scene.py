"""Steering scenes: spec validation, the three kinds end to end, result files."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

from study.cli import main
from study.engine.runner import run_scene
from study.engine.store import ResultError, open_result
from study.scenes.planar_model import periodic_motion, rest_state
from study.scenes.planner import arc_displacement, calibrate_commands, plan_leg
from study.scenes.scene_spec import SceneError, load_scene, parse_scene
from study.solvers.integrator import IntegratorSettings, Schedule
from study.solvers.planar import simulate_planar
from tests.support.tiers import headline

WORKFLOWS = Path(__file__).resolve().parents[2] / "workflows"

DISK = """
[disk]
radius = 0.02
cs = 0.25

[[plate]]
name = "head"
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
direction = 0.0
attachment = [0.02, 0.0]

[[plate]]
name = "tail"
f0 = 7.7
Q = 10.0
alpha = 64.0
M = 0.08
direction = -90.0
attachment = [-0.02, 0.0]
"""

TRAJECTORY = """
[scene]
name = "tiny"
kind = "trajectory"
""" + DISK + """
[trajectory]
sample_interval = 0.1
start = [0.0, 0.0, 90.0]

[[segment]]
label = "forward"
f = 14.2
a = 7.0
duration = 1.0
[[segment]]
label = "left"
f = 7.2
a = 7.0
duration = 1.0
"""


def test_the_workflows_share_one_disk():
    """The three steering workflows describe the same disk (no silent drift)."""
    specs = [load_scene(WORKFLOWS / f"{name}.toml")
             for name in ("steering", "steering-calibration", "steering-plan")]
    assert specs[0].disk == specs[1].disk == specs[2].disk
    assert [s.kind for s in specs] == ["trajectory", "calibration", "plan"]


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (lambda t: t.replace('kind = "trajectory"', 'kind = "trajectroy"'),
         ["kind", "trajectroy", "'trajectory', 'calibration', 'plan'"]),
        (lambda t: t.replace("Q = 17.5", "Q = -17.5"), ["plate", "Q", ">= 0.01"]),
        (lambda t: t.replace("radius = 0.02", "raduis = 0.02"),
         ["raduis", "[disk]", "radius"]),
        (lambda t: t.replace("duration = 1.0\n[[segment]]", "duration = -1.0\n[[segment]]"),
         ["segment #1", "duration"]),
        (lambda t: t.replace("label = \"left\"", "label = \"left\"\nfreq = 7.0"),
         ["freq", "segment #2", "allowed"]),
        (lambda t: t + "\n[calibration]\nf = { values = [8.0] }\na = { values = [7.0] }\n",
         ["[calibration]", "trajectory"]),
        (lambda t: t + "\n[bogus]\nx = 1\n", ["bogus", "allowed"]),
        (lambda t: t.replace("[[segment]]", "[[segmnt]]", 1), ["segmnt"]),
    ],
)
def test_bad_specs_are_refused_with_file_key_and_allowed_values(edit, words):
    with pytest.raises(SceneError) as error:
        parse_scene(edit(TRAJECTORY), "workflows/tiny.toml")
    message = str(error.value)
    assert "workflows/tiny.toml" in message
    for word in words:
        assert word in message


def test_comments_and_key_order_do_not_change_the_hash():
    spec = parse_scene(TRAJECTORY)
    edited = parse_scene("# a comment\n" + TRAJECTORY.replace(
        'name = "head"\nf0 = 14.44', 'f0 = 14.44\nname = "head"'))
    assert spec.sha256 == edited.sha256
    assert parse_scene(TRAJECTORY.replace("a = 7.0\nduration = 1.0\n[[segment]]",
                                          "a = 7.5\nduration = 1.0\n[[segment]]")
                       ).sha256 != spec.sha256


def test_trajectory_scene_end_to_end(tmp_path):
    spec_path = tmp_path / "tiny.toml"
    spec_path.write_text(TRAJECTORY)
    output = tmp_path / "tiny.nc"
    assert main(["run", str(spec_path), "-o", str(output)]) == 0
    data = open_result(output)
    assert data.attrs["study_scene_kind"] == "trajectory"
    units = {name: data[name].attrs["units"] for name in ("x", "y", "heading", "t",
                                                          "heading_change", "plate_alpha",
                                                          "plate_direction")}
    assert units == {"x": "m", "y": "m", "heading": "degree", "t": "s",
                     "heading_change": "degree", "plate_alpha": "degree",
                     "plate_direction": "degree"}
    assert data.attrs["study_scene_format"] == 3
    assert float(data.heading[0]) == 90.0  # the spec's start heading, in degree
    assert list(data.segment_label.values) == ["forward", "left"]
    assert np.all(data.segment_status.values == 0)
    # Segment boundaries are samples, and the summary matches the path there.
    assert 1.0 in data.t.values
    end = data.sel(t=1.0)
    heading0 = 90.0  # degree
    along = (math.cos(math.radians(heading0)) * float(end.x)
             + math.sin(math.radians(heading0)) * float(end.y))
    assert_allclose(float(data.forward_displacement[0]), along, rtol=1e-12, atol=1e-15)
    assert float(data.forward_displacement[0]) > 0.0
    assert float(data.heading_change[1]) > 0.0  # left turn
    # The same run computed directly.
    spec = load_scene(spec_path)
    state = rest_state(spec.disk, (0.0, 0.0, heading0))
    direct = simulate_planar(spec.disk, Schedule(np.array([14.2, 7.2]), np.array([7.0, 7.0]),
                                                 np.array([1.0, 1.0])),
                             initial_state=state, output_times=[2.0], settings=spec.settings,
                             slaving=spec.slaving)
    assert_allclose(float(data.x[-1]), direct.x[-1], rtol=0, atol=1e-12)
    assert_allclose(float(data.heading[-1]), direct.heading[-1], rtol=1e-12)  # both degree
    # Files of scene format 1 (angles in rad) and 2 (heading drift in rad per diameter)
    # are stale, never misread.
    old = Path(shutil.copyfile(output, tmp_path / "old.nc"))
    with netCDF4.Dataset(old, "a") as nc:
        nc.delncattr("study_scene_format")
    with pytest.raises(ResultError, match=r"scene format 1 \(angles in rad\) is stale: this "
                       r"study reads format 3 \(every angle in degree, the heading drift in "
                       r"degree per diameter, spec key heading_drift_deg\); rerun its spec"):
        open_result(old)
    with netCDF4.Dataset(old, "a") as nc:
        nc.setncattr("study_scene_format", np.int64(2))
    with pytest.raises(ResultError, match=r"scene format 2 \(heading drift in rad per "
                       r"diameter, spec key heading_drift\) is stale"):
        open_result(old)
    # A second run is up to date; editing a comment keeps it so.
    assert run_scene(spec_path, output).up_to_date
    spec_path.write_text("# note\n" + TRAJECTORY)
    assert run_scene(spec_path, output).up_to_date
    assert main(["validate", str(output)]) == 0
    assert main(["info", str(output)]) == 0


def test_lift_off_is_a_segment_status_not_a_number(tmp_path):
    text = TRAJECTORY.replace("f = 7.2\na = 7.0", "f = 14.44\na = 9.8")
    spec = parse_scene(text, "lift.toml")
    output = run_scene(spec, tmp_path / "lift.nc").output
    data = open_result(output)
    meanings = data.segment_status.attrs["flag_meanings"].split()
    assert meanings[int(data.segment_status[1])] == "lift_off"
    assert data.attrs["study_outcome"] == "lift_off"
    assert float(data.t[-1]) < 2.0
    assert not np.any(np.isnan(data.x.values))


def test_truncated_and_tampered_scene_files_are_refused(tmp_path):
    spec_path = tmp_path / "tiny.toml"
    spec_path.write_text(TRAJECTORY)
    output = run_scene(spec_path, tmp_path / "tiny.nc").output
    truncated = tmp_path / "truncated.nc"
    truncated.write_bytes(output.read_bytes()[:2000])
    with pytest.raises(ResultError, match="truncated"):
        open_result(truncated)
    data = open_result(output)
    data.attrs["study_spec_sha256"] = "0" * 64
    tampered = tmp_path / "tampered.nc"
    data.to_netcdf(tampered)
    with pytest.raises(ResultError, match="study_spec_sha256"):
        open_result(tampered)
    data = open_result(output)
    del data["x"].attrs["units"]
    data.to_netcdf(tampered)
    with pytest.raises(ResultError, match="units"):
        open_result(tampered)


def test_calibration_scene_matches_periodic_motion(tmp_path):
    text = "[scene]\nname = \"cal\"\nkind = \"calibration\"\n" + DISK + (
        "\n[calibration]\nf = { values = [7.2, 14.2, 14.44] }\na = { values = [2.0, 7.0, 9.8] }\n")
    spec = parse_scene(text, "cal.toml")
    data = open_result(run_scene(spec, tmp_path / "cal.nc").output)
    direct = periodic_motion(spec.disk, 14.2, 7.0, settings=spec.settings)
    assert_allclose(float(data.forward_speed.sel(f=14.2, a=7.0)), direct.forward_speed,
                    rtol=1e-12)
    meanings = data.status.attrs["flag_meanings"].split()
    statuses = {meanings[v] for v in data.status.values.ravel()}
    assert {"static", "stick_slip", "lift_off"} <= statuses
    invalid = np.isin(data.status.values, [3, 4])
    assert np.all(np.isnan(data.turn_rate.values[invalid]))
    assert np.all(np.isfinite(data.turn_rate.values[~invalid]))
    assert np.all(data.turn_rate.values[data.status.values == 0] == 0.0)
    assert data.turn_rate.attrs["units"] == "degree s-1"
    assert_allclose(float(data.turn_rate.sel(f=14.2, a=7.0)), direct.turn_rate,  # degree s-1
                    rtol=1e-12)


def test_arc_displacement_is_the_integral_of_the_body_velocity():
    """Turn rate in degree s-1 (0.3 rad s-1), turn in degree."""
    command = calibrate_commands.__globals__["Command"]("x", 14.2, 7.0, 0.01, 0.002,
                                                        math.degrees(0.3))
    duration = 4.0
    t = np.linspace(0.0, duration, 200_001)
    heading = 0.3 * t  # rad
    vx = command.forward_speed * np.cos(heading) - command.lateral_speed * np.sin(heading)
    vy = command.forward_speed * np.sin(heading) + command.lateral_speed * np.cos(heading)
    trapezoid = [np.trapezoid(vx, t), np.trapezoid(vy, t), math.degrees(heading[-1])]
    assert_allclose(arc_displacement(command, duration), trapezoid, rtol=1e-9, atol=1e-14)


def test_a_planned_leg_ends_on_its_target_in_the_calibrated_model():
    spec = load_scene(WORKFLOWS / "steering-plan.toml")
    commands = calibrate_commands(spec.disk, spec.options["frequencies"],
                                  spec.options["acceleration"],
                                  settings=IntegratorSettings(tolerance=1e-9))
    assert commands["left"].turn_rate > 10.0  # degree s-1 (README: 0.542 rad s-1)
    for target in [(0.05, 0.03), (-0.04, 0.0), (0.0, -0.2)]:
        legs = plan_leg((0.0, 0.0, 17.0), target, commands)  # heading in degree
        assert_allclose(legs[-1].predicted_pose[:2], target, rtol=0, atol=1e-9)
        # Each leg's predicted pose is where its arcs (degree) take the previous one.
        pose = (0.0, 0.0, 17.0)
        for leg in legs:
            for name, span in ((leg.turn, leg.turn_duration),
                               (leg.straight, leg.straight_duration)):
                forward, left, turn = arc_displacement(commands[name], span)
                c, s = math.cos(math.radians(pose[2])), math.sin(math.radians(pose[2]))
                pose = (pose[0] + c * forward - s * left, pose[1] + s * forward + c * left,
                        pose[2] + turn)
            assert_allclose(leg.predicted_pose, pose, rtol=1e-9, atol=1e-12)
            pose = leg.predicted_pose


PLAN = "[scene]\nname = \"plan\"\nkind = \"plan\"\n" + DISK + """
[plan]
acceleration = 7.0
forward = 14.2
backward = 15.2
left = 7.2
right = 8.2
start = [0.0, 0.0, 90.0]
waypoints = [[0.0, 0.03], [0.02, 0.04]]
realisations = 1
seed = 3
"""


def test_plan_scene_reaches_its_waypoints_without_noise(tmp_path):
    spec = parse_scene(PLAN, "plan.toml")
    data = open_result(run_scene(spec, tmp_path / "plan.nc").output)
    miss = data.miss_distance
    assert list(data.strategy_name.values) == ["calibration", "open_loop", "closed_loop"]
    miss = miss.swap_dims(strategy="strategy_name")
    assert np.all(np.isfinite(miss.values))
    # Corrected in the model, the noise-free runs end within a millimetre of each
    # waypoint; the calibration alone does not know the command-switch transients.
    assert float(miss.sel(strategy_name="open_loop", realisation=0).max()) < 1e-3
    assert float(miss.sel(strategy_name="closed_loop", realisation=0).max()) < 1e-3
    assert float(miss.sel(strategy_name="calibration", realisation=0).max()) > 1e-3
    # The noise model's drift: the default, the paper's 0.1 rad, in degree per diameter.
    drift = data.realisation_heading_drift
    assert drift.attrs["units"] == "degree" and list(drift.values) == [0.0, 5.73]
    assert data.attrs["start_heading"] == 90.0 and data.heading.attrs["units"] == "degree"
    assert_allclose(float(data.heading.isel(strategy=0, realisation=0, t=0)), 90.0)
    # After its schedule a run stays put: the last samples repeat.
    assert isinstance(data, xr.Dataset)
    assert float(data.x.isel(t=-1, strategy=0, realisation=0)) == float(
        data.x.isel(t=-2, strategy=0, realisation=0))


def test_a_second_writer_is_refused_while_one_runs(tmp_path):
    from study.engine.runner import StudyBusy
    from study.engine.store import exclusive

    spec = parse_scene(TRAJECTORY, "tiny.toml")
    output = tmp_path / "tiny.nc"
    with exclusive(output), pytest.raises(StudyBusy, match="another run"):
        run_scene(spec, output)
    assert not output.exists()


CALIBRATION = ("[scene]\nname = \"cal\"\nkind = \"calibration\"\n" + DISK
               + "\n[calibration]\nf = { values = [7.2, 14.2] }\na = { values = [7.0] }\n")


@pytest.mark.parametrize(("text", "unit"), headline([
    (TRAJECTORY, "s"),
    (TRAJECTORY.replace("[trajectory]", "[trajectory]\nheading_drift_deg = 5.73"), "s"),
    (CALIBRATION, "pt"),
    (PLAN, "flight"),
], per=lambda text, unit: unit))
def test_a_scene_reports_all_its_work_as_it_runs(text, unit):
    """What the scene reports adds up to the work its progress bar counts, in order, and
    the result is the same with or without a report."""
    from study.scenes.scene_kind import scene_dataset
    from study.scenes.scene_run import scene_work

    spec = parse_scene(text, "scene.toml")
    work, named = scene_work(spec)
    reports: list[float] = []
    data = scene_dataset(spec, reports.append)
    assert named == unit
    assert all(r > 0 for r in reports)
    assert_allclose(math.fsum(reports), work, rtol=1e-12)
    if "heading_drift_deg" in text:  # a kick every drive period: progress all along
        assert len(reports) > 10
    if unit != "flight":  # the plan is checked by its own test; once is enough
        quiet = scene_dataset(spec)
        for name in data.data_vars:
            assert data[name].equals(quiet[name]), name


def test_study_run_shows_a_scene_s_progress_on_request(tmp_path, capsys):
    path = tmp_path / "cal.toml"
    path.write_text(CALIBRATION)
    assert main(["run", str(path), "-o", str(tmp_path / "cal.nc"), "--progress"]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("cal:  50% 1/2 pt") and lines[-1].startswith("cal: 100% 2/2 pt")
    assert lines[-1].endswith("done")
    assert main(["run", str(path), "-o", str(tmp_path / "cal2.nc"), "--no-progress"]) == 0
    assert capsys.readouterr().err == ""

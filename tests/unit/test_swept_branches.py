"""The branches observable (:mod:`study.solvers.sweep_branches`): the branches the slow
sweeps of a study ride, continued over the swept range, written beside the map and
drawn by the branch-diagram figure.

Checked against what it does not use: study.branch called directly from the sweep's own
orbit, and the jumps observable's located folds (hysteresis-flight's, to 1e-9). Its
phase is kept like the frontier's and the fold curves': a rerun reuses it, Ctrl-C keeps
the map. A file without it still draws the other figures.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import shutil
import signal
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.engine.interrupts import RunInterrupted
from study.engine.runner import run_study
from study.engine.spec_files import SpecError
from study.engine.store import open_result
from study.engine.validation import seal
from study.engine.validation.files import validate_file
from study.figures import FigureError, draw_figure
from study.figures import branch_diagram as diagram
from study.model.bifurcations import ENDS, LOCATION_FLAGS, kind_named
from study.solvers import sweep_branches as branches_module
from study.solvers.protocol import slow_sweep
from study.studies.spec import parse_spec
from tests.support.sealed_results import rewrite

ROOT = Path(__file__).resolve().parents[2]
M099 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
FOLD = kind_named("fold").code
DOUBLING = kind_named("period_doubling").code
END = {end.name: end.code for end in ENDS}

SPEC = """
[study]
name = "swept-branches"
observables = [{observables}]
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.99
cs = 0.25
[sweep]
f = {{ start = 14.8, stop = 16.4, num = 17 }}
a = {{ values = [10.0] }}
protocol = {{ along = "f", direction = "{direction}" }}
[solver]
coupling = "{coupling}"
flight = true
"""


def _spec(tmp_path: Path, observables: str = '"velocity", "jumps", "branches"',
          direction: str = "up", coupling: str = "two-way") -> Path:
    path = tmp_path / f"branches-{direction}.toml"
    path.write_text(SPEC.format(observables=observables, direction=direction,
                                coupling=coupling))
    return path


@pytest.fixture(scope="module")
def hysteresis(tmp_path_factory) -> Path:
    """workflows/hysteresis-flight.toml run as make runs it (into a folder of its own)."""
    folder = tmp_path_factory.mktemp("hysteresis")
    spec = folder / "hysteresis-flight.toml"
    shutil.copy(ROOT / "workflows" / "hysteresis-flight.toml", spec)
    run_study(spec, folder / "hysteresis-flight.nc", progress=False, workers=1)
    return folder / "hysteresis-flight.nc"


def _branch(ds, sweep: str, start_f: float, a: float) -> int:
    """The index of the branch of sweep ``sweep`` that settled at ``(start_f, a)``."""
    flags = dict(zip(ds.branch_sweep.attrs["flag_meanings"].split(),
                     ds.branch_sweep.attrs["flag_values"].tolist(), strict=True))
    (found,) = np.flatnonzero((ds.branch_sweep.values == flags[sweep])
                              & np.isclose(ds.branch_start_f.values, start_f, rtol=0,
                                           atol=1e-12)
                              & (ds.branch_start_a.values == a))
    return int(found)


def test_a_written_branch_is_study_branch_from_the_sweeps_orbit(hysteresis):
    ds = open_result(hysteresis)
    assert ds.branch_f.dims == ("branch", "step")
    assert ds.branch_bifurcation_f.dims == ("branch", "bifurcation")
    assert (ds.branch_f.attrs["units"], ds.branch_velocity.attrs["units"],
            ds.branch_bifurcation_a.attrs["units"]) == ("Hz", "m s-1", "m s-2")
    # Swept up at 10 m s-2 the structure rides the forward hop from 12.1 Hz (period 1,
    # after the period-2 orbit of 12 Hz) to 16 Hz and jumps at 16.1 Hz.
    b = _branch(ds, "up", 12.1, 10.0)
    assert int(ds.branch_end.values[b]) == END["turned_back"]
    f = ds.f.values
    lead = slow_sweep(M099, f, [10.0], along="f", direction="up", flight=True)
    last = int(np.flatnonzero(f == 16.0)[0])
    start = dict(start=lead.state.phase_state[last, 0],
                 periods=int(lead.state.orbit_period[last, 0]))
    back = study.branch(M099, 16.0, 10.0, along="f", to=12.1, flight=True, **start)
    on = study.branch(M099, 16.0, 10.0, along="f", to=17.0, flight=True, **start)
    steps = int(ds.branch_steps.values[b])
    assert steps == back.sizes["step"] + on.sizes["step"] - 1
    for written, direct in (("branch_f", "f"), ("branch_a", "a"),
                            ("branch_velocity", "velocity"),
                            ("branch_largest_multiplier", "largest_multiplier"),
                            ("branch_largest_hop", "largest_hop")):
        expected = np.concatenate([back[direct].values[::-1], on[direct].values[1:]])
        assert_allclose(ds[written].values[b, :steps], expected, rtol=1e-12, atol=1e-15,
                        err_msg=written)
    stable = np.concatenate([back.stable.values[::-1], on.stable.values[1:]])
    np.testing.assert_array_equal(ds.branch_stable.values[b, :steps], stable)
    assert np.all(ds.branch_stable.values[b, steps:] == -1)  # no_step past its steps
    assert np.all(np.isnan(ds.branch_f.values[b, steps:]))
    # Its bifurcations: the part traced back's in reverse, then the part traced on's.
    kinds = np.concatenate([back.bifurcation_kind.values[::-1], on.bifurcation_kind.values])
    count = int(ds.branch_bifurcations.values[b])
    np.testing.assert_array_equal(ds.branch_bifurcation_kind.values[b, :count], kinds)
    for written, direct in (("branch_bifurcation_f", "bifurcation_f"),
                            ("branch_bifurcation_velocity", "bifurcation_velocity")):
        expected = np.concatenate([back[direct].values[::-1], on[direct].values])
        assert_allclose(ds[written].values[b, :count], expected, rtol=1e-12, atol=1e-15,
                        err_msg=written)
    n = back.sizes["step"]
    np.testing.assert_array_equal(
        ds.branch_bifurcation_step.values[b, :count],
        np.concatenate([n - 2 - back.bifurcation_step.values[::-1],
                        n - 1 + on.bifurcation_step.values]))
    validate_file(hysteresis)  # raises on a problem


def test_the_written_folds_are_the_located_jumps_of_hysteresis_flight(hysteresis):
    ds = open_result(hysteresis)
    up = ds.sel(direction="up")
    jumps = np.argwhere(up.jumped.values == 1)
    assert len(jumps) == 2  # at 10 and 11 m s-2
    for i_f, i_a in jumps:
        a = float(ds.a.values[i_a])
        jump_f = float(up.jump_f.values[i_f, i_a])
        # The branch the sweep rode to the point before the jump.
        ridden = [b for b in range(ds.sizes["branch"])
                  if ds.branch_start_a.values[b] == a and ds.branch_sweep.values[b] == 0
                  and ds.branch_start_f.values[b] < ds.f.values[i_f]]
        b = max(ridden, key=lambda k: ds.branch_start_f.values[k])
        folds = ds.branch_bifurcation_f.values[b][ds.branch_bifurcation_kind.values[b] == FOLD]
        assert folds.size == 1
        assert_allclose(folds[0], jump_f, rtol=0, atol=1e-9)
    assert_allclose(up.jump_f.sel(a=10.0).max(), 16.0545378, rtol=0, atol=1e-7)


def test_the_branch_diagram_is_drawn_from_the_file(hysteresis, tmp_path, monkeypatch):
    kept = []
    monkeypatch.setattr(diagram, "save", lambda fig, *args: kept.append(fig) or [])
    draw_figure("branch-diagram", open_result(hysteresis), tmp_path / "diagram")
    (fig,) = kept
    ds = open_result(hysteresis)
    # A column per acceleration (9, 10, 11 m s-2), with flight the largest hop below.
    axes = np.array(fig.axes[:6]).reshape(2, 3)
    assert [ax.get_title() for ax in axes[0]] == [f"a = {a:g} m s$^{{-2}}$"
                                                   for a in (9.0, 10.0, 11.0)]
    top = axes[0, 1]
    b = _branch(ds, "up", 12.1, 10.0)
    names = [h.get_label() for h in top.get_legend().legend_handles]
    assert "swept up, from 12.1 Hz" in names
    n = names.index("swept up, from 12.1 Hz")  # its colour index in the column
    lines = {line.get_gid(): line for line in top.get_lines()}
    # Stable up to the fold, dashed past it; the fold marked where the jump is located.
    jump_f = float(ds.jump_f.sel(direction="up", a=10.0).max())
    (fold,) = [line for line in top.get_lines() if line.get_gid() == f"branch {n} fold"]
    assert_allclose(fold.get_xdata(), [jump_f], rtol=0, atol=1e-9)
    solid = [line for line in top.get_lines() if line.get_gid() == f"branch {n} stable"]
    dashed = [line for line in top.get_lines() if line.get_gid() == f"branch {n} unstable"]
    assert solid and dashed and {line.get_linestyle() for line in dashed} == {"--"}
    assert max(line.get_xdata().max() for line in solid) == pytest.approx(jump_f, abs=1e-9)
    assert_allclose(solid[0].get_ydata()[0], 1e3 * ds.branch_velocity.values[b, 0],
                    rtol=1e-12)
    # The located jump ringed, the sweep's jump an arrow from 16 to 16.1 Hz.
    ring = lines["sweep 0 located jump"]
    assert_allclose(ring.get_xdata(), [jump_f], rtol=0, atol=1e-12)
    (arrow,) = [t for t in top.texts if t.get_gid() == "sweep 0 jump"]
    assert arrow.xy[0] == pytest.approx(16.1)
    assert arrow.xyann[1] > 0 > arrow.xy[1]  # from the forward hop to the backward one
    assert "two-way coupling" in fig.get_suptitle() and "M = 0.99" in fig.get_suptitle()
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert {"stable orbit", "unstable orbit", "fold", "jump located (jumps)"} <= set(legend)
    plt.close(fig)


def test_the_folds_at_a_doubled_orbits_birth_are_flagged_not_converged(
        hysteresis, tmp_path, monkeypatch):
    ds = open_result(hysteresis)
    flags = dict(zip(ds.branch_bifurcation_location.attrs["flag_meanings"].split(),
                     ds.branch_bifurcation_location.attrs["flag_values"].tolist(),
                     strict=True))
    assert list(flags) == list(LOCATION_FLAGS)
    kind, location = ds.branch_bifurcation_kind.values, ds.branch_bifurcation_location.values
    assert ((kind == 0) == (location == flags["none"])).all()
    # Every located fold and period doubling has its multiplier at +1 and -1.
    modulus = ds.branch_bifurcation_multiplier_modulus.values
    angle = ds.branch_bifurcation_multiplier_angle.values
    located = location == flags["located"]
    for code, expected in ((FOLD, 0.0), (DOUBLING, 180.0)):
        chosen = located & (kind == code)
        assert chosen.any()
        assert_allclose(modulus[chosen], 1.0, rtol=0, atol=1e-8)
        assert_allclose(angle[chosen], expected, rtol=0, atol=1e-5)
    # The sweep up at 9 m s-2 starts on the hop of period 2; its branch, continued up
    # to where it is born at the period-1 hop's doubling (located on the branch of the
    # sweep down), has no tangent there: the "folds" it reports are not converged.
    b = _branch(ds, "up", 12.0, 9.0)
    assert int(ds.branch_orbit_period.values[b]) == 2
    count = int(ds.branch_bifurcations.values[b])
    folds = kind[b, :count] == FOLD
    assert folds.any() and (location[b, :count][folds] == flags["not_converged"]).all()
    parent = _branch(ds, "down", 17.0, 9.0)
    (doubling,) = np.flatnonzero(kind[parent] == DOUBLING)
    assert location[parent, doubling] == flags["located"]
    assert_allclose(ds.branch_bifurcation_f.values[b, :count][folds],
                    ds.branch_bifurcation_f.values[parent, doubling], rtol=1e-6, atol=0)
    # study.branch flags them the same, and a curve is not continued from one.
    traced = study.branch(M099, 12.0, 9.0, along="f", to=12.7, flight=True)
    unlocated = np.flatnonzero(traced.bifurcation_location.values == flags["not_converged"])
    assert unlocated.size and (traced.bifurcation_kind.values[unlocated] == FOLD).all()
    with pytest.raises(ValueError, match="bifurcation_location is 'not_converged'"):
        study.bifurcation_curve(M099, traced, int(unlocated[0]), to=9.5, num=3)
    # The diagram draws them hollow, the located ones filled.
    kept = []
    monkeypatch.setattr(diagram, "save", lambda fig, *args: kept.append(fig) or [])
    draw_figure("branch-diagram", ds, tmp_path / "diagram")
    (fig,) = kept
    top = fig.axes[0]
    names = [h.get_label() for h in top.get_legend().legend_handles]
    n = names.index("swept up, from 12 Hz")
    (hollow,) = [line for line in top.get_lines()
                 if line.get_gid() == f"branch {n} fold not converged"]
    assert hollow.get_markerfacecolor() == "none"
    assert len(hollow.get_xdata()) == int(folds.sum())
    assert not [line for line in top.get_lines() if line.get_gid() == f"branch {n} fold"]
    plt.close(fig)
    # A file of the branches observable written before the flag stays valid and draws,
    # every bifurcation then filled.
    earlier = rewrite(hysteresis, tmp_path / "earlier.nc",
                      drop=("branch_bifurcation_location",))
    seal(earlier)
    assert validate_file(earlier) == "study result"
    draw_figure("branch-diagram", open_result(earlier), tmp_path / "earlier")
    fig = kept[-1]
    assert [line for line in fig.axes[0].get_lines()
            if line.get_gid() == f"branch {n} fold"]
    plt.close(fig)


def test_the_hysteresis_figure_draws_a_file_with_branches(hysteresis, tmp_path):
    # The branches' own dimensions (branch, step, bifurcation) are not a sweep of the
    # study to select: the figure reads the sweeps' velocity and draws as before.
    ds = open_result(hysteresis)
    assert {"branch", "step", "bifurcation"} <= set(ds.dims)
    paths = draw_figure("hysteresis", ds, tmp_path / "hysteresis")
    assert paths and all(p.exists() and p.stat().st_size > 0 for p in paths)


def test_a_file_without_branches_draws_the_other_figures(tmp_path):
    spec = _spec(tmp_path, observables='"velocity", "jumps"', direction="both")
    run_study(spec, tmp_path / "old.nc", progress=False, workers=1)
    ds = open_result(tmp_path / "old.nc")
    assert "branch_f" not in ds.variables
    paths = draw_figure("hysteresis", ds, tmp_path / "hysteresis")
    assert all(p.exists() for p in paths)
    with pytest.raises(FigureError, match=r"figure 'branch-diagram' needs branch_sweep.*"
                                          r"add 'branches'"):
        draw_figure("branch-diagram", ds, tmp_path / "diagram")


def test_a_diagram_of_more_columns_than_it_draws_says_what_to_select(hysteresis, tmp_path,
                                                                     monkeypatch):
    monkeypatch.setattr(diagram, "MAX_COLUMNS", 2)
    with pytest.raises(FigureError, match=r"a column per value of a, at most 2; .* holds "
                                          r"3: select one or a few, e.g. --sel a=10 or "
                                          r"--sel a=9:10"):
        draw_figure("branch-diagram", open_result(hysteresis), tmp_path / "diagram")
    kept = []
    monkeypatch.setattr(diagram, "save", lambda fig, *args: kept.append(fig) or [])
    draw_figure("branch-diagram", open_result(hysteresis), tmp_path / "one",
                sel=["a=10"])
    (fig,) = kept
    assert fig.axes[0].get_title() == "a = 10 m s$^{-2}$" and "selected: a=10" in (
        fig.get_suptitle())
    plt.close(fig)


def test_a_rerun_reuses_the_branches_and_compute_map_gives_the_same(tmp_path, capsys):
    spec, cache = _spec(tmp_path), tmp_path / "cache"
    run_study(spec, tmp_path / "first.nc", cache=cache, progress=False, workers=1)
    run_study(spec, tmp_path / "second.nc", cache=cache, progress=True, workers=1)
    assert "branches of 1 of 1 structures reused" in capsys.readouterr().err
    first, second = open_result(tmp_path / "first.nc"), open_result(tmp_path / "second.nc")
    in_memory = study.compute_map(M099, np.linspace(14.8, 16.4, 17), [10.0],
                                  observables=["velocity", "jumps", "branches"],
                                  coupling="two-way", flight=True,
                                  protocol={"along": "f", "direction": "up"})
    for name in [v for v in first.data_vars if str(v).startswith("branch_")]:
        for other in (second, in_memory):
            np.testing.assert_array_equal(first[name].values, other[name].values,
                                          err_msg=name)
    # Two pieces: the forward hop to 16 Hz, the backward hop from 16.1 Hz.
    assert_allclose(first.branch_start_f.values, [14.8, 16.1], rtol=0, atol=1e-12)
    assert first.branch_end.values.tolist() == [END["turned_back"], END["reached"]]


def test_a_spec_without_a_protocol_or_the_two_way_solver_is_refused(tmp_path):
    text = SPEC.format(observables='"velocity", "branches"', direction="up",
                       coupling="two-way")
    with pytest.raises(SpecError, match=r'observable "branches" needs \[sweep\] protocol'):
        parse_spec(text.replace('protocol = { along = "f", direction = "up" }', ""),
                   "no-protocol.toml")
    with pytest.raises(SpecError, match=r'observable "branches" needs \[solver\] '
                                        r'coupling = "two-way"'):
        parse_spec(text.replace('coupling = "two-way"', 'coupling = "one-way"')
                   .replace("flight = true", ""), "one-way.toml")


def test_ctrl_c_in_the_branches_phase_keeps_the_map_and_the_rerun_finishes(
        tmp_path, monkeypatch, python_sigint):
    original = branches_module.trace

    def interrupting(*args, **kwargs):
        traced = original(*args, **kwargs)
        signal.raise_signal(signal.SIGINT)  # as Ctrl-C, after the first trace
        return traced

    monkeypatch.setattr(branches_module, "trace", interrupting)
    spec, output, cache = _spec(tmp_path), tmp_path / "stop.nc", tmp_path / "cache"
    with pytest.raises(RunInterrupted) as stopped:
        run_study(spec, output, cache=cache, progress=False, workers=1)
    assert stopped.value.kept == stopped.value.points == 17
    assert not output.exists()
    monkeypatch.undo()
    report = run_study(spec, output, cache=cache, progress=False, workers=1)
    assert (report.points_reused, report.points_computed) == (17, 0)
    assert open_result(output).branch_steps.values.min() > 0


def test_the_branches_of_several_structures_are_each_ones_own_padded(tmp_path):
    """Over M = 0.95 and 0.99 each structure's branches are those of a study of it
    alone, padded to the most branches, steps and bifurcations of either (sweep none,
    NaN, no_step, kind none past its own)."""
    text = SPEC.format(observables='"velocity", "branches"', direction="both",
                       coupling="two-way").replace(
        "M = 0.99\n", "").replace("[sweep]\n", "[sweep]\nM = { values = [0.95, 0.99] }\n")
    (tmp_path / "both.toml").write_text(text)
    run_study(tmp_path / "both.toml", tmp_path / "both.nc", progress=False, workers=1)
    both = open_result(tmp_path / "both.nc")
    assert both.branch_f.dims == ("M", "branch", "step")
    validate_file(tmp_path / "both.nc")
    for k, m in enumerate((0.95, 0.99)):
        (tmp_path / f"one-{k}.toml").write_text(
            SPEC.format(observables='"velocity", "branches"', direction="both",
                        coupling="two-way").replace("M = 0.99", f"M = {m}"))
        run_study(tmp_path / f"one-{k}.toml", tmp_path / f"one-{k}.nc", progress=False,
                  workers=1)
        alone, here = open_result(tmp_path / f"one-{k}.nc"), both.isel(M=k)
        for name in [v for v in alone.data_vars if str(v).startswith("branch_")]:
            own = alone[name].values
            np.testing.assert_array_equal(here[name].values[tuple(slice(0, n) for n in
                                                                   own.shape)], own,
                                          err_msg=name)
        extra = slice(alone.sizes["branch"], None)
        assert np.all(here.branch_sweep.values[extra] == -1)
        assert np.all(here.branch_stable.values[extra] == -1)
        assert np.all(np.isnan(here.branch_f.values[extra]))
        assert np.all(here.branch_stable.values[:, alone.sizes["step"]:] == -1)
        assert np.all(here.branch_bifurcation_kind.values[:, alone.sizes["bifurcation"]:]
                      == 0)


def test_a_phase_whose_blocks_miss_a_variable_is_a_declaration_error():
    from dataclasses import replace

    from study.studies.observables import OBSERVABLES
    from study.studies.phases import FoldCurvesPhase, PhaseInput, phase_blocks

    declared = OBSERVABLES["fold_curves"]
    observable = replace(declared, variables=(*declared.variables, "branch_f"))
    item = PhaseInput((), M099, np.array([15.0, 16.0]), np.array([10.0]), None, None, {})
    with pytest.raises(RuntimeError, match=r"missing: branch_f\): extend "
                                           r"FoldCurvesPhase.blocks"):
        phase_blocks(FoldCurvesPhase(observable), item, "code")

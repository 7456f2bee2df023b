"""The impact law of the base on the table (study.kernels.impact, study.solvers.impact),
against things that share no code with it: the momentum balance and the kinetic energy
of base and plate written from the Lagrangian, a step-by-step numerical integration of
Darboux-Keller with the mass matrix inverted numerically, the stick cone, the mirror
alpha -> -alpha, the rigid block of M -> 0, and finite differences for the Jacobian."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.kernels import impact as kernel
from study.model.codes import IMPACT_PARADOX, IMPACT_SLIP, IMPACT_STICK
from study.model.inputs import InputTypeError
from study.model.structure import tilt_warnings
from study.solvers.impact import impact
from study.solvers.structure_constants import structure_vector


def structure(alpha, M, cs, ck, restitution=0.0):
    with tilt_warnings(False):  # small tilts are part of the space, in degree
        return study.Structure(f0=20.0, Q=10.0, alpha=alpha, M=M, cs=cs, ck=ck,
                               restitution=restitution)


def random_structure(rng, restitution=None):
    """M uniform on (0, 0.999) or close to 1 (half each), alpha in (-89, 89) degree,
    cs >= ck, the restitution uniform on [0, 1] unless given."""
    if rng.random() < 0.5:
        M = 1.0 - 10.0 ** rng.uniform(-3.0, 0.0)
    else:
        M = rng.uniform(1e-6, 0.999)
    cs = rng.uniform(0.02, 2.0)
    e = rng.uniform(0.0, 1.0) if restitution is None else restitution
    return structure(rng.uniform(-89.0, 89.0), M, cs, cs * rng.uniform(0.05, 1.0), e)


def random_velocities(rng, count):
    """delta', v, h' before an impact [m s-1]; the first v exactly 0 (lands at rest)."""
    velocity = rng.normal(size=count)
    velocity[0] = 0.0
    return rng.normal(size=count), velocity, -(10.0 ** rng.uniform(-3.0, 0.5, count))


def tilt(s):
    return math.sin(math.radians(s.alpha)), math.cos(math.radians(s.alpha))


def kinetic_energy(s, delta_rate, velocity, gap_rate):
    """T = (1-M)|V|^2/2 + M|V + delta' e|^2/2 per unit total mass, V = (v, h') [m2 s-2]."""
    sa, ca = tilt(s)
    plate = (velocity + delta_rate * sa) ** 2 + (gap_rate + delta_rate * ca) ** 2
    return (1.0 - s.M) * (velocity ** 2 + gap_rate ** 2) / 2 + s.M * plate / 2


def momenta(s, delta_rate, velocity, gap_rate):
    """Total momentum of base and plate, horizontal and vertical (table frame), and the
    plate's velocity along e [m s-1]."""
    sa, ca = tilt(s)
    return (velocity + s.M * sa * delta_rate, gap_rate + s.M * ca * delta_rate,
            sa * velocity + ca * gap_rate + delta_rate)


def random_impacts(seed, structures, per_structure, restitution=None):
    rng = np.random.default_rng(seed)
    for _ in range(structures):
        s = random_structure(rng, restitution)
        before = random_velocities(rng, per_structure)
        yield s, before, impact(s, *before)


# (a) conservation on random impacts -----------------------------------------------------

def test_momentum_balance_and_plate_velocity_on_random_impacts():
    """Horizontal momentum of base + plate changes by Px, vertical by Pz, the plate's
    velocity along e is continuous, h'+ = -e h'-, Pz > 0 and |Px| <= cs Pz."""
    checked = 0
    for s, before, after in random_impacts(1, 1500, 4):
        ok = after.outcome != IMPACT_PARADOX
        if not ok.any():
            continue
        d, v, h = (x[ok] for x in before)
        px, pz = after.tangential_impulse[ok], after.normal_impulse[ok]
        post = (after.delta_rate[ok], after.velocity[ok], after.gap_rate[ok])
        scale = np.abs(d) + np.abs(v) + np.abs(h)
        jump = [b - a for a, b in zip(momenta(s, d, v, h), momenta(s, *post), strict=True)]
        assert_allclose(jump[0] - px, 0.0, rtol=0, atol=1e-14 * scale.max() * 4)
        assert_allclose(jump[1] - pz, 0.0, rtol=0, atol=1e-14 * scale.max() * 4)
        assert_allclose(jump[2], 0.0, rtol=0, atol=1e-14 * scale.max() * 4)
        assert_allclose(post[2], -s.restitution * h, rtol=1e-15, atol=0)
        assert np.all(pz > 0)
        assert np.all(np.abs(px) <= s.cs * pz * (1 + 1e-12))
        checked += ok.sum()
    assert checked > 5000


def test_no_plastic_impact_gains_kinetic_energy():
    largest = -np.inf
    for s, before, after in random_impacts(2, 1500, 4, restitution=0.0):
        ok = after.outcome != IMPACT_PARADOX
        t_before = kinetic_energy(s, *(x[ok] for x in before))
        t_after = kinetic_energy(s, after.delta_rate[ok], after.velocity[ok],
                                 after.gap_rate[ok])
        if ok.any():
            largest = max(largest, np.max((t_after - t_before) / t_before))
    assert largest <= 1e-13


def test_no_impact_without_a_switch_gains_energy_whatever_the_restitution():
    """With one phase (slides or sticks throughout) the normal impulse's work is
    p (1 - e) h'- / 2 <= 0 and friction's is <= 0. With a switch (slide stops, then
    stick or slide back) Newton's kinematic law may give back more than compression took
    (Kane's paradox): the law is the one asked for (h'+ = -e h'-), and this is where it
    can gain energy, so the test says where it cannot."""
    gains = {True: 0, False: 0}
    out = np.empty(kernel.IMPACT_SIZE)
    for s, before, after in random_impacts(3, 1500, 4):
        vector = structure_vector(s, "two-way")
        for i in range(before[0].size):
            if after.outcome[i] == IMPACT_PARADOX:
                continue
            kernel.impact(vector, before[0][i], before[1][i], before[2][i], out)
            switched = out[kernel.IMPACT_STOP_IMPULSE] > 0.0  # NaN: slid throughout
            t0 = kinetic_energy(s, *(x[i] for x in before))
            t1 = kinetic_energy(s, after.delta_rate[i], after.velocity[i], after.gap_rate[i])
            if t1 > t0 * (1 + 1e-13):
                gains[switched] += 1
    assert gains[False] == 0
    assert gains[True] > 0  # the documented exception exists (else the comment is wrong)


# (b) a step-by-step integration of Darboux-Keller ---------------------------------------

def darboux_keller_steps(s, delta_rate, velocity, gap_rate, steps):
    """Integrate the impact along the normal impulse in small steps (first order).

    The base's velocity response to an impulse comes from inverting the mass matrix of
    (X, Z, delta) numerically. Each step is a Moreau step: the tangential impulse that
    would stop the base, if the cone allows it (cs at rest, ck sliding), else ck along
    it. Returns delta', v, h' after, Pz, Px and a bound of the error of one step in a
    velocity [m s-1] and in an impulse [m s-1].
    """
    sa, ca = tilt(s)
    M = s.M
    mass = np.array([[1.0, 0.0, M * sa], [0.0, 1.0, M * ca], [M * sa, M * ca, M]])
    response = np.linalg.inv(mass)
    gxx, gxz, gzx, gzz = (float(response[i, j]) for i, j in ((0, 0), (0, 1), (1, 0), (1, 1)))
    gdx, gdz = float(response[2, 0]), float(response[2, 1])
    target = -s.restitution * gap_rate
    # The rise of h' per unit normal impulse: at rest, sliding forward, backward.
    rates = (gzz - gzx * gxz / gxx, gzz - s.ck * gzx, gzz + s.ck * gzx)
    step = (target - gap_rate) / (steps * max(rates))
    dp = step
    vd, vx, vz, pz, px = delta_rate, velocity, gap_rate, 0.0, 0.0
    for _ in range(100 * steps):
        for last in (False, True):
            trial = -(vx + gxz * dp) / gxx
            bound = (s.ck if vx != 0.0 else s.cs) * dp
            dpx = trial if abs(trial) <= bound else math.copysign(s.ck * dp, trial)
            rise = gzx * dpx + gzz * dp
            if last or vz + rise <= target:
                break
            dp *= (target - vz) / rise  # the last step ends the impact
        vx = 0.0 if dpx == trial else vx + gxx * dpx + gxz * dp
        vz += rise
        vd += gdx * dpx + gdz * dp
        pz += dp
        px += dpx
        if last:
            return vd, vx, target, pz, px, step * (gxx * s.cs + abs(gxz)), step * (1 + s.cs)
    raise AssertionError("the step-by-step impact did not end")


def test_closed_form_agrees_with_step_by_step_darboux_keller():
    rng = np.random.default_rng(4)
    compared = {"stick": 0, "slide": 0, "slide back": 0}
    out = np.empty(kernel.IMPACT_SIZE)
    for _ in range(300):
        s = random_structure(rng)
        sa, ca = tilt(s)
        slides = [1.0 - s.M * sa * (sa + sign * s.ck * ca) for sign in (1.0, -1.0)]
        if s.M < 0.01 or min(slides) < 0.05:  # a singular mass matrix; too many steps
            continue
        d, v, h = (x[0] for x in random_velocities(rng, 1))
        v = rng.normal() * 0.3 if rng.random() < 0.7 else 0.0
        code = kernel.impact(structure_vector(s, "two-way"), d, v, h, out)
        if code == IMPACT_PARADOX:
            continue
        vd, vx, vz, pz, px, velocity_step, impulse_step = darboux_keller_steps(
            s, d, v, h, 3000)
        # First order: the switch is found within a step (a few steps' error at most).
        scale = 1e-12 * (abs(h) + abs(v) + abs(d))
        assert_allclose([out[kernel.IMPACT_DELTA_RATE], out[kernel.IMPACT_VELOCITY]],
                        [vd, vx], rtol=0, atol=5 * velocity_step + scale)
        assert_allclose(out[kernel.IMPACT_GAP_RATE], vz, rtol=1e-12, atol=1e-15)
        assert_allclose(
            [out[kernel.IMPACT_NORMAL_IMPULSE], out[kernel.IMPACT_TANGENTIAL_IMPULSE]],
            [pz, px], rtol=0, atol=5 * impulse_step + scale)
        stopped = not math.isnan(out[kernel.IMPACT_STOP_IMPULSE])
        branch = "stick" if code == IMPACT_STICK else ("slide back" if stopped and v else "slide")
        compared[branch] += 1
    assert min(compared.values()) >= 5, compared


# (c) the stick cone ---------------------------------------------------------------------

def impact_matrix(s):
    """W: the base's velocity jump per unit impulse, from the mass matrix of
    (X, Z, delta) inverted numerically."""
    sa, ca = tilt(s)
    M = s.M
    mass = np.array([[1.0, 0.0, M * sa], [0.0, 1.0, M * ca], [M * sa, M * ca, M]])
    return np.linalg.inv(mass)[:2, :2]


@pytest.mark.parametrize(("alpha", "M"), [(30.0, 0.5), (-60.0, 0.9), (5.0, 0.2), (-80.0, 0.99)])
@pytest.mark.parametrize("landing", ["at rest", "sliding"])
def test_stick_criterion_is_the_ratio_of_the_impact_matrix(alpha, M, landing):
    """|W_xz / W_xx| = cs (1 +- 1e-9): at rest after the slide stops (or from the start)
    above, sliding on in the direction of W_xz below."""
    ratio = abs(impact_matrix(structure(alpha, M, 1.0, 1.0))[0, 1]
                / impact_matrix(structure(alpha, M, 1.0, 1.0))[0, 0])
    w_sign = math.copysign(1.0, alpha)  # sign of W_xz = M sa ca / (1 - M)
    velocity = 0.0 if landing == "at rest" else -w_sign * 1e-3
    for factor, expected in ((1 + 1e-9, IMPACT_STICK), (1 - 1e-9, IMPACT_SLIP)):
        cs = ratio * factor
        after = impact(structure(alpha, M, cs, 0.5 * cs), 0.2, velocity, -1.0)
        assert after.outcome == expected
        if expected == IMPACT_STICK:
            assert after.velocity == 0.0
            if landing == "at rest":  # stuck throughout: Px = -W_xz / W_xx Pz
                assert_allclose(after.tangential_impulse, -w_sign * ratio * after.normal_impulse,
                                rtol=1e-12, atol=0)
        else:
            assert math.copysign(1.0, after.velocity) == w_sign
            assert abs(after.velocity) > 1e-3


# (d) Painleve's paradox -----------------------------------------------------------------

def test_paradox_where_the_slide_that_arises_has_no_positive_normal_mass():
    s = structure(60.0, 0.9, 1.0, 1.0)  # D_+ = 1 - M sa (sa + ck ca) = -0.065
    after = impact(s, [0.1, 0.1, 0.1], [0.5, -0.5, 0.0], -1.0)
    assert list(after.outcome) == [IMPACT_PARADOX, IMPACT_STICK, IMPACT_STICK]
    for name in ("delta_rate", "velocity", "gap_rate", "normal_impulse",
                 "tangential_impulse"):
        values = getattr(after, name)
        assert math.isnan(values[0]) and np.all(np.isfinite(values[1:])), name


def test_paradox_exactly_when_the_first_slide_has_d_s_not_positive():
    """A slide from rest (or back after a stop) never meets the paradox: it arises only
    when |W_xz| > cs W_xx, and then D_s' / (1 - M) = W_zz - ck |W_xz| > det W / W_xx > 0."""
    paradoxes = 0
    for s, before, after in random_impacts(5, 1500, 4):
        sa, ca = tilt(s)
        velocity = before[1]
        d_s = 1.0 - s.M * sa * (sa + np.sign(velocity) * s.ck * ca)
        expected = (velocity != 0.0) & (d_s <= 0.0)
        assert np.array_equal(after.outcome == IMPACT_PARADOX, expected)
        paradoxes += expected.sum()
    assert paradoxes > 20


# (e) mirror -----------------------------------------------------------------------------

def test_mirror_alpha_reverses_velocity_and_tangential_impulse():
    rng = np.random.default_rng(6)
    for _ in range(300):
        s = random_structure(rng)
        mirrored = structure(-s.alpha, s.M, s.cs, s.ck, s.restitution)
        d, v, h = random_velocities(rng, 4)
        one, other = impact(s, d, v, h), impact(mirrored, d, -v, h)
        assert np.array_equal(one.outcome, other.outcome)
        ok = one.outcome != IMPACT_PARADOX
        for name, sign in (("delta_rate", 1), ("velocity", -1), ("gap_rate", 1),
                           ("normal_impulse", 1), ("tangential_impulse", -1)):
            assert_allclose(getattr(other, name)[ok], sign * getattr(one, name)[ok],
                            rtol=1e-14, atol=1e-300, err_msg=name)


# (f) M -> 0: a rigid block --------------------------------------------------------------

def test_small_mass_ratio_is_a_rigid_block():
    """Pz = (1 + e) |h'-|; v unchanged but for friction ck Pz, which may stop it."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        cs = rng.uniform(0.02, 2.0)
        ck = cs * rng.uniform(0.05, 1.0)
        e = rng.uniform(0.0, 1.0)
        s = structure(rng.uniform(-89, 89), 1e-12, cs, ck, e)
        d, v, h = random_velocities(rng, 6)
        pz = -(1 + e) * h
        stops = np.abs(v) <= ck * pz
        block_v = np.where(stops, 0.0, v - np.sign(v) * ck * pz)
        after = impact(s, d, v, h)
        assert_allclose(after.velocity, block_v, rtol=0, atol=1e-10)
        assert_allclose(after.gap_rate, -e * h, rtol=1e-15, atol=0)
        assert_allclose(after.normal_impulse, pz, rtol=1e-10, atol=0)
        assert_allclose(after.tangential_impulse, block_v - v, rtol=0, atol=1e-10)
        assert np.array_equal(after.outcome, np.where(stops, IMPACT_STICK, IMPACT_SLIP))


# (g) why not the tempting shortcut ------------------------------------------------------

def shortcut(s, delta_rate, velocity, gap_rate):
    """The tempting shortcut: the plate keeps its absolute velocity (only its part
    along e can be kept by the one-mode model), Coulomb acts on the base alone (mass
    1 - M). Returns delta', v, h' after and Px, Pz."""
    sa, ca = tilt(s)
    base = 1.0 - s.M
    pz = -base * (1 + s.restitution) * gap_rate
    friction = s.ck * pz / base  # the horizontal speed friction can take from the base
    v_after = np.where(np.abs(velocity) <= friction, 0.0,
                       velocity - np.sign(velocity) * friction)
    gap_after = -s.restitution * gap_rate
    delta_after = delta_rate - (sa * (v_after - velocity) + ca * (gap_after - gap_rate))
    return delta_after, v_after, gap_after, base * (v_after - velocity), pz


def test_the_shortcut_breaks_momentum_and_gains_energy_where_the_law_does_not():
    shortcut_residual = ours_residual = 0.0
    shortcut_gains = ours_gains = 0
    largest_gain = 0.0
    for s, before, after in random_impacts(8, 1000, 4, restitution=0.0):
        ok = after.outcome != IMPACT_PARADOX
        d, v, h = (x[ok] for x in before)
        scale = np.abs(d) + np.abs(v) + np.abs(h)
        t0 = kinetic_energy(s, d, v, h)
        for post, px, ours in (
                ((after.delta_rate[ok], after.velocity[ok], after.gap_rate[ok]),
                 after.tangential_impulse[ok], True),
                (shortcut(s, d, v, h)[:3], shortcut(s, d, v, h)[3], False)):
            residual = np.abs(momenta(s, *post)[0] - momenta(s, d, v, h)[0] - px) / scale
            gain = (kinetic_energy(s, *post) - t0) / t0
            if ours:
                ours_residual = max(ours_residual, residual.max(initial=0.0))
                ours_gains += int(np.sum(gain > 1e-13))
            else:
                shortcut_residual = max(shortcut_residual, residual.max(initial=0.0))
                shortcut_gains += int(np.sum(gain > 1e-9))
                largest_gain = max(largest_gain, gain.max(initial=0.0))
    assert ours_residual < 1e-13 and ours_gains == 0
    assert shortcut_residual > 0.1
    assert shortcut_gains > 100 and largest_gain > 0.5  # T grows by half somewhere


# the Jacobian ---------------------------------------------------------------------------

def test_jacobian_is_the_derivative_on_the_branch():
    """Central differences of the kernel (linear on a branch, so exact but for
    rounding) where both neighbours stay on the branch; at rest the stick's Jacobian."""
    rng = np.random.default_rng(9)
    out = np.empty(kernel.IMPACT_SIZE)
    jac = np.empty((3, 3))
    branches = set()

    def after(vector, state):
        code = kernel.impact(vector, *state, out)
        return code, math.isnan(out[kernel.IMPACT_STOP_IMPULSE]), out[:3].copy()

    for _ in range(400):
        s = random_structure(rng)
        vector = structure_vector(s, "two-way")
        d, _, h = random_velocities(rng, 1)
        state = np.array([d[0], rng.normal(), h[0]])
        code, slid, _ = after(vector, state)
        if code == IMPACT_PARADOX:
            continue
        assert kernel.impact_jacobian(vector, *state, jac) == code
        step = 1e-7 * np.abs(state).max()
        numeric = np.empty((3, 3))
        for column in range(3):
            shift = np.zeros(3)
            shift[column] = step
            (c1, s1, plus), (c2, s2, minus) = after(vector, state + shift), after(
                vector, state - shift)
            if (c1, s1) != (code, slid) or (c2, s2) != (code, slid):
                break
            numeric[:, column] = (plus - minus) / (2 * step)
        else:
            assert_allclose(jac, numeric, rtol=1e-5, atol=1e-5 * (1 + np.abs(jac).max()))
            branches.add((code, slid))
    assert branches == {(IMPACT_STICK, False), (IMPACT_SLIP, True), (IMPACT_SLIP, False)}
    sa, ca = tilt(s)
    e = s.restitution
    kernel.impact_jacobian(vector, 0.3, 0.0, -1.0, jac)
    if abs(impact_matrix(s)[0, 1]) <= s.cs * impact_matrix(s)[0, 0]:
        assert_allclose(jac, [[1, sa, ca * (1 + e)], [0, 0, 0], [0, 0, -e]], rtol=1e-14,
                        atol=1e-15)


# the wrapper ----------------------------------------------------------------------------

def test_wrapper_broadcasts_and_returns_scalars_for_scalars():
    s = structure(30.0, 0.5, 0.6, 0.4)
    grid = impact(s, np.zeros((2, 1)), [0.1, -0.1, 0.0], -1.0)
    assert grid.velocity.shape == grid.outcome.shape == (2, 3)
    assert grid.outcome.dtype == np.int8
    one = impact(s, 0.0, -0.1, -1.0)
    assert np.ndim(one.velocity) == 0 and one.velocity == grid.velocity[1, 1]
    assert one.outcome == grid.outcome[0, 1]


@pytest.mark.parametrize(("arguments", "error", "words"), [
    ((0.0, 0.0, 0.5), ValueError, ("gap_rate", "< 0", "approaching")),
    ((0.0, 0.0, [-1.0, 0.0]), ValueError, ("gap_rate", "< 0")),
    ((0.0, [0.0, 1.0, 2.0], [-1.0, -2.0]), ValueError, ("broadcast", "velocity", "gap_rate")),
    ((math.nan, 0.0, -1.0), ValueError, ("delta_rate", "finite")),
    ((0.0, "1", -1.0), InputTypeError, ("velocity",)),
])
def test_wrapper_refuses_bad_velocities(arguments, error, words):
    with pytest.raises(error) as caught:
        impact(structure(30.0, 0.5, 0.6, 0.4), *arguments)
    assert all(word in str(caught.value) for word in words), str(caught.value)


def test_wrapper_refuses_a_massless_base_and_a_non_structure():
    with pytest.raises(ValueError, match=r"M = 1\.0.*M < 1.*massless base.*unbounded"):
        impact(structure(30.0, 1.0, 0.6, 0.4), 0.0, 0.0, -1.0)
    with pytest.raises(InputTypeError, match="structure"):
        impact({"M": 0.5}, 0.0, 0.0, -1.0)

"""Slow, high-accuracy reference integrator for the planar (2-D) steering model.

Like :mod:`tests.reference.integrator` (the 1-D model), this module is an *independent*
check of the package: it imports nothing from ``study`` and uses no closed form of
the motion. The hybrid stick / slip system is integrated numerically with scipy's
``DOP853`` (explicit, order 8, dense output of order 7) and, only where the
problem is stiff (the first instants of a slip), ``Radau`` (implicit, order 5),
driving the solver objects step by step so that every step is inspected for
events on its dense output, and restarting at every event with the new contact
mode.

Model (per unit total mass, SI units, table frame)
--------------------------------------------------
A rigid disk, pose ``(x, y, theta)`` in the world frame; body frame: forward =
heading, left = heading + 90 degree. Drive acceleration ``A(t) = a_k cos(phi(t))`` in
segment ``k`` of the schedule, with the phase ``phi`` continuous, ``phi(0) = phase``
and ``dphi/dt = 2 pi f_k``. Plate ``i`` (resonance ``f0``, ``w = 2 pi f0``, quality
factor ``Q``, tilt ``alpha``, mass ratio ``M``, body-frame direction ``beta``, so
``e_i = (cos beta, sin beta)``, attachment ``r_i = (r_forward, r_left)``, lever
``l_i = r_forward sin(beta) - r_left cos(beta)``):

* mode (one-way): ``delta_i'' = F_i = A cos(alpha_i) - (w_i/Q_i) delta_i' - w_i^2 delta_i``;
* normal force ``n = g - A + sum_i M_i cos(alpha_i) F_i``;
* body-frame force ``f_b = sum_i (-M_i sin(alpha_i) F_i) e_i``, torque
  ``T = sum_i (-M_i sin(alpha_i) F_i) l_i``; world force ``f_w = R(theta) f_b``;
* scaled twist ``u = (vx, vy, c spin)``, scaled wrench ``W = (f_w, T / c)``,
  ``K = diag(1, 1, kappa)``, ``kappa = c^2 / rho^2`` (``c`` friction length, default
  ``2 R / 3``; ``rho`` gyration radius, default ``R / sqrt(2)``);
* stick (``u = 0``, pose frozen) while ``|W| <= cs n``;
* slip: ``u' = K (W - ck n u / |u|)``, ``(x, y, theta)' = (u_1, u_2, u_3 / c)``,
  path ``s' = |(u_1, u_2)|``;
* lift-off (``n < 0``) ends the run.

Why the slip is integrated in two phases
----------------------------------------
The slip equation is singular at ``u = 0``: ``u / |u|`` is undefined there and its
derivatives grow like ``1 / |u|``. Write ``u = r e`` with ``|e| = 1``. Then

    r' = e . a,        e' = (a - (e . a) e) / r,        a = K (W - ck n e).

**Contraction.** Two slips under the same wrench satisfy
``d/dt [(u1 - u2) . K^-1 (u1 - u2)] = -2 ck n (u1 - u2) . (e1 - e2) <= 0`` (the map
``u -> u / |u|`` is monotone): a perturbation of the twist is not amplified during
a slip, up to a factor ``sqrt(max(1, kappa) / min(1, kappa))`` between norms and the
slow coupling through the heading in ``R(theta)``. This is what makes the start of a
slip from a tiny seed legitimate and its error controllable.

**Slip onset** (phase "A"). At a release (``|W| = cs n``) or at a slip end with
``|W| > cs n`` the slip starts from ``u = 0`` along the onset direction
``e*_j = W_j / (lambda / K_j + ck n)``, ``lambda >= 0`` with ``|e*| = 1`` (Brent's method:
``sum_j W_j^2 / (lambda / K_j + ck n)^2`` decreases in ``lambda``). There
``K (W - ck n e*) = lambda e*``, and ``e*`` attracts the direction as ``r`` grows (the
transverse part of ``e - e*`` decays like a negative power of ``r``). The reference
seeds ``r = r_seed = 1e-2 rtol V`` (``V = g / w``, ``w`` the fastest drive pulsation),
``e = e*``; by the contraction property this changes the twist by ``~r_seed`` at
most, below the absolute tolerance on ``r`` (``rtol V``). The onset is stiff: ``e``
relaxes on the time scale ``r / (ck n)`` while ``r`` grows like ``t - t0`` (or like
``(t - t0)^2`` at a release with ``ck = cs``, where ``lambda = 0``), so an explicit
method needs ``~1 / sqrt(r_seed)`` steps. Phase A is therefore integrated by
``Radau`` (implicit, L-stable, order 5, analytic Jacobian) in the variables
``(r, e)``: ``r`` is smooth through the onset (no ``log r``, whose derivatives blow up
like ``1 / (t - t0)``), and ``e``, the stiff variable, has an absolute tolerance of its
own (in Cartesian ``u`` a tolerance of ``rtol V`` leaves the direction of a tiny
twist undetermined, and Radau then drifts away from the true solution). scipy's
Radau keeps its Jacobian across steps; the stiffness ``~ck n / r`` changes by
orders of magnitude during an onset and a stale Jacobian makes the simplified
Newton iteration "converge" with ``e`` frozen, so :class:`_FreshRadau`
re-evaluates the Jacobian at every step and lets a step at most about double ``r``.
Phase A hands over to phase B when ``r`` reaches ``1e-4 V`` (or starts to decrease
after passing ``1e-5 V``). A slip whose twist peaks below ``1e-5 V`` (a graze of the
threshold) ends in phase A, when ``r`` falls below ``r_seed / 2``.

**Slip body and slip end** (phase "B"): the stop detection. Near a stop ``r -> 0``
linearly while ``e`` turns towards a stop direction with a power law
(``e - e_stop ~ r^p``, ``p = ck n k_j / mu - 1`` for the eigenvalues ``k_j`` of ``K``
across ``e_stop``, ``mu = -r'``), so ``u(t)`` is not smooth at the stop, a step method
in ``t`` needs ever smaller steps there and would locate the stop by extrapolating a
non-smooth function. Phase B removes the singularity by a change of the
independent variable (a blow-up of ``u = 0``):

    dt / dsigma = r / (r + r_switch),        r_switch = 0.02 V by default,

with state ``(t, x, y, theta, path, rho = ln r, e, modes)`` and ``DOP853``. In
``sigma`` the system is smooth and not stiff (every rate is bounded by
``ck n max(1, kappa) / r_switch``): ``de/dsigma = (a - (e.a) e) / (r + r_switch)``,
``drho/dsigma = (e.a) / (r + r_switch)``, the other rates multiplied by ``dt/dsigma``.
For ``r >> r_switch`` it is the ordinary equation (``sigma ~ t``); as ``r -> 0`` the stop
moves to ``sigma = infinity``, ``r`` decays *exponentially* in ``sigma`` and ``e``
converges exponentially to the stop direction. The stop event is
``rho = ln(r_end)``, ``r_end = stop_tol V`` (default ``stop_tol = 1e-14``, i.e. about
``1e-15 m s-1``), located by Brent's method on the order-7 dense output; reaching it
from ``r_switch`` costs a few steps per e-fold of ``r``. The remaining motion is then
added to first order (``dt = r_end / |r'|``, pose ``+= u dt / 2``, modes integrated
over ``dt``). While ``e`` still turns (``e - e_stop ~ r^p``) ``r`` is not exactly linear
in ``t``, so the error of the stop time is ``O(r_end^(1 + min(p, 1)))``: measured
order about 1.1 (``kappa = 8/9``, ``p = 1/8``) to 2, down to the integration noise
(``~1e-15 s``) from ``stop_tol ~ 1e-9``; the pose is insensitive (``O(r_end^2)``).
``stop_tol`` is the accuracy parameter of the stop detection; the convergence
studies in it and in ``rtol`` are in ``tests/unit/test_planar_reference.py`` and
:func:`_demo`.

Events
------
Every accepted step is sampled at ``16`` points of its dense output; the first
sign change of any event function in its direction (release ``|W| - cs n`` up,
lift-off ``n`` down, stop ``ln r - ln r_end`` down, a time breakpoint ``t - t_b`` up
in phase B) is bracketed there and located by ``brentq`` to round-off. Output
times and schedule segment ends are breakpoints: the integration ends exactly on
them (``t_bound`` in ``t``, an event in ``sigma``) and restarts there, so every
output is a step end (never interpolated) and the drive is smooth within a step.
The state at every event is recomputed by integrating again from the start of the
step to the event time (a step end is more accurate than the dense output). At a
breakpoint in stick the release condition is checked again (a jump of the drive at
a segment boundary, or a release that falls on the breakpoint).

At a slip end: stick if ``|W| <= cs n``, else a new slip from the onset direction.

Run this file directly for a convergence table.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import DOP853, Radau
from scipy.optimize import brentq

__all__ = [
    "RefPlate",
    "RefTrajectory",
    "onset_direction",
    "reference_planar",
]

_EPS = float(np.finfo(float).eps)
_SAMPLES = 16  # dense-output samples per step for the event scan
_STICK, _SLIP_A, _SLIP_B = 0, 1, 2
_AB = 1e-4  # in units of V: phase A hands over to phase B at this twist
_GRAZE = 1e-5  # in units of V: a slip peaking below this stays in phase A to its end


@dataclass(frozen=True)
class RefPlate:
    """One plate of the reference model.

    Parameters
    ----------
    f0 : float
        Resonance frequency [Hz].
    Q : float
        Quality factor.
    alpha : float
        Tilt from the horizontal [degree].
    M : float
        Mass ratio (effective plate mass over total mass).
    direction : float
        Body-frame direction ``beta`` of the plate's oscillation [degree], counterclockwise
        from forward.
    attachment : (float, float)
        Attachment point ``(r_forward, r_left)`` in the body frame [m].
    """

    f0: float
    Q: float
    alpha: float
    M: float
    direction: float = 0.0
    attachment: tuple[float, float] = (0.0, 0.0)


@dataclass
class RefTrajectory:
    """Result of :func:`reference_planar`.

    Attributes
    ----------
    time, x, y, heading, vx, vy, spin, path : numpy.ndarray
        State at the output times reached [s, m, m, rad, m s-1, m s-1, rad s-1, m].
    modes : numpy.ndarray
        ``(delta_1, delta_1', ...)`` at the output times, shape ``(len(time), 2 P)``.
    outcome : str
        ``"done"``, ``"lift_off"`` or ``"budget"``.
    end_time : float
        Time reached [s].
    events : list of (float, str)
        ``(time, kind)``, kind in ``"release"``, ``"stop_stick"``, ``"stop_slip"``,
        ``"lift_off"``.
    steps : dict
        Accepted steps per phase (``"stick"``, ``"A"``, ``"B"``).
    """

    time: np.ndarray
    x: np.ndarray
    y: np.ndarray
    heading: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    spin: np.ndarray
    path: np.ndarray
    modes: np.ndarray
    outcome: str
    end_time: float
    events: list = field(default_factory=list)
    steps: dict = field(default_factory=dict)


def onset_direction(W, n, ck, kappa):
    """Unit direction in which a slip starts from rest under the scaled wrench ``W``.

    ``e_j = W_j / (lambda / K_j + ck n)`` with ``K = (1, 1, kappa)`` and ``lambda >= 0``
    such that ``|e| = 1``; then ``K (W - ck n e) = lambda e``. If ``|W| <= ck n`` (no
    slip can start) returns ``W / |W|`` with ``lambda = 0``.

    Returns
    -------
    e : numpy.ndarray
        Shape ``(3,)``.
    lam : float
        ``lambda``, the initial growth rate of ``|u|`` [m s-2].
    """
    W = np.asarray(W, dtype=float)
    K = np.array([1.0, 1.0, float(kappa)])
    norm = float(np.linalg.norm(W))
    if norm == 0.0:
        raise ValueError("onset direction undefined for W = 0")
    ckn = ck * n
    if ckn <= 0.0:
        e = K * W
        return e / np.linalg.norm(e), math.inf

    def excess(lam):
        return float(np.sum((W / (lam / K + ckn)) ** 2)) - 1.0

    if excess(0.0) <= 0.0:
        return W / norm, 0.0
    hi = float(K.max()) * norm
    while excess(hi) > 0.0:  # pragma: no cover - cannot happen (see docstring)
        hi *= 2.0
    lam = brentq(excess, 0.0, hi, xtol=1e-300, rtol=4 * _EPS, maxiter=500)
    e = W / (lam / K + ckn)
    return e / np.linalg.norm(e), lam


class _FreshRadau(Radau):
    """``Radau`` with a fresh Jacobian at every step and a bound on the growth of ``r``.

    scipy's Radau reuses its Jacobian across steps and judges Newton convergence on the
    whole state. Here the stiffness of the direction ``e`` is ``~ ck n / r`` and ``r``
    grows by many orders of magnitude during an onset: with a Jacobian from a much
    smaller ``r`` the Newton increments of ``e`` are damped to nothing and the iteration
    "converges" with ``e`` merely extrapolated. So the Jacobian is re-evaluated (and
    the iteration matrices refactored) at every step start, and a step may at most
    double ``r`` (``h <= r / |r'|`` and ``h <= sqrt(2 r / |r''|)``, ``r''`` estimated from
    the previous step), so that it stays accurate to a factor 2 within the step.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._prev = None  # (t, r') at the previous step start

    def _step_impl(self):
        t, y, f = self.t, self.y, self.f
        self.J = self.jac(t, y, f)
        self.current_jac = True
        self.LU_real = None
        self.LU_complex = None
        r, p = abs(y[4]), abs(f[4])
        h_lim = math.inf
        if p > 0.0:
            h_lim = r / p
        if self._prev is not None and t > self._prev[0]:
            dp = abs(f[4] - self._prev[1]) / (t - self._prev[0])
            if dp > 0.0:
                h_lim = min(h_lim, math.sqrt(2.0 * r / dp))
        self._prev = (t, f[4])
        if self.h_abs > h_lim:
            self.h_abs = h_lim
            self.h_abs_old = None
            self.error_norm_old = None
        return super()._step_impl()


class _Model:
    """Parameters, forces and right-hand sides."""

    def __init__(self, plates, cs, ck, g, radius, friction_length, gyration_radius, drive):
        self.P = len(plates)
        if self.P == 0:
            raise ValueError("at least one plate is needed")
        f0 = np.array([p.f0 for p in plates], dtype=float)
        Q = np.array([p.Q for p in plates], dtype=float)
        alpha = np.radians([p.alpha for p in plates])
        M = np.array([p.M for p in plates], dtype=float)
        beta = np.radians([p.direction for p in plates])
        rf = np.array([p.attachment[0] for p in plates], dtype=float)
        rl = np.array([p.attachment[1] for p in plates], dtype=float)
        w0 = 2.0 * np.pi * f0
        self.w0 = w0
        self.cd = w0 / Q  # damping
        self.kk = w0 * w0  # stiffness
        self.ca = np.cos(alpha)
        self.nm = M * self.ca  # n = g - A + nm . F
        tang = -M * np.sin(alpha)  # tangential load per unit F
        lever = rf * np.sin(beta) - rl * np.cos(beta)
        self.cf = float(friction_length) if friction_length is not None else 2.0 * radius / 3.0
        rho = float(gyration_radius) if gyration_radius is not None else radius / math.sqrt(2.0)
        if not (self.cf > 0.0 and rho > 0.0):
            raise ValueError("friction length and gyration radius must be > 0")
        self.bx = tang * np.cos(beta)  # f_b,x = bx . F
        self.by = tang * np.sin(beta)
        self.bt = tang * lever / self.cf  # T / c = bt . F
        self.kappa = (self.cf / rho) ** 2
        self.K = np.array([1.0, 1.0, self.kappa])
        self.cs, self.ck, self.g = float(cs), float(ck), float(g)
        freq, acc, dur, phase = drive
        self.t0 = np.concatenate(([0.0], np.cumsum(dur)[:-1]))
        self.t1 = np.cumsum(dur)
        self.om = 2.0 * np.pi * freq
        self.acc = acc
        self.ph = phase + np.concatenate(([0.0], np.cumsum(self.om * dur)[:-1]))
        # column versions for sampled (vectorised) evaluation
        names = ("cd", "kk", "ca", "nm", "bx", "by", "bt")
        self._c = {name: getattr(self, name)[:, None] for name in names}
        # natural scales
        wmax = float(np.max(self.om))
        self.T = 2.0 * np.pi / wmax
        self.V = self.g / wmax
        self.L = self.g / wmax**2
        fast = np.maximum(wmax, w0)
        self.mode_scale = np.empty(2 * self.P)
        self.mode_scale[0::2] = self.g / fast**2
        self.mode_scale[1::2] = self.g / fast

    # -- forces -------------------------------------------------------------------
    def drive(self, t, k):
        return self.acc[k] * np.cos(self.ph[k] + self.om[k] * (t - self.t0[k]))

    def loads(self, t, k, modes):
        """Body-frame loads at scalar ``t``: ``(F, fbx, fby, T/c, n)``."""
        A = self.acc[k] * math.cos(self.ph[k] + self.om[k] * (t - self.t0[k]))
        F = A * self.ca - self.cd * modes[1::2] - self.kk * modes[0::2]
        return (
            F,
            float(self.bx @ F),
            float(self.by @ F),
            float(self.bt @ F),
            self.g - A + float(self.nm @ F),
        )

    def loads_vec(self, t, k, modes):
        """Vectorised :meth:`loads`: ``t`` shape ``(m,)``, ``modes`` shape ``(2P, m)``."""
        c = self._c
        A = self.drive(t, k)
        F = A * c["ca"] - c["cd"] * modes[1::2] - c["kk"] * modes[0::2]
        return (
            (c["bx"] * F).sum(0),
            (c["by"] * F).sum(0),
            (c["bt"] * F).sum(0),
            self.g - A + (c["nm"] * F).sum(0),
        )

    def wrench(self, t, k, theta, modes):
        """Scaled world wrench ``W`` (shape (3,)) and ``n`` at scalar ``t``."""
        _, fbx, fby, wt, n = self.loads(t, k, modes)
        c, s = math.cos(theta), math.sin(theta)
        return np.array([c * fbx - s * fby, s * fbx + c * fby, wt]), n

    def release_margin_vec(self, t, k, modes):
        fbx, fby, wt, n = self.loads_vec(t, k, modes)
        return np.sqrt(fbx * fbx + fby * fby + wt * wt) - self.cs * n

    # -- stick: modes only ---------------------------------------------------------
    def rhs_stick(self, k):
        cd, kk, ca = self.cd, self.kk, self.ca
        om, ph, t0, acc = self.om[k], self.ph[k], self.t0[k], self.acc[k]

        def rhs(t, y):
            A = acc * math.cos(ph + om * (t - t0))
            out = np.empty_like(y)
            out[0::2] = y[1::2]
            out[1::2] = A * ca - cd * y[1::2] - kk * y[0::2]
            return out

        return rhs

    # -- phase A: t-form, twist as magnitude and direction u = r e -------------------
    # YA = (x, y, theta, path, r, e1, e2, e3, modes...)
    def rhs_a(self, k, r_floor):
        K3, ck, cf = self.kappa, self.ck, self.cf

        def rhs(t, Y):
            modes = Y[8:]
            F, fbx, fby, wt, n = self.loads(t, k, modes)
            c, s = math.cos(Y[2]), math.sin(Y[2])
            W1, W2 = c * fbx - s * fby, s * fbx + c * fby
            r = Y[4]
            rd = max(r, r_floor)  # guard against a non-positive r inside Newton iterations
            en = math.sqrt(Y[5] * Y[5] + Y[6] * Y[6] + Y[7] * Y[7])
            e1, e2, e3 = Y[5] / en, Y[6] / en, Y[7] / en
            ckn = ck * n
            a1 = W1 - ckn * e1
            a2 = W2 - ckn * e2
            a3 = K3 * (wt - ckn * e3)
            p = e1 * a1 + e2 * a2 + e3 * a3
            out = np.empty_like(Y)
            out[0] = r * e1
            out[1] = r * e2
            out[2] = r * e3 / cf
            out[3] = r * math.hypot(e1, e2)
            out[4] = p
            out[5] = (a1 - p * e1) / rd
            out[6] = (a2 - p * e2) / rd
            out[7] = (a3 - p * e3) / rd
            out[8::2] = modes[1::2]
            out[9::2] = F
            return out

        return rhs

    def jac_a(self, k, r_floor):
        """Jacobian of :meth:`rhs_a` (taking ``|e| = 1``; used by Newton only)."""
        P, K, ck, cf = self.P, self.K, self.ck, self.cf
        N = 8 + 2 * P
        eye = np.eye(3)
        scale = np.array([1.0, 1.0, 1.0 / cf])

        def jac(t, Y):
            modes = Y[8:]
            _, fbx, fby, wt, n = self.loads(t, k, modes)
            c, s = math.cos(Y[2]), math.sin(Y[2])
            W = np.array([c * fbx - s * fby, s * fbx + c * fby, wt])
            r = Y[4]
            rd = max(r, r_floor)
            e = Y[5:8] / np.linalg.norm(Y[5:8])
            ckn = ck * n
            a = K * (W - ckn * e)
            p = float(e @ a)
            J = np.zeros((N, N))
            # pose and path: r e
            J[0:3, 4] = e * scale
            J[0:3, 5:8] = r * np.diag(scale)
            et = math.hypot(e[0], e[1])
            J[3, 4] = et
            if et > 0.0:
                J[3, 5] = r * e[0] / et
                J[3, 6] = r * e[1] / et
            # r' = p, e' = (a - p e) / r
            dp_de = a - ckn * K * e
            J[4, 5:8] = dp_de
            if r > r_floor:
                J[5:8, 4] = -(a - p * e) / (r * r)
            J[5:8, 5:8] = (-ckn * np.diag(K) - np.outer(e, dp_de) - p * eye) / rd
            # through theta
            da = np.array([-W[1], W[0], 0.0])
            J[4, 2] = float(e @ da)
            J[5:8, 2] = (da - float(e @ da) * e) / rd
            # through the modes: da/dF_i = K (dW/dF_i - ck e dn/dF_i)
            dW = np.array([c * self.bx - s * self.by, s * self.bx + c * self.by, self.bt])
            dA = K[:, None] * (dW - ck * e[:, None] * self.nm[None, :])  # (3, P)
            dp = e @ dA  # (P,)
            de = (dA - e[:, None] * dp[None, :]) / rd  # (3, P)
            for i in range(P):
                jd, jv = 8 + 2 * i, 9 + 2 * i
                J[4, jd] = -self.kk[i] * dp[i]
                J[4, jv] = -self.cd[i] * dp[i]
                J[5:8, jd] = -self.kk[i] * de[:, i]
                J[5:8, jv] = -self.cd[i] * de[:, i]
                J[jd, jv] = 1.0
                J[jv, jd] = -self.kk[i]
                J[jv, jv] = -self.cd[i]
            return J

        return jac

    # -- phase B: sigma-form ----------------------------------------------------------
    # Z = (t, x, y, theta, path, rho, e1, e2, e3, modes...)
    def rhs_b(self, k, r_sw):
        K3, ck, cf = self.kappa, self.ck, self.cf

        def rhs(_s, Z):
            modes = Z[9:]
            F, fbx, fby, wt, n = self.loads(Z[0], k, modes)
            c, s = math.cos(Z[3]), math.sin(Z[3])
            W1, W2 = c * fbx - s * fby, s * fbx + c * fby
            r = math.exp(Z[5])
            rs = r + r_sw
            h = r / rs  # dt / dsigma
            en = math.sqrt(Z[6] * Z[6] + Z[7] * Z[7] + Z[8] * Z[8])
            e1, e2, e3 = Z[6] / en, Z[7] / en, Z[8] / en
            ckn = ck * n
            a1 = W1 - ckn * e1
            a2 = W2 - ckn * e2
            a3 = K3 * (wt - ckn * e3)
            p = e1 * a1 + e2 * a2 + e3 * a3
            hr = h * r
            out = np.empty_like(Z)
            out[0] = h
            out[1] = hr * e1
            out[2] = hr * e2
            out[3] = hr * e3 / cf
            out[4] = hr * math.hypot(e1, e2)
            out[5] = p / rs
            out[6] = (a1 - p * e1) / rs
            out[7] = (a2 - p * e2) / rs
            out[8] = (a3 - p * e3) / rs
            out[9::2] = h * modes[1::2]
            out[10::2] = h * F
            return out

        return rhs

    def radial_rate(self, t, k, theta, modes, e):
        """``r' = e . K (W - ck n e)`` for a unit direction ``e``."""
        W, n = self.wrench(t, k, theta, modes)
        return float(e @ (self.K * (W - self.ck * n * e)))


def _step_until(make_solver, t0, y0, t_bound, events, max_steps, after_step=None):
    """Step ``make_solver(t0, y0, t_bound)`` until an event, ``t_bound``, or ``after_step``.

    ``events`` is a list of ``(fun, direction)``; ``fun(s, Y)`` accepts ``s`` of shape
    ``(m,)`` and ``Y`` of shape ``(n, m)`` and returns shape ``(m,)``. Each accepted
    step is sampled at ``_SAMPLES + 1`` points of its dense output; the first sign
    change of ``direction * fun`` from ``< 0`` to ``>= 0`` is located by ``brentq``.
    The state at the event is then recomputed by integrating again from the start of
    that step to the event (a step end is more accurate than the dense output).

    Returns ``(s, y, fired, steps, reason)``: ``fired`` is the event index or None;
    ``reason`` is ``"event"``, ``"bound"``, ``"after"`` or ``"budget"``.
    """
    frac = np.linspace(0.0, 1.0, _SAMPLES + 1)
    solver = make_solver(t0, y0, t_bound)
    for n_steps in range(1, max_steps + 1):
        y_start = solver.y.copy()
        msg = solver.step()
        if solver.status == "failed":
            raise RuntimeError(f"integration failed at {solver.t}: {msg}")
        sa, sb = solver.t_old, solver.t
        dense = solver.dense_output()
        grid = sa + (sb - sa) * frac
        grid[-1] = sb
        Yg = dense(grid)
        Yg[:, -1] = solver.y  # the exact step end
        best = None
        for i, (fun, d) in enumerate(events):
            og = d * fun(grid, Yg)
            hit = np.nonzero((og[:-1] < 0.0) & (og[1:] >= 0.0))[0]
            if hit.size == 0:
                continue
            j = int(hit[0])
            if best is not None and grid[j] >= best[0]:
                continue
            lo, hi = grid[j], grid[j + 1]

            def oriented(s, fun=fun, d=d, dense=dense):
                return float(d * fun(np.array([s]), dense(s)[:, None])[0])

            if og[j + 1] == 0.0:
                root = hi
            else:
                root = brentq(oriented, lo, hi, xtol=4 * _EPS, rtol=4 * _EPS)
            if best is None or root < best[0]:
                best = (root, i)
        if best is not None:
            s = best[0]
            if s == sb:
                y = solver.y.copy()
            else:
                again = make_solver(sa, y_start, s)
                while again.status == "running":
                    again.step()
                y = again.y.copy() if again.status == "finished" else dense(s)
            return s, y, best[1], n_steps, "event"
        if solver.status == "finished":
            return sb, solver.y.copy(), None, n_steps, "bound"
        if after_step is not None and after_step(sb, solver.y):
            return sb, solver.y.copy(), None, n_steps, "after"
    return solver.t, solver.y.copy(), None, max_steps, "budget"


class _Run:
    """The hybrid integration loop."""

    def __init__(self, model, rtol, stop_tol, r_switch, max_steps, r_ab=None):
        m = model
        self.m = m
        self.rtol = rtol
        self.rtol_radau = max(rtol, 1000.0 * _EPS * 1.01)
        self.r_sw = r_switch if r_switch is not None else 0.02 * m.V
        self.r_ab = _AB * m.V if r_ab is None else r_ab
        self.r_end = stop_tol * m.V
        self.r_seed = 1e-2 * rtol * m.V
        self.r_graze = _GRAZE * m.V
        self.max_steps = max_steps
        self.steps = {"stick": 0, "A": 0, "B": 0}
        self.max_step = m.T / 8.0
        ms = m.mode_scale
        ang = m.L / m.cf
        self.atol_stick = rtol * ms
        # phase A: (x, y, theta, path, r, e, modes); phase B: (t, x, y, theta, path, ln r, e, modes)
        self.atol_a = self.rtol_radau * np.concatenate(([m.L, m.L, ang, m.L, m.V, 1, 1, 1], ms))
        self.atol_b = rtol * np.concatenate(([m.T, m.L, m.L, ang, m.L, 1, 1, 1, 1], ms))

    # -- event functions (vectorised) ------------------------------------------------
    def _ev_release(self, k, moff, tfun):
        m = self.m

        def ev(s, Y):
            return m.release_margin_vec(tfun(s, Y), k, Y[moff:])

        return ev

    def _ev_lift(self, k, moff, tfun):
        m = self.m

        def ev(s, Y):
            return m.loads_vec(tfun(s, Y), k, Y[moff:])[3]

        return ev

    # -- phases ------------------------------------------------------------------------
    def stick(self, t, t_next, k, modes):
        m = self.m
        rhs = m.rhs_stick(k)

        def make(t0, y0, t1):
            return DOP853(rhs, t0, y0, t1, max_step=self.max_step, rtol=self.rtol,
                          atol=self.atol_stick)

        events = [
            (self._ev_release(k, 0, lambda s, Y: s), +1),
            (self._ev_lift(k, 0, lambda s, Y: s), -1),
        ]
        s, y, fired, n, reason = _step_until(make, t, modes, t_next, events, self.max_steps)
        self.steps["stick"] += n
        if reason == "budget":
            return s, y, "budget"
        if fired is None:
            return t_next, y, "break"
        return s, y, ("release", "lift")[fired]

    def slip_a(self, t, t_next, k, Y):
        """Phase A (Radau in ``t`` on ``(r, e)``) from the t-form state ``Y`` (``u != 0``)."""
        m = self.m
        u = Y[4:7]
        r = float(np.linalg.norm(u))
        YA = np.concatenate((Y[0:4], [r], u / r, Y[7:]))
        floor = 1e-3 * self.r_seed
        rhs, jac = m.rhs_a(k, floor), m.jac_a(k, floor)

        def make(t0, y0, t1):
            return _FreshRadau(rhs, t0, y0, t1, max_step=self.max_step, rtol=self.rtol_radau,
                               atol=self.atol_a, jac=jac)

        r_stop = 0.5 * self.r_seed
        events = [(lambda s, Yg: Yg[4] - r_stop, -1), (self._ev_lift(k, 8, lambda s, Y: s), -1)]

        def switch(s, y):
            if y[4] >= self.r_ab:
                return True
            if y[4] >= self.r_graze:
                e = y[5:8] / np.linalg.norm(y[5:8])
                return m.radial_rate(s, k, y[2], y[8:], e) < 0.0
            return False

        s, y, fired, n, reason = _step_until(make, t, YA, t_next, events, self.max_steps, switch)
        self.steps["A"] += n
        e = y[5:8] / np.linalg.norm(y[5:8])
        r = y[4]
        Y = np.concatenate((y[0:4], r * e, y[8:]))
        if reason == "budget":
            return s, Y, "budget"
        if reason == "after":
            return s, Y, "to_B"
        if fired is None:
            return t_next, Y, "break"
        if fired == 1:
            return s, Y, "lift"
        # stop inside phase A (a graze)
        mu = -m.radial_rate(s, k, Y[2], Y[7:], e)
        out = self._finish_stop(s, k, Y, r * e, r, mu, t_next)
        return out[-1], out[:-1], "stop"

    def _finish_stop(self, s, k, y, u, r, mu, t_next):
        """Add the rest of the slip from ``|u| = r`` to first order (``dt = r / mu``).

        The pose gets ``u dt / 2``, the modes are integrated over ``dt`` (DOP853). The
        step is skipped when ``mu <= 0`` or ``dt > 1e-3 T`` (a degenerate, tangential
        stop). Returns the t-form state at the stop with the stop time appended.
        """
        m = self.m
        dt = r / mu if mu > 0.0 else math.inf
        dt = min(dt, t_next - s)
        out = np.empty(7 + 2 * m.P + 1)
        out[:-1] = y
        out[-1] = s
        if 0.0 < dt <= 1e-3 * m.T:
            out[0] += 0.5 * u[0] * dt
            out[1] += 0.5 * u[1] * dt
            out[2] += 0.5 * u[2] * dt / m.cf
            out[3] += 0.5 * math.hypot(u[0], u[1]) * dt
            solver = DOP853(m.rhs_stick(k), s, y[7:], s + dt, rtol=self.rtol,
                            atol=self.atol_stick)
            while solver.status == "running":
                solver.step()
            out[7:-1] = solver.y
            out[-1] = s + dt
        out[4:7] = 0.0
        return out

    def slip_b(self, t, t_next, k, Y):
        """Phase B (DOP853 in ``sigma``) from the t-form state ``Y`` (``u != 0``)."""
        m = self.m
        u = Y[4:7]
        r = float(np.linalg.norm(u))
        Z = np.concatenate(([t], Y[0:4], [math.log(r)], u / r, Y[7:]))
        rhs = m.rhs_b(k, self.r_sw)
        log_end = math.log(self.r_end)
        events = [
            (lambda s, Zg: Zg[5] - log_end, -1),
            (lambda s, Zg: Zg[0] - t_next, +1),
            (self._ev_lift(k, 9, lambda s, Zg: Zg[0]), -1),
        ]
        def make(s0, z0, s1):
            return DOP853(rhs, s0, z0, s1, max_step=self.max_step, rtol=self.rtol,
                          atol=self.atol_b)

        ckg = max(m.ck * m.g, 1e-300)
        chunk = (t_next - t) + 50.0 * self.r_sw * max(math.log(self.r_sw / self.r_end), 1.0) / ckg
        used = 0
        while True:
            _, Z, fired, n, reason = _step_until(make, 0.0, Z, chunk, events,
                                                 self.max_steps - used)
            self.steps["B"] += n
            used += n
            if fired is not None:
                break
            if reason == "budget" or used >= self.max_steps:
                return Z[0], self._z_to_y(Z), "budget"
        if fired == 1:
            Y = self._z_to_y(Z)
            return t_next, Y, "break"
        if fired == 2:
            return Z[0], self._z_to_y(Z), "lift"
        # stop at r = r_end
        r = math.exp(Z[5])
        e = Z[6:9] / np.linalg.norm(Z[6:9])
        Y = self._z_to_y(Z)
        mu = -m.radial_rate(Z[0], k, Z[3], Z[9:], e)
        y = self._finish_stop(Z[0], k, Y, r * e, r, mu, t_next)
        return y[-1], y[:-1], "stop"

    @staticmethod
    def _z_to_y(Z):
        r = math.exp(Z[5])
        e = Z[6:9] / np.linalg.norm(Z[6:9])
        return np.concatenate((Z[1:5], r * e, Z[9:]))


def reference_planar(
    plates: Sequence[RefPlate],
    frequency,
    acceleration,
    duration,
    *,
    phase: float = 0.0,
    cs: float = 0.25,
    ck: float | None = None,
    g: float = 9.8,
    radius: float = 0.02,
    friction_length: float | None = None,
    gyration_radius: float | None = None,
    initial_state=None,
    output_times=None,
    rtol: float = 1e-12,
    stop_tol: float = 1e-14,
    r_switch: float | None = None,
    max_steps: int = 50_000,
) -> RefTrajectory:
    """Integrate the planar model through a drive schedule.

    Parameters
    ----------
    plates : sequence of RefPlate
    frequency, acceleration, duration : array_like
        Drive schedule: one entry per segment [Hz, m s-2, s].
    phase : float
        Drive phase at ``t = 0`` [rad].
    cs, ck, g : float
        Static and kinetic friction coefficients (``ck`` defaults to ``cs``), gravity.
    radius : float
        Disk radius [m]: only sets the defaults ``friction_length = 2 R / 3`` and
        ``gyration_radius = R / sqrt(2)``.
    initial_state : array_like, optional
        ``(x, y, theta, vx, vy, spin, path, delta_1, delta_1', ...)``; default zeros.
    output_times : array_like, optional
        Sorted times in ``[0, end]``; default ``[0, end]``. The run always ends at the
        end of the schedule (or at lift-off).
    rtol : float
        Relative tolerance of the steps (absolute tolerances: ``rtol`` times the
        natural scale of each component). Radau uses ``max(rtol, 1000 eps)``.
    stop_tol : float
        Stop detection threshold, ``<= 1e-6``: a slip ends when
        ``|u| = stop_tol * g / w`` (``w`` the fastest drive pulsation); the rest of the
        slip is added to first order.
    r_switch : float, optional
        Scale [m s-1] of the blow-up ``dt / dsigma = r / (r + r_switch)`` of phase B;
        default ``0.02 g / w``.
    max_steps : int
        Step budget of each phase call, and budget of phase calls.
    """
    if ck is None:
        ck = cs
    if not (0.0 <= ck <= cs):
        raise ValueError(f"need 0 <= ck <= cs, got ck={ck}, cs={cs}")
    freq = np.atleast_1d(np.asarray(frequency, dtype=float))
    acc = np.atleast_1d(np.asarray(acceleration, dtype=float))
    dur = np.atleast_1d(np.asarray(duration, dtype=float))
    if not (freq.shape == acc.shape == dur.shape) or freq.ndim != 1:
        raise ValueError("frequency, acceleration, duration must be 1-D of one length")
    if not (100 * _EPS <= rtol <= 1e-6):
        raise ValueError(f"need 100 eps <= rtol <= 1e-6, got {rtol}")
    if not (0.0 < stop_tol <= 1e-6):
        raise ValueError(f"need 0 < stop_tol <= 1e-6, got {stop_tol}")
    m = _Model(list(plates), cs, ck, g, radius, friction_length, gyration_radius,
               (freq, acc, dur, float(phase)))
    run = _Run(m, rtol, stop_tol, r_switch, max_steps)
    end = float(m.t1[-1])
    P = m.P
    state = np.zeros(7 + 2 * P) if initial_state is None else np.array(initial_state, float)
    if state.shape != (7 + 2 * P,):
        raise ValueError(f"initial_state must have {7 + 2 * P} entries")
    out_t = np.array([0.0, end]) if output_times is None else np.asarray(output_times, float)
    if np.any(np.diff(out_t) < 0) or out_t.min() < 0 or out_t.max() > end:
        raise ValueError("output_times must be sorted and within the schedule")
    # t-form state Y = (x, y, theta, path, u1, u2, u3, modes)
    Y = np.concatenate((state[0:3], [state[6]], state[3:5], [m.cf * state[5]], state[7:]))
    breaks = np.unique(np.concatenate((out_t, m.t1)))
    breaks = breaks[breaks > 0.0]
    rows = []
    events = []

    def record(t, Y):
        for _ in range(int(np.count_nonzero(out_t == t))):
            rows.append(np.concatenate(([t], Y[0:3], Y[4:6], [Y[6] / m.cf], [Y[3]], Y[7:])))

    def contact_after_rest(t, k, Y):
        W, n = m.wrench(t, k, Y[2], Y[7:])
        if n < 0.0:
            return "lift", None
        if float(np.linalg.norm(W)) > cs * n:
            return _SLIP_A, onset_direction(W, n, ck, m.kappa)[0]
        return _STICK, None

    t = 0.0
    k = 0
    record(t, Y)
    outcome = "done"
    if float(np.linalg.norm(Y[4:7])) > 0.0:
        mode = _SLIP_B if m.wrench(t, k, Y[2], Y[7:])[1] >= 0.0 else "lift"
    else:
        mode, e_seed = contact_after_rest(t, k, Y)
        if mode == _SLIP_A:
            Y[4:7] = run.r_seed * e_seed
            events.append((t, "release"))
    bi = 0
    calls = 0
    while mode != "lift":
        calls += 1
        if calls > max_steps:
            outcome = "budget"
            break
        t_next = float(breaks[bi])
        if t >= t_next:  # an event fell on a breakpoint
            what = "break"
        elif mode == _STICK:
            t, Y[7:], what = run.stick(t, t_next, k, Y[7:].copy())
        elif mode == _SLIP_A:
            t, Y, what = run.slip_a(t, t_next, k, Y)
        else:
            t, Y, what = run.slip_b(t, t_next, k, Y)
        if what == "budget":
            outcome = "budget"
            break
        if what == "lift":
            mode = "lift"
        elif what == "to_B":
            mode = _SLIP_B
        elif what == "break":
            t = t_next
            record(t, Y)
            bi += 1
            if bi >= breaks.size:
                break
            k = int(np.searchsorted(m.t1, t, side="right"))  # a new segment may start
            if m.wrench(t, k, Y[2], Y[7:])[1] < 0.0:
                mode = "lift"
            elif mode == _STICK:  # the drive may jump, or a release fall on the break
                mode, e_seed = contact_after_rest(t, k, Y)
                if mode == _SLIP_A:
                    Y[4:7] = run.r_seed * e_seed
                    events.append((t, "release"))
        elif what == "release":
            W, n = m.wrench(t, k, Y[2], Y[7:])
            Y[4:7] = run.r_seed * onset_direction(W, n, ck, m.kappa)[0]
            mode = _SLIP_A
            events.append((t, "release"))
        elif what == "stop":
            Y[4:7] = 0.0
            mode, e_seed = contact_after_rest(t, k, Y)
            if mode == _SLIP_A:
                Y[4:7] = run.r_seed * e_seed
                events.append((t, "stop_slip"))
            elif mode == _STICK:
                events.append((t, "stop_stick"))
        else:  # pragma: no cover
            raise AssertionError(what)
    if mode == "lift":
        outcome = "lift_off"
        events.append((t, "lift_off"))
    return _pack(rows, outcome, t, events, run.steps, P)


def _pack(rows, outcome, t_end, events, steps, P):
    arr = np.array(rows).reshape(-1, 8 + 2 * P)
    return RefTrajectory(
        time=arr[:, 0],
        x=arr[:, 1],
        y=arr[:, 2],
        heading=arr[:, 3],
        vx=arr[:, 4],
        vy=arr[:, 5],
        spin=arr[:, 6],
        path=arr[:, 7],
        modes=arr[:, 8:],
        outcome=outcome,
        end_time=float(t_end),
        events=events,
        steps=dict(steps),
    )


def _demo():  # pragma: no cover - manual
    """Convergence tables on the steering disk (forward drive, 14.2 Hz, 7 m s-2)."""
    R = 0.02
    head = RefPlate(14.44, 17.5, 64.0, 0.08, 0.0, (R, 0.0))
    tail = RefPlate(8.5, 10.0, 64.0, 0.05, 90.0, (-R, 0.0))
    f, a = 14.2, 7.0
    T = 1.0 / f
    w = 2.0 * math.pi * f
    init = np.zeros(11)
    for i, p in enumerate((head, tail)):
        w0 = 2.0 * math.pi * p.f0
        amp = a * math.cos(math.radians(p.alpha)) / complex(w0 * w0 - w * w, w0 * w / p.Q)
        init[7 + 2 * i], init[8 + 2 * i] = amp.real, (1j * w * amp).real
    times = np.array([1.0, 2.0, 3.0]) * T
    print("rtol: three periods, differences to rtol = 1e-13 [m, m, rad]")
    runs = {}
    for rtol in (1e-9, 1e-10, 1e-11, 1e-12, 1e-13):
        t0 = time.perf_counter()
        runs[rtol] = reference_planar([head, tail], [f], [a], [3 * T], output_times=times,
                                      initial_state=init, rtol=rtol)
        runs[rtol].seconds = time.perf_counter() - t0
    best = runs[1e-13]
    for rtol, tr in runs.items():
        dx, dy = np.abs(tr.x - best.x).max(), np.abs(tr.y - best.y).max()
        dh = np.abs(tr.heading - best.heading).max()
        print(f"  {rtol:.0e}  x {dx:.1e}  y {dy:.1e}  heading {dh:.1e}  steps {tr.steps}"
              f"  {tr.seconds:.2f} s")
    print("stop_tol: one period, event times and poses against stop_tol = 1e-16 [s, m, rad]")
    runs = {}
    for stop_tol in (1e-6, 1e-7, 1e-8, 1e-10, 1e-14, 1e-16):
        runs[stop_tol] = reference_planar([head, tail], [f], [a], [T], output_times=[T],
                                          initial_state=init, stop_tol=stop_tol)
    best = runs[1e-16]
    ref_t = np.array([t for t, _ in best.events])
    for stop_tol, tr in runs.items():
        ev = np.array([t for t, _ in tr.events])
        dx, dh = abs(tr.x[0] - best.x[0]), abs(tr.heading[0] - best.heading[0])
        print(f"  {stop_tol:.0e}  events {np.abs(ev - ref_t).max():.1e}  x {dx:.1e}"
              f"  heading {dh:.1e}")


if __name__ == "__main__":  # pragma: no cover
    _demo()

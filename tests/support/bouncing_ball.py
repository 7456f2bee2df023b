"""The bouncing block: a structure of negligible mass ratio whose base, of restitution
e, hops on the shaken table as a ball does, with the closed forms of its period-1
orbit (Holmes 1982; Luck and Mehta 1993): born in a fold at Gamma = a / g =
pi (1 - e) / (1 + e), period-doubling at Gamma^2 = (pi (1 - e) / (1 + e))^2 +
(2 (1 + e^2) / (1 + e)^2)^2."""

from __future__ import annotations

import math

import numpy as np

import study

__all__ = ["G", "ball", "ball_doubling", "ball_fold", "ball_orbit"]

G = 9.8


def ball(e: float) -> study.Structure:
    """The bouncing block: the paper's plate with a negligible mass ratio."""
    return study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=1e-12, cs=0.25, restitution=e)


def ball_fold(e: float) -> float:
    """Gamma [1] of the period-1 orbit's fold."""
    return math.pi * (1.0 - e) / (1.0 + e)


def ball_doubling(e: float) -> float:
    """Gamma [1] of its period doubling."""
    return math.hypot(ball_fold(e), 2.0 * (1.0 + e * e) / (1.0 + e) ** 2)


def ball_orbit(e: float, f: float, a: float) -> np.ndarray:
    """The state at phase 0 of the stable period-1 orbit of the ball on the table
    (closed form): it lands where the table rises and decelerates, sin(w t0) =
    -Gamma_fold / Gamma, cos(w t0) > 0, and leaves at u = g T e / (1 + e)."""
    w = 2.0 * np.pi * f
    period = 1.0 / f
    phase = 2.0 * np.pi - math.asin(ball_fold(e) / (a / G))
    u = G * period * e / (1.0 + e)
    flown = period - phase / w
    gap = (u * flown - 0.5 * G * flown ** 2 - a / w ** 2 * (1.0 - math.cos(phase))
           - a / w * math.sin(phase) * flown)
    rate = u - G * flown - a / w * math.sin(phase)
    return np.array([0.0, 0.0, 0.0, gap, rate])

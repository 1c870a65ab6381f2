"""Horizontal wind field: a constant wind plus random disturbance episodes (paper 000).

Directions are meteorological: the direction the wind comes **from**, clockwise from
north (a west wind, from 270°, blows toward the east).  The wind vector in ENU is
``w = speed * [-sin(from), -cos(from), 0]``.

A disturbance episode adds, during ``[start, end]``, a wind of random speed in
``speed_range`` and random direction in ``from_range`` that changes every
``change_interval`` seconds.  Every change (and the episode's start and end) is a smooth
cubic ramp of ``ramp`` seconds, so the ground acceleration the aircraft feels is
continuous and the IMU stays consistent with the truth.  All draws come from the run's
``numpy.random.Generator``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def wind_vector(speed, from_rad) -> np.ndarray:
    """ENU wind [m/s] of ``speed`` coming from ``from_rad`` (clockwise from north)."""
    s = np.asarray(speed, dtype=float)
    f = np.asarray(from_rad, dtype=float)
    return np.stack([-s * np.sin(f), -s * np.cos(f), np.zeros_like(s)], axis=-1)


@dataclass(frozen=True)
class Episode:
    """A random disturbance: speed [m/s] and from-direction [rad] ranges, time window and
    change interval [s]."""

    start: float
    end: float
    speed_range: tuple[float, float]
    from_range: tuple[float, float]
    change_interval: float


class WindField:
    """Constant wind + smooth piecewise-constant random disturbances.

    ``__call__(t)`` returns the wind (N, 3) and its time derivative (N, 3) at times ``t``.
    """

    def __init__(self, speed: float, from_rad: float, episodes=(), ramp: float = 10.0,
                 rng: np.random.Generator | None = None):
        self.base = wind_vector(speed, from_rad)
        self.ramp = float(ramp)
        if self.ramp <= 0:
            raise ValueError("wind ramp time must be positive")
        knots_t, knots_w = [-np.inf], [np.zeros(3)]
        for ep in episodes:
            if ep.end <= ep.start or ep.change_interval <= 0:
                raise ValueError("wind episode: end must follow start and the change "
                                 "interval must be positive")
            if rng is None:
                raise ValueError("random wind episodes need a numpy Generator")
            for t0 in np.arange(ep.start, ep.end, ep.change_interval):
                sp = rng.uniform(*ep.speed_range)
                fr = rng.uniform(*ep.from_range)
                knots_t.append(float(t0))
                knots_w.append(wind_vector(sp, fr))
            knots_t.append(float(ep.end))
            knots_w.append(np.zeros(3))
        self.knots_t = np.array(knots_t)
        self.knots_w = np.array(knots_w)

    def __call__(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        i = np.searchsorted(self.knots_t, t, side="right") - 1
        w = np.tile(self.base, (len(t), 1)) + self.knots_w[i]
        dw = np.zeros((len(t), 3))
        # Smoothly blend from the previous knot's value during the ramp after each knot.
        tau = (t - self.knots_t[i]) / self.ramp
        on = (i > 0) & (tau < 1.0)
        if on.any():
            s = 3 * tau[on] ** 2 - 2 * tau[on] ** 3
            ds = (6 * tau[on] - 6 * tau[on] ** 2) / self.ramp
            jump = self.knots_w[i[on]] - self.knots_w[i[on] - 1]
            w[on] -= (1.0 - s)[:, None] * jump
            dw[on] = ds[:, None] * jump
        return w, dw

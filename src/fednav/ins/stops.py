"""Stand-still detection from the IMU alone: the SHOE detector.

Skog, Händel, Nilsson, Rantakokko, "Zero-velocity detection — an algorithm evaluation",
IEEE Trans. Biomed. Eng. 57(11), 2010, eq. 9 (the stance hypothesis optimal detector):
over a window of ``W`` samples around sample ``k``,

    T_k = 1/W * sum_i ( ||a_i - mean(a)||^2 / sigma_a^2 + ||w_i||^2 / sigma_w^2 )

with ``a`` the specific force [m/s^2] and ``w`` the angular rate [rad/s] of the body,
``sigma_a``, ``sigma_w`` their per-sample white noise (the IMU's VRW and ARW over
``sqrt(dt)``).  Skog's detector compares ``a_i`` with ``g`` along the mean direction; the
scatter about the window mean used here is the same test without the local gravity
(one accelerometer bias along the vertical does not matter).  At rest each term is a
sum of squares of unit-variance noise: ``W T_k`` is chi-square with ``3 (W - 1) + 3 W``
degrees of freedom, so the threshold is its ``1 - alpha`` point (``alpha`` = 0.001: one
window in a thousand of a still vehicle is called moving).  The gyro term's sigma holds
what a resting gyro also reads — the Earth rate and the turn-on bias — so that a
navigation-grade gyro at rest is not "rotating" at 15 deg/h.

What it cannot see: constant velocity (a vehicle cruising straight at a steady speed on
a smooth road is, to an IMU, at rest) and vibration beyond the data sheet's noise (an
idling engine: then every window is "moving" and nothing is declared still — the safe
side).  Callers that can, confirm a stop with the GNSS speed (:mod:`fednav.ins.alignment`).
Units: SI; body axes as in the data.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from ..core import earth

#: Window [s] of the detector.
WINDOW_S = 0.5
#: Probability that a window of a vehicle at rest is called moving.
ALPHA = 1e-3


def _window_sums(x: np.ndarray, W: int) -> np.ndarray:
    """Sums of ``x`` (N, ...) over the centred windows of ``W`` samples (shortened at
    the ends: the sums are over the samples that exist), and their counts."""
    c = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)])
    n = len(x)
    lo = np.clip(np.arange(n) - W // 2, 0, n)
    hi = np.clip(lo + W, 0, n)
    lo = np.maximum(hi - W, 0)
    return c[hi] - c[lo], (hi - lo)


def stationary(gyro: np.ndarray, accel: np.ndarray, dt: float, gyro_arw: float,
               accel_vrw: float, gyro_bias: float = 0.0, window_s: float = WINDOW_S,
               alpha: float = ALPHA) -> np.ndarray:
    """Which IMU samples lie in a window of a vehicle at rest (bool, (N,)).

    ``gyro`` [rad/s], ``accel`` [m/s^2] (N, 3) at period ``dt`` [s]; ``gyro_arw``
    [rad/sqrt(s)], ``accel_vrw`` [m/s/sqrt(s)] the white-noise densities; ``gyro_bias``
    [rad/s] the 1-sigma turn-on bias (added to the gyro's allowance with the Earth rate).
    """
    gyro = np.asarray(gyro, dtype=float)
    accel = np.asarray(accel, dtype=float)
    n = len(gyro)
    if n == 0:
        return np.zeros(0, dtype=bool)
    W = max(2, int(round(window_s / dt)))
    sa2 = max(accel_vrw, 1e-12) ** 2 / dt
    sw2 = max(gyro_arw, 1e-15) ** 2 / dt + earth.OMEGA_IE**2 + gyro_bias**2
    s_a, cnt = _window_sums(accel, W)
    s_aa, _ = _window_sums(np.sum(accel**2, axis=1), W)
    s_ww, _ = _window_sums(np.sum(gyro**2, axis=1), W)
    scatter = s_aa - np.sum(s_a**2, axis=1) / cnt  # sum ||a_i - mean||^2
    stat = np.maximum(scatter, 0.0) / sa2 + s_ww / sw2
    dof = 3 * (cnt - 1) + 3 * cnt
    return stat <= chi2.ppf(1.0 - alpha, dof)


def still_spans(t: np.ndarray, still: np.ndarray, min_s: float = 0.0) -> list[tuple[float,
                                                                                     float]]:
    """The time spans ``(start, end)`` [s] of consecutive still samples lasting at least
    ``min_s``."""
    s = np.asarray(still, dtype=np.int8)
    edges = np.flatnonzero(np.diff(np.r_[0, s, 0]))
    spans = [(float(t[a]), float(t[b - 1])) for a, b in zip(edges[::2], edges[1::2],
                                                            strict=True)]
    return [sp for sp in spans if sp[1] - sp[0] >= min_s]

"""Stand-still detection from the IMU alone: the SHOE detector.

Skog, Händel, Nilsson, Rantakokko, "Zero-velocity detection — an algorithm evaluation",
IEEE Trans. Biomed. Eng. 57(11), 2010, eq. 9 (the stance hypothesis optimal detector):
over a window of ``W`` samples around sample ``k``,

    T_k = 1/W * sum_i ( ||a_i - mean(a)||^2 / sigma_a^2 + ||w_i||^2 / sigma_w^2 )

with ``a`` the specific force [m/s^2] and ``w`` the angular rate [rad/s] of the body,
``sigma_a``, ``sigma_w`` their per-sample white noise (the IMU's VRW and ARW over
``sqrt(dt)``; or the recording's quietest windows' own noise where that is less than
half of it: a config whose figures hold the vehicle's vibration, as a tuned one's do,
would otherwise call a moving vehicle still).  Skog's detector compares ``a_i`` with
``g`` along the mean direction; the scatter about the window mean used here is the same
test without the local gravity (one accelerometer bias along the vertical does not
matter).  At rest each term is a
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

import numba
import numpy as np

from ..core import earth
from ..core.stats import chi2_ppf

#: Window [s] of the detector.
WINDOW_S = 0.5
#: Probability that a window of a vehicle at rest is called moving.
ALPHA = 1e-3
#: Percentile of the recording's window variances taken as the noise at rest when it is
#: below the figures' (the quietest windows: stops, if there are any).
QUIET_PERCENTILE = 2.0


def _window_sums(x: np.ndarray, W: int) -> np.ndarray:
    """Sums of ``x`` (N, ...) over the centred windows of ``W`` samples (at the ends the
    window is shifted inside the data, still ``W`` long unless N < W), and their
    counts."""
    c = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)])
    n = len(x)
    lo = np.clip(np.arange(n) - W // 2, 0, n)
    hi = np.clip(lo + W, 0, n)
    lo = np.maximum(hi - W, 0)
    return c[hi] - c[lo], (hi - lo)


@numba.njit(cache=True)
def window_scatter(accel, W):
    """Each sample's sum of ``||a_i - mean(a)||^2`` [m^2/s^4] over its centred window of
    ``W`` samples of the specific force ``accel`` (N, 3) (shifted inside the data at the
    ends, ``min(W, N)`` long): the accelerometer term of the detector, from running sums
    (negative round-off clipped to 0)."""
    n = len(accel)
    c0, c1, c2 = np.zeros(n + 1), np.zeros(n + 1), np.zeros(n + 1)  # running sums of a
    cq = np.zeros(n + 1)  # ... and of ||a||^2
    for i in range(n):
        c0[i + 1] = c0[i] + accel[i, 0]
        c1[i + 1] = c1[i] + accel[i, 1]
        c2[i + 1] = c2[i] + accel[i, 2]
        cq[i + 1] = cq[i] + (accel[i, 0] ** 2 + accel[i, 1] ** 2 + accel[i, 2] ** 2)
    scatter = np.empty(n)
    W = min(W, n)
    for i in range(n):
        a = min(max(i - W // 2, 0), n - W)
        b = a + W
        s2 = (c0[b] - c0[a]) ** 2 + (c1[b] - c1[a]) ** 2 + (c2[b] - c2[a]) ** 2
        v = (cq[b] - cq[a]) - s2 / W
        scatter[i] = 0.0 if v < 0.0 else v
    return scatter


def rest_variance(quiet: float, figure: float, floor: float) -> float:
    """A per-sample noise variance at rest: the figures' (``figure``), unless the
    recording's quietest windows (``quiet``) are less than half as noisy (figures that
    hold vibration, as a tuned config's do, would call motion "still"); never below 1e-4
    of the figures' (a noise-free simulation with round-off for its scatter) nor
    ``floor``."""
    return max(quiet if quiet < 0.5 * figure else figure, 1e-4 * figure, floor)


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
    scatter = window_scatter(accel, W)  # sum ||a_i - mean||^2
    s_ww, cnt = _window_sums(np.sum(gyro**2, axis=1), W)
    # Per-sample variances at rest: the figures', unless the data's quietest windows are
    # less than half as noisy (figures that hold vibration, as a tuned config's do, would
    # call motion "still"): the QUIET_PERCENTILE-th percentile of the windows' own
    # variances, scaled by the chi-square's at that percentile (unbiased if at least that
    # share of the windows is still; else it is motion's, above the figures, unused).
    q = QUIET_PERCENTILE / 100.0
    quiet_a = (np.percentile(scatter / (3 * np.maximum(cnt - 1, 1)), QUIET_PERCENTILE)
               / (chi2_ppf(q, 3 * (W - 1)) / (3 * (W - 1))))
    quiet_w = np.percentile(s_ww / (3 * cnt), QUIET_PERCENTILE) / (chi2_ppf(q, 3 * W)
                                                                   / (3 * W))
    sa2 = accel_vrw**2 / dt
    sw2 = gyro_arw**2 / dt + earth.OMEGA_IE**2 + gyro_bias**2
    sa2 = rest_variance(quiet_a, sa2, 1e-24)
    sw2 = rest_variance(quiet_w, sw2, 1e-30)
    stat = scatter / sa2 + s_ww / sw2
    dof = 3 * (cnt - 1) + 3 * cnt
    # (the quantile once per distinct window length: only the edges' windows are shorter)
    dofs, which = np.unique(dof, return_inverse=True)
    return stat <= chi2_ppf(1.0 - alpha, dofs)[which]


def still_spans(t: np.ndarray, still: np.ndarray, min_s: float = 0.0) -> list[tuple[float,
                                                                                     float]]:
    """The time spans ``(start, end)`` [s] of consecutive still samples lasting at least
    ``min_s``."""
    s = np.asarray(still, dtype=np.int8)
    edges = np.flatnonzero(np.diff(np.r_[0, s, 0]))
    spans = [(float(t[a]), float(t[b - 1])) for a, b in zip(edges[::2], edges[1::2],
                                                            strict=True)]
    return [sp for sp in spans if sp[1] - sp[0] >= min_s]

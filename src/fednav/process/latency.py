"""A GNSS velocity's latency seen against the INS: the check for noisy positions.

:func:`fednav.process.checks.velocity_latency` sees a receiver's velocity lag from its
positions' differences, which needs precise positions (RTK: a sigma of 0.002 s on the
real drive; 1.5 m fixes give a sigma above 0.1 s and it gives up).  The INS sees the
vehicle's velocity far better than differenced noisy fixes do: an INS aided by the
positions alone and smoothed holds its velocity to a centimetre per second, and its
acceleration comes from the accelerometers.  So with that solution's horizontal speed
at the antenna ``s_a(t)`` (IMU-rate [m/s]), a receiver's velocity stamped ``t`` that is
``L`` seconds old has the speed

    s_gnss(t) = s_a(t - L) + noise,

and ``L`` is its least-squares fit (Gauss-Newton on ``ds_a/dL = -(speed rate)``; an
epoch whose residual at the current ``L`` lies beyond 5 robust sigmas, a receiver's
glitch, is left out).

The speed, not the velocity vector: a heading error of the INS turns its velocity as a
latency does in a steady turn (``L a = psi x v``, both across the track), and that
heading is what an INS aided by positions alone knows least; the speed does not depend
on it.  A latency then shows only where the speed changes (pulling away, braking), and a
cruise at one speed says nothing (None).  The INS's own speed error is slow (corrected
by the positions over tens of seconds), so the 1-sigma is the cluster-robust one from
:data:`BLOCK_S` blocks of epochs: neighbouring epochs share that error, blocks hardly do.
"""

from __future__ import annotations

import numpy as np

from ..core import attitude as att
from ..core import earth

#: the cluster-robust sigma's blocks [s]
BLOCK_S = 10.0
#: fewest blocks the sigma is taken from (blocks that inform: the effective number by
#: their share of the speed's changes)
MIN_BLOCKS = 8
#: the acceleration is the antenna velocity's difference over +-this [s]
HALF_SPAN_S = 0.25
#: a latency is searched within +-this [s] (``velocity_latency_s`` takes up to 2 s)
MAX_LATENCY_S = 1.0
#: an epoch whose residual is beyond this many robust sigmas is left out
GATE = 5.0
#: epochs slower than this [m/s] are left out (a noisy velocity's speed is biased up by
#: ``sigma^2 / 2 s`` near standstill)
MIN_SPEED_MPS = 1.0


def antenna_velocity(sol, lever) -> np.ndarray:
    """ENU velocity [m/s] of the point at ``lever`` (body right-forward-up, m) along a
    :class:`~fednav.navigator.solution.Solution` (its velocity, attitude and body rate:
    :func:`fednav.core.earth.lever_arm_velocity`)."""
    return earth.lever_arm_velocity(sol.vel, att.euler_to_dcm(sol.euler), sol.omega, lever)


def velocity_latency_ins(t, vel, t_sol, v_ant) -> tuple[float, float] | None:
    """How much older than its stamp a receiver's velocity is [s], and the estimate's
    1-sigma [s], against an INS solution's antenna velocity (module docstring).

    Parameters
    ----------
    t : ndarray, shape (K,)
        The receiver's velocity stamps [s] (the navigator's time).
    vel : ndarray, shape (K, 3)
        Its ENU velocities [m/s].
    t_sol : ndarray, shape (N,)
        The solution's times [s], increasing (IMU rate).
    v_ant : ndarray, shape (N, 3)
        The solution's ENU velocity of the antenna [m/s] (:func:`antenna_velocity`),
        from a run that did not fly these velocities (smoothed: its errors are a
        fraction of the forward filter's).

    Returns
    -------
    tuple of float, or None
        ``(L, sigma)`` [s]: positive for a velocity older than its stamp.  None with
        fewer than :data:`MIN_BLOCKS` blocks of epochs that inform (whose speed changes)
        above :data:`MIN_SPEED_MPS`, or a fit outside +-:data:`MAX_LATENCY_S`.
    """
    t = np.asarray(t, dtype=float)
    v = np.asarray(vel, dtype=float)
    z = np.hypot(v[:, 0], v[:, 1])
    s_sol = np.hypot(v_ant[:, 0], v_ant[:, 1])
    h = HALF_SPAN_S

    def at(s):
        return np.interp(s, t_sol, s_sol)

    inside = ((t - MAX_LATENCY_S - h >= t_sol[0]) & (t + MAX_LATENCY_S + h <= t_sol[-1])
              & np.isfinite(z))
    t, z = t[inside], z[inside]
    moving = at(t) > MIN_SPEED_MPS
    t, z = t[moving], z[moving]
    if len(t) < 2:
        return None
    block = np.floor((t - t[0]) / BLOCK_S).astype(int)

    def fit(L):  # the residual and its derivative d s_a(t - L) / dL = -(speed rate)
        return z - at(t - L), (at(t - L - h) - at(t - L + h)) / (2 * h)

    def gate(e):  # within GATE robust sigmas of the residuals' median
        d = np.abs(e - np.median(e))
        return d <= GATE * max(1.4826 * float(np.median(d)), 1e-6)

    L = 0.0
    for _ in range(12):
        e, J = fit(L)
        # the gate at the current latency (at L = 0 the residuals hold the signal, -L
        # times the speed rate, and a gate there would cut the speed changes themselves)
        keep = gate(e)
        jj = float(np.sum(J[keep] ** 2))
        if jj <= 0.0:
            return None
        step = float(np.sum(J[keep] * e[keep])) / jj
        L += step
        if abs(L) > MAX_LATENCY_S:
            return None
        if abs(step) < 1e-5:
            break
    e, J = fit(L)
    keep = gate(e)
    g = np.bincount(block[keep], weights=J[keep] * e[keep])
    jb = np.bincount(block[keep], weights=J[keep] ** 2)
    jj = float(jb.sum())
    # blocks that inform: their share of the speed's changes (a cruise at one speed has
    # few, and then its sigma would be its one block's)
    nb = jj**2 / max(float(np.sum(jb**2)), 1e-300)
    if nb < MIN_BLOCKS or jj <= 0.0:
        return None
    sigma = float(np.sqrt(np.sum(g * g) * nb / (nb - 1))) / jj
    return float(L), sigma

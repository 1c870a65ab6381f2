"""Delayed measurements: carrying a measurement from its capture instant to the epoch of
use (paper 004).

A measurement describes the instant ``t_c`` (image capture) but reaches the filter at the
first epoch ``t_k`` after it is available.  The strategies (per sensor, see
:class:`~fednav.sim.scenario.TimingConfig`):

* ``none`` — compare it with the INS at ``t_k`` (the delay becomes an error);
* ``curve_fit`` — extrapolate the sensor's own last K values to ``t_k`` with a polynomial;
* ``ins_increment`` — paper 004 eq. 6: compare it with the INS *carried back* to ``t_c``
  by the INS's own increments, ``Z_fixed = Z + (dt1/T) (P(t3) - P(t2)) + (P(tk) - P(t2))``
  with ``t2`` the first epoch after ``t_c``, ``dt1 = t2 - t_c``, ``t3 = t2 + T``.  The
  increments are those of the mechanization alone (the filter's feedback corrections in
  between are not motion and are excluded), for position, velocity and attitude;
* ``recompute`` — re-run the filter from the capture epoch with the stored IMU data
  (the navigator's ``_advance``); the measurement is used at the first epoch after
  ``t_c`` with the fractional increment above (the previous interval's).
"""

from __future__ import annotations

import numpy as np

from ..core import earth
from ..core.attitude import dcm_to_rotvec, rotvec_to_dcm
from .measurement import NavSnapshot


class InsIncrements:
    """Cumulative mechanization-only motion at the filter epochs ``t0 + e T``, e = 0..n:
    position [m ENU, summed per interval], velocity [m/s] and attitude (nav-frame
    rotation ``C_b^n(e) = R(e) ... C_b^n(0)``, corrections excluded)."""

    def __init__(self, n_epochs: int, t0: float, T: float):
        self.t0, self.T = float(t0), float(T)
        self.pos = np.zeros((n_epochs + 1, 3))
        self.vel = np.zeros((n_epochs + 1, 3))
        self.rot = np.tile(np.eye(3), (n_epochs + 1, 1, 1))

    def record(self, e: int, lla_prev, vel_prev, C_prev, lla_now, vel_now, C_now) -> None:
        """The mechanization moved the INS from (prev, after epoch e-1's correction) to
        (now, at epoch e before its correction)."""
        if e >= len(self.pos):  # a stream: room for as many epochs again
            n = len(self.pos)
            self.pos = np.concatenate([self.pos, np.zeros((n, 3))])
            self.vel = np.concatenate([self.vel, np.zeros((n, 3))])
            self.rot = np.concatenate([self.rot, np.tile(np.eye(3), (n, 1, 1))])
        d = earth.llh_difference_enu(lla_now[0], lla_now[1], lla_now[2], lla_prev[0],
                                     lla_prev[1], lla_prev[2])
        self.pos[e] = self.pos[e - 1] + d
        self.vel[e] = self.vel[e - 1] + (np.asarray(vel_now) - vel_prev)
        self.rot[e] = (C_now @ C_prev.T) @ self.rot[e - 1]

    def epoch_after(self, t: float) -> int:
        """Index of the first epoch at or after time ``t``."""
        return int(np.ceil((t - self.t0) / self.T - 1e-9))

    def increment(self, a: int, b: int):
        """Motion from epoch a to b: (dp ENU m, dv m/s, rotation R with C(b) = R C(a))."""
        return (self.pos[b] - self.pos[a], self.vel[b] - self.vel[a],
                self.rot[b] @ self.rot[a].T)

    def carry_back(self, nav: NavSnapshot, k: int, t_c: float) -> NavSnapshot:
        """The INS solution at epoch ``k`` carried back to ``t_c`` by eq. 6."""
        e2 = self.epoch_after(t_c)
        if e2 >= k:  # captured in the last interval: only the fractional part
            e2 = k
        frac = (self.t0 + e2 * self.T - t_c) / self.T
        dp, dv, R = self.increment(e2, k)
        if frac > 0.0:
            a, b = (e2, e2 + 1) if e2 + 1 <= k else (e2 - 1, e2)  # paper: t2 -> t3
            fp, fv, fR = self.increment(max(a, 0), b)
            dp = dp + frac * fp
            dv = dv + frac * fv
            R = R @ rotvec_to_dcm(frac * dcm_to_rotvec(fR))
        return NavSnapshot(earth.move_enu(nav.lla, -dp), nav.vel - dv, R.T @ nav.C, nav.omega_b)


def curve_fit_value(t_hist, z_hist, t_eval: float, degree: int, points: int,
                    angles: tuple = ()) -> np.ndarray:
    """Each component of the last ``points`` values ``z_hist`` (at ``t_hist``) fitted by a
    polynomial of ``degree`` (lower when fewer values exist) and evaluated at ``t_eval``.
    Angle components are unwrapped first (the residuals wrap the difference)."""
    t = np.asarray(t_hist[-points:], dtype=float)
    z = np.array(z_hist[-points:], dtype=float)
    if len(t) < 2:
        return z[-1].copy()
    deg = min(degree, len(t) - 1)
    for c in angles:
        z[:, c] = np.unwrap(z[:, c])
    ref = z[-1].copy()
    tt = t - t[-1]
    coef = np.polyfit(tt, z - ref, deg)  # (deg + 1, m): Horner works row-wise
    return ref + np.polyval(coef, t_eval - t[-1])

"""The navigator's solution at every IMU sample: position, velocity, attitude and their
1-sigma, forward and smoothed.

Between filter epochs the rows are the corrected mechanization; the rows of the epochs
hold the state after the filter's feedback.  The sigmas between epochs interpolate,
linearly in time, from the corrected covariance of the interval's start to the
predicted one of its end.  The smoothed solution removes the RTS smoother's error
estimate (:mod:`fednav.filters.smoother`) from every row: at the epochs its smoothed
error, between them the error interpolated from that of the interval's corrected start
to that of its predicted end.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import attitude as att
from ..filters.smoother import rts_errors
from ..ins import error_model as em
from ..ins.strapdown import correct_rows


@dataclass
class Solution:
    """Navigation solution at every IMU sample, with its 1-sigma.

    Between filter epochs the rows are the corrected mechanization; the rows of the
    epochs (``epoch_rows``) hold the state after the filter's feedback.  The sigmas
    between epochs interpolate, linearly in time, from the corrected covariance of the
    interval's start to the predicted one of its end.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time of each row [s].
    lla : ndarray, shape (N, 3)
        Latitude, longitude [rad] and ellipsoidal height [m] (WGS-84) of the IMU.
    vel : ndarray, shape (N, 3)
        Velocity east, north, up [m/s].
    euler : ndarray, shape (N, 3)
        Attitude [pitch, roll, heading] [rad], body right-forward-up in ENU; heading from
        north toward east.
    sigma : ndarray, shape (N, 9)
        1-sigma of the attitude errors phi east, north, up [rad], velocity errors east,
        north, up [m/s] and position errors east, north, up [m].
    sigma_euler : ndarray, shape (N, 3)
        1-sigma of the Euler angles [pitch, roll, heading] [rad].
    omega : ndarray, shape (N, 3)
        Body angular rate, compensated gyro, body axes [rad/s].
    label : str
        ``"forward"`` or ``"smoothed"``.
    fdi : list of tuple
        The fault-detection log (time [s], local filter, statistic, dof, threshold,
        isolated).
    epoch_rows : ndarray, shape (K+1,), or None
        Row index of each filter epoch [-].
    levels : dict of str to ndarray, or None
        Per row, the protection levels and the alert state when integrity was asked for
        (:mod:`fednav.navigator.integrity`): ``hpl_m``, ``vpl_m`` [m], ``heading_pl_deg``
        [deg], ``integrity_alert`` (1: an alert) and ``excluded`` (the sensor excluded,
        index into the integrity result's ``sensors``; −1 none) [-].
    """

    t: np.ndarray
    lla: np.ndarray
    vel: np.ndarray
    euler: np.ndarray
    sigma: np.ndarray
    sigma_euler: np.ndarray
    omega: np.ndarray
    label: str = "forward"
    fdi: list = field(default_factory=list)
    epoch_rows: np.ndarray | None = None
    levels: dict | None = None

    def rows(self, index) -> Solution:
        """The solution at some of its rows.

        Parameters
        ----------
        index : slice or ndarray
            The rows: a slice, integer indices or a boolean mask [-].

        Returns
        -------
        Solution
            Those rows (its ``epoch_rows`` dropped).
        """
        return Solution(self.t[index], self.lla[index], self.vel[index], self.euler[index],
                        self.sigma[index], self.sigma_euler[index], self.omega[index],
                        self.label, self.fdi, levels=None if self.levels is None
                        else {k: v[index] for k, v in self.levels.items()})


def imu_rate(res, smooth: bool = False, sigmas: bool = True
             ) -> tuple[Solution, Solution | None]:
    """The forward :class:`Solution` at every IMU sample of a navigator's result (recorded
    with ``record_rows`` and ``record_covariance``) and, with ``smooth``, the smoothed one;
    ``sigmas`` False: the motion alone, every 1-sigma NaN (a third of the work saved, for
    a caller that reads none)."""
    if res.rows is None or res.Phi is None:
        raise ValueError("the IMU-rate solution needs a navigator built with "
                         "record_rows=True and record_covariance=True")
    n_cycles = len(res.states) - 1
    if n_cycles < 1:
        raise ValueError("the IMU-rate solution needs one complete filter epoch; none yet")
    n_rows = len(res.rows["q"])
    n_per = (n_rows - 1) // max(n_cycles, 1)
    rows_q, rows_v, rows_p = res.rows["q"], res.rows["vel"], res.rows["lla"]
    rows_w = res.rows["omega"]
    P_post, Phis, Qs, dxs = res.P, res.Phi, res.Qd, res.dx
    t_rows = res.t[0] + res.dt * np.arange(n_rows)
    euler = att.quat_to_euler(rows_q)
    if sigmas:
        P_prior = Phis[1:] @ P_post[:-1] @ np.swapaxes(Phis[1:], 1, 2) + Qs[1:]
        P_prior = np.concatenate([P_post[:1], P_prior])
        sd = _sigmas(euler, _interpolate_intervals(_nav_cov(P_post), _nav_cov(P_prior),
                                                   n_per))
    else:
        sd = _no_sigmas(n_rows)
    forward = Solution(t_rows, rows_p, rows_v, euler, *sd, rows_w, "forward", res.fdi,
                       np.arange(0, n_rows, n_per))
    smoothed = None
    if smooth:
        e, Ps = rts_errors(P_post, Phis, Qs, dxs)
        err = _interpolate_intervals(e[:, :9], e[:, :9] + dxs[:, :9], n_per) * em.SCALE[:9]
        q, v, p = rows_q.copy(), rows_v.copy(), rows_p.copy()
        correct_rows(q, v, p, np.ascontiguousarray(err))
        euler = att.quat_to_euler(q)
        if sigmas:
            cs = _nav_cov(Ps)
            sd = _sigmas(euler, _interpolate_intervals(cs, cs, n_per))
        smoothed = Solution(t_rows, p, v, euler, *sd, rows_w, "smoothed", [],
                            forward.epoch_rows)
    return forward, smoothed


def _no_sigmas(n: int) -> tuple[np.ndarray, np.ndarray]:
    """NaN 1-sigmas of ``n`` rows (read-only views: nothing is allocated)."""
    return np.broadcast_to(np.nan, (n, 9)), np.broadcast_to(np.nan, (n, 3))


def epoch_rate(res) -> Solution:
    """The :class:`Solution` at the filter epochs of a navigator's result whose core
    records no IMU-rate rows (the total-state navigator of paper 003): the state after
    each epoch's update and its 1-sigma; ``omega`` (not recorded) is zero."""
    from ..ins.strapdown import STATE_LLA, STATE_Q, STATE_VEL

    st = res.states
    q = st[:, STATE_Q]
    cov = _nav_cov(res.P)
    euler = att.quat_to_euler(q)
    sd, sd_euler = _sigmas(euler, cov)
    return Solution(res.t.copy(), st[:, STATE_LLA].copy(), st[:, STATE_VEL].copy(),
                    euler, sd, sd_euler, np.zeros((len(st), 3)), "forward",
                    res.fdi, np.arange(len(st)))


def consistency(fdi: list) -> dict[str, dict[str, float]]:
    """Per local filter: mean normalized innovation squared per degree of freedom (about 1
    for a consistent filter; well above 1: the noise figures are too optimistic) and the
    fraction of measurements isolated by fault detection."""
    if not fdi:
        return {}
    _, local, nis, dof, _, iso = zip(*fdi, strict=True)
    r = np.asarray(nis, dtype=float) / np.asarray(dof, dtype=float)
    iso = np.asarray(iso, dtype=float)
    names, which = np.unique(np.asarray(local), return_inverse=True)
    out = {}
    for g, name in enumerate(names):  # (sorted by name)
        m = which == g
        out[str(name)] = {"nis_per_dof": float(r[m].mean()),
                          "isolated_fraction": float(iso[m].mean()),
                          "measurements": int(m.sum())}
    return out



def _nav_cov(P):
    """Variances of the 9 navigation states and the phi cross terms (E-N, E-U, N-U) of
    covariances ``P`` (..., 18, 18), filter units."""
    return np.concatenate([np.diagonal(P[..., :9, :9], axis1=-2, axis2=-1),
                           P[..., [0, 0, 1], [1, 2, 2]]], axis=-1)


def _interpolate_intervals(post, end, n_per: int) -> np.ndarray:
    """Per-epoch quantities (N+1, ...) on the IMU rows of N intervals of ``n_per`` samples:
    row ``(k-1) n_per + m`` lies between ``post[k-1]`` (m = 0) and ``end[k]`` (m = n_per),
    linearly in time, except the epoch rows (m = n_per), which take ``post[k]``."""
    post, end = np.asarray(post, dtype=float), np.asarray(end, dtype=float)
    N, tail = len(post) - 1, post.shape[1:]
    out = np.empty((N * n_per + 1,) + tail)
    out[0] = post[0]
    rows = out[1:].reshape((N, n_per) + tail)  # (a view: written in place)
    f = (np.arange(1, n_per) / n_per).reshape((1, -1) + (1,) * (post.ndim - 1))
    np.multiply(1.0 - f, post[:-1, None], out=rows[:, :-1])
    rows[:, :-1] += f * end[1:, None]
    rows[:, -1] = post[1:]
    return out


def _sigmas(euler, cov) -> tuple[np.ndarray, np.ndarray]:
    """1-sigma (N, 9) of [phi (rad), dv ENU (m/s), dp ENU (m)] and of the Euler angles
    [pitch, roll, heading] (N, 3) [rad] from :func:`_nav_cov` rows (filter units) at the
    attitudes ``euler`` (N, 3) [rad]."""
    sd = np.sqrt(cov[:, :9]) * em.SCALE[:9]
    s = em.SCALE[0] ** 2
    Pphi = np.empty((len(cov), 3, 3))
    Pphi[:, [0, 1, 2], [0, 1, 2]] = cov[:, :3] * s
    for j, (a, b) in zip((9, 10, 11), ((0, 1), (0, 2), (1, 2)), strict=True):
        Pphi[:, a, b] = Pphi[:, b, a] = cov[:, j] * s
    J = att.euler_error_jacobian(euler)
    var = np.sum((J @ Pphi) * J, axis=-1)  # (the diagonal of J P J^T)
    return sd, np.sqrt(np.maximum(var, 0.0))

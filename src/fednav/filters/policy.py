"""The federated filter's rules, written once and compiled: what both the Python
federated filter (:class:`fednav.filters.federated.FederatedFilter`, flown by
:mod:`fednav.navigator.loop`) and the compiled engine (:mod:`fednav.navigator.engine`)
call, so that the two cannot drift apart.

* **Fault detection and recovery** (paper 003, section 2.3): :func:`fdi_gate` gives the
  gate a local filter's measurement is tested against — none (detection off), the
  chi-square threshold, or ``-1`` (test only: the filter is recovering from an
  isolation and comes back after ``recovery`` passes in a row) — and
  :func:`fdi_passes` the count of passes after the test; :func:`is_accepted` the
  decision; :func:`leave_one_out` the unit (a raw GNSS epoch's satellite) whose removal
  explains a failed test (fault detection and exclusion of one satellite).
* **Process-noise adaptation** (``filter.q_adaptation``): :func:`adapt_qlog` moves a
  filter's ``ln s`` by the step times its NIS/dof excess after an accepted measurement,
  :func:`adapted_qd` scales the white part of ``Qd`` by ``s``, and
  :func:`fused_q_scale` is the fused prior's scale ``1 / sum(beta_i / s_i)``.
* **Sharing** (paper 002 eq. 13): :func:`adaptive_shares` — ``beta_i = tr(P_i^-1) /
  sum_j tr(P_j^-1)``.
* **Delay interpolation** (``timing.delay_compensation: interpolate``):
  :func:`validity_sample` — the IMU sample of the epoch's interval nearest a
  measurement's time of validity and the lag left, by which the INS position is moved
  back along its velocity.

The re-admission of a locked-out position source is :func:`fednav.filters.federated.
lockout_step` (with its state arrays); the fusion :func:`fednav.filters.federated.
fuse_information` and :func:`fednav.filters.sr_kernels.sr_fuse`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..core.kernels import cholesky_lower


@numba.njit(cache=True)
def fdi_gate(threshold, passes, recovery):
    """The gate of a local filter's next measurement: ``inf`` when detection is off
    (``threshold`` NaN), ``-1.0`` while the filter recovers from an isolation (fewer than
    ``recovery - 1`` passes in a row: the measurement is tested, never applied), else the
    chi-square ``threshold``."""
    if math.isnan(threshold):
        return np.inf
    if passes + 1 < recovery:
        return -1.0
    return threshold


@numba.njit(cache=True)
def is_accepted(nis, gate):
    """Whether a measurement of statistic ``nis`` passes ``gate`` (:func:`fdi_gate`)."""
    return not nis > gate


@numba.njit(cache=True)
def fdi_passes(threshold, gate, passes, recovery, nis):
    """A local filter's count of consecutive passes after a measurement of statistic
    ``nis`` was tested against ``gate`` (:func:`fdi_gate`): unchanged without detection;
    while recovering, one more for a pass (``nis <= threshold``) and 0 for a fail;
    otherwise ``recovery`` when accepted, 0 when isolated."""
    if math.isnan(threshold):
        return passes
    if gate == -1.0:
        return passes + 1 if nis <= threshold else 0
    return recovery if is_accepted(nis, gate) else 0


@numba.njit(cache=True)
def leave_one_out(r, S, groups, thresholds):
    """The unit to leave out of a measurement that failed its test: ``r`` (m,) its
    residual, ``S`` (m, m) its covariance, ``groups`` (m,) the unit of each row (a raw
    GNSS epoch's satellite: its two rows go together), ``thresholds`` the chi-square
    threshold by number of rows.  Of the units whose removal passes the test of the rows
    left (``r_k' S_kk^-1 r_k``: the same prior, no second prediction), the one that leaves
    the smallest statistic.  Returns (unit, statistic, rows kept); unit -1 when none
    passes or the measurement is one unit (RAIM's leave-one-out on the filter's predicted
    innovation)."""
    units = np.unique(groups)
    best, best_stat = -1, np.inf
    best_keep = np.ones(groups.shape[0], dtype=np.bool_)
    if units.shape[0] < 2:
        return best, np.nan, best_keep
    for u in units:
        keep = groups != u
        idx = np.flatnonzero(keep)
        c = idx.shape[0]
        Sk = np.empty((c, c))
        rk = np.empty(c)
        for i in range(c):
            rk[i] = r[idx[i]]
            for j in range(c):
                Sk[i, j] = S[idx[i], idx[j]]
        L, ok = cholesky_lower(Sk)
        if not ok:
            continue
        stat = 0.0  # |L^-1 r_k|^2
        w = np.empty(c)
        for i in range(c):
            s = rk[i]
            for j in range(i):
                s -= L[i, j] * w[j]
            w[i] = s / L[i, i]
            stat += w[i] * w[i]
        if stat <= thresholds[c] and stat < best_stat:
            best, best_stat, best_keep = u, stat, keep
    return best, (best_stat if best >= 0 else np.nan), best_keep


@numba.njit(cache=True)
def adapt_qlog(qlog, step, nis, dof, logmax):
    """A filter's ``ln s`` (process-noise scale) after an accepted measurement of ``dof``
    components and statistic ``nis``: ``ln s + step (nis / dof - 1)`` within ``[0,
    logmax]``."""
    return min(max(qlog + step * (nis / dof - 1.0), 0.0), logmax)


@numba.njit(cache=True)
def adapted_qd(Qd, Qw, qlog):
    """The filter's process noise with the white part ``Qw`` of ``Qd`` scaled by
    ``s = exp(qlog)``: ``Qd + (s - 1) Qw``."""
    return Qd + (math.exp(qlog) - 1.0) * Qw


@numba.njit(cache=True)
def fused_q_scale(beta, qlog):
    """The fused prior's white-noise scale: ``1 / sum_i(beta_i / s_i)`` (the filters'
    information summed; exact when the scales are equal), 1 when nothing is shared."""
    inv = 0.0
    for f in range(beta.shape[0]):
        inv += beta[f] / math.exp(qlog[f])
    return 1.0 / inv if inv > 0.0 else 1.0


@numba.njit(cache=True)
def adaptive_shares(traces):
    """Adaptive sharing factors from each filter's ``tr(P_i^-1)``: ``tr_i / sum tr``."""
    return traces / traces.sum()


@numba.njit(cache=True)
def validity_sample(t, t_start, dt, n_per):
    """The sample of an epoch's interval (``0`` its start ``t_start`` [s], ``n_per`` its
    end, ``dt`` [s] apart) nearest the time of validity ``t`` [s], and the lag [s] left:
    that sample's time minus ``t`` (the INS there is moved back by ``lag`` along its
    velocity)."""
    j = min(max(int(round((t - t_start) / dt)), 0), n_per)
    return j, t_start + j * dt - t

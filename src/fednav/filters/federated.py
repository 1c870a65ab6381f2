"""Federated filter: local filters + optional master, information sharing and fusion.

Cycle (Carlson's federated filter, paper 002 eq. 13–15, paper 003 eq. 16–22):

1. every filter (locals and master) time-updates with its share of the process noise,
   ``Q_i = Q / beta_i``;
2. local filters measurement-update with their own sensors (the master has none);
3. global fusion ``P_g = (sum P_i^-1)^-1``, ``x_g = P_g sum P_i^-1 x_i`` over every
   filter (when a local filter's covariance is a sample estimate — a
   particle filter — the fused covariance is corrected for the bias that fusing noisy
   covariances introduces, :func:`_sampling_bias_correction`).  When every filter
   keeps a Cholesky factor (``form: square_root``), the fusion is the
   square-root information form (:func:`fednav.filters.sr_kernels.sr_fuse`: the
   information factors ``S_i^-1`` and vectors ``S_i^-1 x_i`` stacked and triangularized;
   no covariance is formed or inverted) and the reset hands each filter the factor
   ``S_g / sqrt(beta_i)``;
4. ``reset`` mode: ``x_i = x_g``, ``P_i = P_g / beta_i``.  ``no_reset`` mode: locals keep
   their own estimates (the fused result is output only).

Sharing factors (``sum beta_i = 1``): ``equal``; ``fixed`` (given values);
``adaptive`` (eq. 13) ``beta_i = tr(P_i^-1) / sum_j tr(P_j^-1)``.  The paper writes the
adaptive rule with the *predicted* covariances; in reset mode those are all ``P_g/beta_i``
transformed alike, so the rule would only return the previous factors.  fednav evaluates
it on each filter's covariance *after* its measurement update, where it does measure the
information each filter gained.  With fusion-reset and a linear model the federated
estimate equals the centralized Kalman filter (tested).

Fault detection and isolation (paper 003, section 2.3), available to every local filter
of every configuration: with ``fdi_alpha`` set (one level for all local filters, or a
dict by local filter name), each local measurement's statistic
``T = r' S^-1 r`` (``r`` the residual against the filter's prediction, ``S`` its
covariance) is compared with the chi-square quantile ``chi2.ppf(1 - alpha, m)``; above
it, the local filter's measurement is left out (the filter is isolated for that epoch)
and it returns automatically at the first epoch whose statistic passes.  The paper
leaves the isolated filter out of the fusion altogether; fednav keeps its share of the
*prior* information in the fusion (it carries no measurement), so the fused covariance
does not jump by the isolated filter's share of the prior.  Every statistic and decision
is recorded in :attr:`FederatedFilter.log`.

Fault isolation cannot lock out the last position source (``fdi_readmit_s``,
:class:`Lockout`): a filter too confident of its IMU figures isolates a sound receiver —
the innovation grows faster than the covariance that should cover it — and would never
re-admit it.  When every position source has been isolated for ``fdi_readmit_s``, the
candidate (the isolated source with the lowest latest NIS/dof) is re-admitted when its
innovation has *drifted* since its isolation began by more than the test allows
(``D = dr' (S + S0)^-1 dr > chi2.ppf(1 - 1e-7, c)``, :data:`READMIT_ALPHA`; ``dr`` the
change of the residual over the ``c`` rows both measurements hold — compared by what
each row measures, :func:`row_ids` — ``S``, ``S0`` the innovation covariances now and
then): the filter, not the sensor, is wrong.  Every filter's covariance is then inflated
by the factor that gives the residual seen its expected statistic (``r' (s HPH' + R)^-1 r
= m``, or less the part no inflation moves where ``HPH'`` spans fewer than the ``m`` rows,
:func:`_inflation`) and the measurement is applied if it passes the test with it.  A
true fault — a receiver that jumps and stays — shows a large residual that does *not*
drift beyond the covariance, and stays isolated.
"""

from __future__ import annotations

import copy
import functools
import math
from collections import namedtuple

import numba
import numpy as np

from ..core.kernels import spd_inverse
from . import policy
from .base import Filter, FilterError
from .sr_kernels import factor_product, sr_fuse


def sharing_factors(covs: dict[str, np.ndarray], rule: str = "equal",
                    fixed: dict[str, float] | None = None) -> dict[str, float]:
    """Information-sharing factors for filters with covariances ``covs``."""
    names = list(covs)
    if rule == "equal":
        return {k: 1.0 / len(names) for k in names}
    if rule == "fixed":
        if fixed is None or set(fixed) != set(names):
            raise ValueError(f"fixed sharing needs a factor for each of {names}")
        s = sum(fixed.values())
        if any(v <= 0 for v in fixed.values()):
            raise ValueError("fixed sharing factors must be positive")
        return {k: fixed[k] / s for k in names}
    if rule == "adaptive":
        tr = {}
        for k, P in covs.items():
            Pinv, ok = spd_inverse(np.ascontiguousarray(P, dtype=float))
            if not ok:
                raise FilterError(f"adaptive sharing: covariance of '{k}' is not positive "
                                  f"definite")
            tr[k] = np.trace(Pinv)
        s = sum(tr.values())
        return {k: tr[k] / s for k in names}
    raise ValueError(f"unknown sharing rule '{rule}'; choose equal, fixed or adaptive")


@numba.njit(cache=True)
def fuse_information(xs, Ps):
    """Information fusion of k estimates: (x_g, P_g, tr(P_i^-1) (k,), index of failure).
    One estimate is its own fusion (returned as it is, its trace set to 1: the sharing
    factor is 1 whatever it is)."""
    k, n = xs.shape
    if k == 1:
        return xs[0].copy(), Ps[0].copy(), np.ones(1), -1
    Ig = np.zeros((n, n))
    v = np.zeros(n)
    tr = np.empty(k)
    for i in range(k):
        Ii, ok = spd_inverse(Ps[i])
        if not ok:
            return v, Ig, tr, i
        Ig += Ii
        v += Ii @ xs[i]
        tr[i] = np.trace(Ii)
    Pg, ok = spd_inverse(0.5 * (Ig + Ig.T))
    if not ok:
        return v, Ig, tr, k
    return Pg @ v, 0.5 * (Pg + Pg.T), tr, -1


#: Test level of the drift test that re-admits a locked-out position source
#: (:func:`lockout_step`), per measurement: strict, as it is tried at every measurement of a
#: long fault (at 20 Hz, 1e-7 is one false re-admission in ~140 h of a true fault, were
#: the tests independent); never looser than the detection level itself.
READMIT_ALPHA = 1e-7


@functools.cache
def drift_threshold(dof: int, alpha: float) -> float:
    """The drift test's threshold for ``dof`` components: the chi-square quantile at
    the stricter of :data:`READMIT_ALPHA` and the detection level ``alpha``."""
    from ..core.stats import chi2_ppf

    return float(chi2_ppf(1.0 - min(alpha, READMIT_ALPHA), dof))


@numba.njit(cache=True)
def _nis_inflated(r, A, R, s):
    """``r' (s A + R)^-1 r`` (inf where that is not positive definite)."""
    Inv, ok = spd_inverse(s * A + R)
    return r @ Inv @ r if ok else np.inf


@numba.njit(cache=True)
def _range_basis(A, floor):
    """Columns spanning the range of the symmetric positive semidefinite ``A`` (m, m):
    ``L`` (m, k) of its pivoted Cholesky factorization ``A = L L'`` (rows in ``A``'s
    order), stopped where the largest diagonal left is round-off (1e-12 of ``A``'s
    largest, and at least ``floor``)."""
    m = A.shape[0]
    W = A.copy()
    L = np.zeros((m, m))
    done = np.zeros(m, dtype=np.bool_)
    top = 0.0
    for i in range(m):
        top = max(top, W[i, i])
    k = 0
    while k < m:
        p, d = -1, max(1e-12 * top, floor)
        for i in range(m):
            if not done[i] and W[i, i] > d:
                p, d = i, W[i, i]
        if p < 0:
            break
        done[p] = True
        root = math.sqrt(d)
        for i in range(m):
            L[i, k] = 0.0 if done[i] and i != p else W[i, p] / root
        for i in range(m):
            for j in range(m):
                W[i, j] -= L[i, k] * L[j, k]
        k += 1
    return np.ascontiguousarray(L[:, :k])


@numba.njit(cache=True)
def _unreached(r, A, R):
    """The part of the statistic ``r' (s A + R)^-1 r`` no inflation ``s`` moves, its limit
    as ``s`` grows (``r`` less its best fit in the range of ``A``, weighted by ``R^-1``),
    and the dimension ``k`` of that range: (limit, k); (0, m) when ``A`` has full rank.
    A measurement of more rows than the states it sees (a raw GNSS epoch: two rows per
    satellite over position, velocity and clock) has such a part."""
    m = r.shape[0]
    big = 0.0  # (A = S - R: its round-off is that of S's largest diagonal)
    for i in range(m):
        big = max(big, abs(A[i, i] + R[i, i]))
    U = _range_basis(A, 16.0 * m * 2.220446049250313e-16 * big)
    k = U.shape[1]
    if k == m:
        return 0.0, m
    Ri, ok = spd_inverse(np.ascontiguousarray(R))
    if not ok:
        return 0.0, m
    # (loops, not BLAS products: this runs at a re-admission only, and compiles quicker)
    w = np.zeros(m)  # R^-1 r
    RiU = np.zeros((m, k))
    for i in range(m):
        for j in range(m):
            w[i] += Ri[i, j] * r[j]
            for c in range(k):
                RiU[i, c] += Ri[i, j] * U[j, c]
    full = 0.0
    for i in range(m):
        full += r[i] * w[i]
    b = np.zeros(k)  # U' R^-1 r
    G = np.zeros((k, k))  # U' R^-1 U
    for c in range(k):
        for i in range(m):
            b[c] += U[i, c] * w[i]
            for e in range(k):
                G[c, e] += U[i, c] * RiU[i, e]
    Gi, ok = spd_inverse(G)
    if not ok:
        return 0.0, m
    fit = 0.0
    for c in range(k):
        for e in range(k):
            fit += b[c] * Gi[c, e] * b[e]
    return max(full - fit, 0.0), k


@numba.njit(cache=True)
def _inflation(r, S, R, nis):
    """The factor ``s`` >= 1 of the filter's part ``A = S - R`` of the innovation
    covariance ``S`` that gives the residual ``r`` its expected statistic, ``r' (s A +
    R)^-1 r = m`` (bisection on ``ln s``; ``R`` not finite: taken as zero, ``s = NIS /
    m``).  Where ``A`` spans ``k < m`` dimensions the target is the part no ``s`` moves
    plus ``k`` (:func:`_unreached`: its expected share, ``m - k``, is what it is); 0 when
    the statistic is already at or below the target (no factor helps)."""
    m = r.shape[0]
    if not math.isfinite(R.sum()):
        return max(nis / m, 1.0)
    A = S - R
    far, k = _unreached(r, A, R)
    target = float(m) if k == m else far + k
    if not _nis_inflated(r, A, R, 1.0) > target:  # (what is left no inflation moves)
        return 0.0
    lo = 0.0
    hi = math.log(max(nis / m, 1.0))
    while _nis_inflated(r, A, R, math.exp(hi)) > target:
        if hi > 80.0:
            return math.exp(hi)
        lo = hi
        hi = hi + 2.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if _nis_inflated(r, A, R, math.exp(mid)) > target:
            lo = mid
        else:
            hi = mid
    return max(math.exp(hi), 1.0)


#: The lockout guard's settings and state (:func:`lockout_step`): ``pos`` (nf,) which
#: filters are position sources; ``hold`` [s] ``fdi_readmit_s`` (NaN: never re-admit);
#: ``state`` (nf, 3) per filter the start [s] of its current run of isolated measurements
#: (NaN: none), the number of rows of its reference and the NIS/dof of its latest
#: isolated measurement; ``r0`` (nf, w), ``S0`` (nf, w, w), ``k0`` (nf, w) the residual,
#: covariance and row keys of the reference (the run's first measurement, or the first
#: with no row in common with it); ``t_pos`` (1,) the time [s] of the last accepted
#: position measurement.
LockoutState = namedtuple("LockoutState", "pos hold state r0 S0 k0 t_pos")


@numba.njit(cache=True)
def common_rows(keys, ref):
    """Positions in ``keys`` and in ``ref`` (int arrays, each without repeats) of the keys
    both hold, in the order of ``keys``."""
    a = np.empty(keys.shape[0], dtype=np.int64)
    b = np.empty(keys.shape[0], dtype=np.int64)
    n = 0
    for i in range(keys.shape[0]):
        for j in range(ref.shape[0]):
            if keys[i] == ref[j]:
                a[n], b[n] = i, j
                n += 1
                break
    return a[:n], b[:n]


@numba.njit(cache=True)
def lockout_step(f, t, accepted, nis, r, S, R, keys, thr_drift, lk):
    """One local measurement through the guard against locking out the last position
    source (the same function in the Python loop and the compiled engine).

    ``f``: the local filter's index; ``t`` [s]: the measurement's time; ``accepted``: what
    the chi-square test decided; ``nis`` = ``r' S^-1 r`` with ``r`` (m,) and ``S`` (m, m)
    its residual and covariance, ``R`` the measurement's noise covariance (filter units;
    not finite where the model makes its own); ``keys`` (m,) what each row measures
    (:func:`row_ids`: the rows of two measurements are compared where their keys agree,
    so a raw GNSS epoch is compared satellite by satellite as satellites rise and set);
    ``thr_drift`` (> m,) the drift test's threshold by number of rows compared
    (:func:`drift_threshold`; NaN: no detection); ``lk``: the guard's settings and state
    (:data:`LockoutState`, its arrays updated in place).

    Returns ``(s, t_start)``: ``s`` > 1 the factor by which to inflate every filter's
    covariance to re-admit this measurement (0: no) — the factor that gives the residual
    seen its expected statistic (:func:`_inflation`; 0 when no factor can) — and
    ``t_start`` [s] when the lockout began."""
    pos, hold, state, r0, S0, k0, t_pos = lk
    if not pos[f]:
        return 0.0, np.nan
    m = r.shape[0]
    if accepted:
        t_pos[0] = t
        state[f, 0] = np.nan
        state[f, 2] = np.inf
        return 0.0, np.nan
    state[f, 2] = nis / m
    now, ref = common_rows(keys, k0[f, :int(state[f, 1])])
    if math.isnan(state[f, 0]) or now.shape[0] == 0:
        if math.isnan(state[f, 0]):  # (a run goes on through a change of reference)
            state[f, 0] = t
        state[f, 1] = m
        r0[f, :m] = r
        S0[f, :m, :m] = S
        k0[f, :m] = keys
        return 0.0, np.nan
    if not (t - state[f, 0] >= hold and t - t_pos[0] >= hold):
        return 0.0, np.nan
    for g in range(pos.shape[0]):  # the most consistent source: the lowest NIS/dof
        if g != f and pos[g] and not math.isnan(state[g, 0]) and state[g, 2] < state[f, 2]:
            return 0.0, np.nan
    c = now.shape[0]
    dr = np.empty(c)
    Sd = np.empty((c, c))
    for i in range(c):
        dr[i] = r[now[i]] - r0[f, ref[i]]
        for j in range(c):
            Sd[i, j] = S[now[i], now[j]] + S0[f, ref[i], ref[j]]
    Inv, ok = spd_inverse(Sd)
    if not ok:
        return 0.0, np.nan
    D = dr @ Inv @ dr
    if not D > thr_drift[c]:  # the residual moved no more than the covariance: a fault
        return 0.0, np.nan
    # the filter, not the sensor: its covariance inflated to cover the innovation seen
    return _inflation(r, S, R, nis), max(state[f, 0], t_pos[0])


def row_ids(model, m: int, rows=None) -> np.ndarray:
    """What each of the ``m`` rows of a measurement of ``model`` measures, as integers
    (:func:`lockout_step`): its ``row_ids`` (a raw GNSS epoch: satellite and kind), else
    its row kinds (:class:`~fednav.sensors.measurement.RowModel`), else the row's
    position among ``m`` (never paired with a row of a measurement of another size);
    ``rows``: the rows an update kept (fault detection left a unit out)."""
    ids = getattr(model, "row_ids", None)
    if ids is None:
        ids = getattr(model, "kinds", None)
    if ids is not None and rows is not None:
        ids = np.asarray(ids)[np.asarray(rows)]
    if ids is None or len(ids) != m:
        ids = np.arange(m) + (m << 20)
    return np.ascontiguousarray(ids, dtype=np.int64)


class Lockout:
    """The state of :func:`lockout_step` for local filters ``names`` of which ``positions``
    fix the position, re-admitting after ``hold_s`` [s] (None: never); ``episodes``:
    one entry per re-admission (:meth:`episode`)."""

    def __init__(self, names: list[str], positions, hold_s: float | None, width: int = 6):
        nf = len(names)
        self.names = list(names)
        self.pos = np.array([k in set(positions) for k in names], dtype=np.bool_)
        self.hold = float("nan") if hold_s is None else float(hold_s)
        self.state = np.zeros((nf, 3))
        self.state[:, 0], self.state[:, 2] = np.nan, np.inf
        self.r0 = np.zeros((nf, width))
        self.S0 = np.zeros((nf, width, width))
        self.k0 = np.zeros((nf, width), dtype=np.int64)
        self.t_pos = np.array([-np.inf])
        self.episodes: list[dict] = []

    def arrays(self) -> LockoutState:
        """The settings and state as :func:`lockout_step` takes them (the arrays
        themselves: updated in place)."""
        return LockoutState(self.pos, self.hold, self.state, self.r0, self.S0, self.k0,
                            self.t_pos)

    @property
    def on(self) -> bool:
        return bool(self.pos.any()) and self.hold > 0.0

    def track(self, f: int, t: float, accepted: bool, nis: float, r, S, R, keys,
              alpha: float | None):
        """:func:`lockout_step` for filter index ``f`` with the rows' ``keys``
        (:func:`row_ids`) and the filter's detection level ``alpha`` (None: none), widening
        the state for a measurement of more than its width."""
        r = np.ascontiguousarray(r, dtype=float).ravel()
        self.widen(len(r))
        thr = np.empty(0) if accepted else np.array(  # (read only for an isolated one)
            [np.nan] + [np.nan if alpha is None else drift_threshold(d, alpha)
                        for d in range(1, len(r) + 1)])
        S = np.ascontiguousarray(S, dtype=float).reshape(len(r), len(r))
        R = np.asarray(R, dtype=float) if R is not None else None
        R = (np.ascontiguousarray(R).reshape(len(r), len(r))
             if R is not None and R.size == len(r) ** 2 else np.full_like(S, np.nan))
        return lockout_step(f, float(t), bool(accepted), float(nis), r, S, R,
                            np.ascontiguousarray(keys, dtype=np.int64), thr, self.arrays())

    def widen(self, w: int) -> None:
        """Room for measurements of ``w`` rows (the state kept as it is)."""
        w0 = self.r0.shape[1]
        if w > w0:
            nf = len(self.names)
            r0, S0, k0 = np.zeros((nf, w)), np.zeros((nf, w, w)), np.zeros((nf, w), np.int64)
            r0[:, :w0], S0[:, :w0, :w0], k0[:, :w0] = self.r0, self.S0, self.k0
            self.r0, self.S0, self.k0 = r0, S0, k0

    def episode(self, f: int, t_start: float, t: float, nis_before: float, s: float,
                nis_after: float, dof: int) -> dict:
        """Record a re-admission: local filter, lockout start and re-admission time [s],
        duration [s], NIS/dof before and after, the covariance inflation."""
        e = {"local": self.names[f], "t_start_s": float(t_start), "t_s": float(t),
             "duration_s": float(t - t_start), "nis_per_dof": float(nis_before / dof),
             "inflation": float(s), "nis_per_dof_after": float(nis_after / dof)}
        self.episodes.append(e)
        return e

    def snapshot(self) -> tuple:
        return (self.state.copy(), self.r0.copy(), self.S0.copy(), self.k0.copy(),
                self.t_pos.copy(), len(self.episodes))

    def restore(self, snap: tuple) -> None:
        state, r0, S0, k0, t_pos, n = snap
        self.state, self.r0, self.S0, self.k0, self.t_pos = (
            state.copy(), r0.copy(), S0.copy(), k0.copy(), t_pos.copy())
        del self.episodes[n:]


def kept_cov(f: Filter) -> np.ndarray:
    """What a filter keeps of its covariance: ``P``, or the factor ``S`` of a factored one
    (restored as it was, with no factorization of ``S S'``)."""
    return f.S if f.form == "square_root" else f.P


def _set_cov(f: Filter, C: np.ndarray) -> None:
    if f.form == "square_root":
        f.S = C
    else:
        f.P = C


def _sampling_bias_correction(Pg, Ps, dofs, names) -> np.ndarray:
    """Remove the second-order bias of ``P_g = (sum P_i^-1)^-1`` when some ``P_i`` are sample
    covariances with ``dof_i`` degrees of freedom (particle filters).

    With ``P_i = Sigma_i^(1/2) (I + E_i) Sigma_i^(1/2)`` and Wishart-like noise
    (``E[E M E] = (M + tr(M) I) / dof``), a second-order expansion gives
    ``E[P_g] = P - sum_i [(n + 1) P A_i P - P A_i P A_i P - tr(P A_i) P A_i P] / dof_i``
    (``A_i = Sigma_i^-1``, ``P`` the true fused covariance).  The bracket vanishes where
    one filter carries all the information and is ``P/dof`` for two equal scalar filters;
    uncorrected, the deficit compounds every fusion-reset cycle and the fused covariance
    collapses.  The plug-in estimate of the bias (``A_i = P_i^-1``, ``P = P_g``) is added
    back.
    """
    n = Pg.shape[0]
    corr = np.zeros_like(Pg)
    for P, dof, name in zip(Ps, dofs, names, strict=True):
        if dof is None:
            continue
        if dof <= n + 1:
            raise FilterError(f"federated fusion: '{name}' has {dof + 1:.1f} effective "
                              f"samples, too few to estimate a covariance of {n} states")
        A, ok = spd_inverse(np.ascontiguousarray(P))
        if not ok:
            raise FilterError(f"federated fusion: covariance of '{name}' is not positive "
                              f"definite")
        PA = Pg @ A
        PAP = PA @ Pg
        corr += ((n + 1 - np.trace(PA)) * PAP - PA @ PAP) / dof
    out = Pg + 0.5 * (corr + corr.T)
    if not np.all(np.isfinite(out)) or np.linalg.eigvalsh(out).min() <= 0:
        raise FilterError("federated fusion: sampling-bias correction left the fused "
                          "covariance not positive definite")
    return out


class FederatedFilter:
    """Federated combination of named local filters and an optional master filter."""

    def __init__(self, locals: dict[str, Filter], master: Filter | None = None,
                 sharing: str = "adaptive", fixed: dict[str, float] | None = None,
                 reset: bool = True, fdi_alpha: float | dict[str, float] | None = None,
                 fdi_recovery: int = 1, fdi_readmit_s: float | None = None,
                 positions=()):
        if not locals:
            raise ValueError("federated filter needs at least one local filter")
        self.locals = dict(locals)
        self.master = master
        self.sharing, self.fixed, self.reset = sharing, fixed, reset
        self.filters: dict[str, Filter] = dict(self.locals)
        if master is not None:
            if "master" in self.locals:
                raise ValueError("a local filter may not be called 'master'")
            self.filters["master"] = master
        self.beta = sharing_factors({k: f.P for k, f in self.filters.items()},
                                    "fixed" if sharing == "fixed" else "equal", fixed)
        first = next(iter(self.filters.values()))
        self.x = first.x.copy()
        self.P = first.P.copy()
        alphas = (dict(fdi_alpha) if isinstance(fdi_alpha, dict)
                  else dict.fromkeys(self.locals, fdi_alpha))
        for k, a in alphas.items():
            if k not in self.locals:
                raise ValueError(f"fdi_alpha given for '{k}', which is not a local filter "
                                 f"(have {list(self.locals)})")
            if a is not None and not 0.0 < a < 1.0:
                raise ValueError(f"fdi_alpha must be in (0, 1), got {a} for '{k}'")
        #: Chi-square test level per local filter (None: no detection for that filter).
        self.fdi_alphas = {k: alphas.get(k) for k in self.locals}
        if fdi_recovery < 1:
            raise ValueError(f"fdi_recovery must be >= 1, got {fdi_recovery}")
        self.fdi_recovery = fdi_recovery
        self.passes = dict.fromkeys(self.locals, fdi_recovery)  # consecutive passes
        if fdi_readmit_s is not None and not fdi_readmit_s > 0.0:
            raise ValueError(f"fdi_readmit_s must be positive, got {fdi_readmit_s}")
        #: the guard against isolating every position source for good: ``positions``
        #: (local filter names) re-admitted after ``fdi_readmit_s`` [s] (None: never)
        self.lockout = Lockout(list(self.filters), [k for k in positions if k in self.locals],
                               fdi_readmit_s)
        #: online process-noise adaptation (:meth:`adapt_q`): step per NIS/dof excess and
        #: the bound of ln(scale); 0, 0: off
        self.q_step, self.q_logmax = 0.0, 0.0
        #: ln of each filter's process-noise scale (0: the figures' Qd)
        self.qlog = dict.fromkeys(self.filters, 0.0)
        self.q_scale_fused = 1.0
        self._thresholds: dict[tuple, float] = {}
        #: One entry per local measurement: t, local, statistic, dof, threshold, isolated.
        self.log: list[tuple] = []
        #: One entry per unit of a measurement left out (:meth:`_exclude`): t, local,
        #: unit (a satellite's number), the statistic without it.
        self.excluded: list[tuple] = []
        if reset:
            for k, f in self.filters.items():
                f.x = self.x.copy()
                f.P = self.P / self.beta[k]

    def share(self, x, P) -> None:
        """Distribute an externally time-updated estimate (paper 003: the master does the
        time update): every filter gets ``x`` and ``P / beta_i``."""
        x = np.asarray(x, dtype=float)
        for k, f in self.filters.items():
            f.x = x.copy()
            f.P = np.asarray(P, dtype=float) / self.beta[k]
            f.step += 1

    def adapt_q(self, step: float, max_scale: float) -> None:
        """Adapt each local filter's process noise online: after every accepted
        measurement ``ln s += step (NIS/dof - 1)`` within ``[0, ln max_scale]``, and the
        filter's time update scales the white part of ``Qd`` (``process.Qd_white``: the
        IMU's ARW and VRW) by ``s`` (:class:`fednav.navigator.system.QAdaptationConfig`)."""
        self.q_step, self.q_logmax = float(step), float(np.log(max_scale))

    def q_scales(self) -> dict[str, float]:
        """Each filter's process-noise scale now (1: the figures')."""
        return {k: float(np.exp(v)) for k, v in self.qlog.items()}

    def predict(self, process) -> None:
        """Time update of every filter with its share of the process noise (the white
        part scaled by the filter's adapted factor, :meth:`adapt_q`)."""
        for k, f in self.filters.items():
            proc = process
            if self.q_step and self.qlog[k] > 0.0:
                proc = copy.copy(process)
                proc.Qd = policy.adapted_qd(process.Qd, process.Qd_white, self.qlog[k])
            f.predict(proc, q_scale=1.0 / self.beta[k] if self.reset else 1.0)
        #: the fused prior's white-noise scale this interval — what the smoother's prior
        #: must use
        self.q_scale_fused = policy.fused_q_scale(
            np.array([self.beta[k] for k in self.filters]),
            np.array([self.qlog[k] for k in self.filters]))

    def threshold(self, dof: int, local: str | None = None) -> float:
        """Chi-square detection threshold for ``dof`` measurement components of local filter
        ``local`` (default: the first), NaN where detection is off."""
        alpha = self.fdi_alphas[local if local is not None else next(iter(self.locals))]
        if alpha is None:
            return float("nan")
        key = (dof, alpha)
        if key not in self._thresholds:
            from ..core.stats import chi2_ppf

            self._thresholds[key] = float(chi2_ppf(1.0 - alpha, dof))
        return self._thresholds[key]

    @property
    def readmissions(self) -> list[dict]:
        """One entry per re-admission of an isolated position source
        (:meth:`Lockout.episode`)."""
        return self.lockout.episodes

    def update(self, local: str, y, model, nav=None, R=None, t: float = float("nan"),
               readmit: bool = True, share: float = 1.0):
        """Measurement update of local filter ``local`` (at time ``t`` [s], for the log),
        with chi-square fault detection when ``fdi_alpha`` is set; ``readmit``: whether
        the measurement is one of its sensor's (a constraint applied to every local filter
        is not), seen by the lockout guard (:func:`lockout_step`).

        ``share`` (0 < share <= 1): the part of the measurement's information this local
        filter takes, when one measurement goes to several of them (the wind constraint):
        it is updated with ``R / share`` (``R`` must be given), and its test statistic —
        about ``share`` times the statistic of the whole measurement, since the local
        filter holds ``P / beta`` — is divided by ``share`` for the gate, the log and the
        Q adaptation."""
        try:
            f = self.locals[local]
        except KeyError:
            raise ValueError(f"no local filter named '{local}' (have {list(self.locals)})") \
                from None
        dof = len(np.atleast_1d(y))
        thr = self.threshold(dof, local)
        if share != 1.0:
            if not 0.0 < share <= 1.0 or R is None or readmit:
                raise ValueError(f"update of '{local}': a share of {share} needs 0 < share "
                                 f"<= 1, an explicit R and readmit=False")
            R = np.asarray(R, dtype=float) / share
        # the gate (none, the threshold, or -1 while recovering: test only) and the
        # passes after the test (policy.fdi_gate, fdi_passes: the engine's rules too)
        gate = policy.fdi_gate(thr, self.passes[local], self.fdi_recovery)
        inn = f.update(y, model, nav, R, gate=None if math.isinf(gate) else gate * share)
        if (not inn.accepted and 0.0 <= gate < math.inf  # (a failed test, not recovery)
                and getattr(model, "groups", None) is not None):
            inn = self._exclude(local, f, y, model, nav, R, t, inn)
            dof, thr = len(inn.r), self.threshold(len(inn.r), local)
        self.passes[local] = policy.fdi_passes(thr, gate, self.passes[local],
                                                self.fdi_recovery, inn.nis / share)
        if readmit and self.lockout.on:
            inn = self._readmit(local, f, y, model, nav, R, t, thr, inn)
        nis = inn.nis / share
        self.log.append((t, local, nis, dof, thr, not inn.accepted))
        if self.q_step and inn.accepted:
            self.qlog[local] = policy.adapt_qlog(self.qlog[local], self.q_step, nis, dof,
                                                 self.q_logmax)
        return inn

    def _exclude(self, local, f, y, model, nav, R, t, inn):
        """A measurement of several units (a raw GNSS epoch's satellites: ``model.groups``,
        the unit of each row) that failed its test, with one unit left out: of the units
        whose removal passes the test of the rows left (the innovation's own ``S``
        restricted to them — the same prior, no second prediction), the one that leaves
        the smallest statistic, and the update made with the rows left (logged in
        :attr:`excluded`); ``inn`` itself when no single unit explains the failure or the
        measurement is one unit.  Fault detection and exclusion of one satellite, not the
        receiver (RAIM's leave-one-out, on the filter's predicted innovation)."""
        groups = np.ascontiguousarray(model.groups, dtype=np.int64)
        r, S = np.asarray(inn.r, dtype=float), np.asarray(inn.S, dtype=float)
        u, stat, keep = policy.leave_one_out(
            np.ascontiguousarray(r), np.ascontiguousarray(S), groups,
            np.array([self.threshold(d, local) if d else np.nan
                      for d in range(len(r) + 1)]))
        if u < 0:
            return inn
        rows = np.flatnonzero(keep)
        new = f.update(np.asarray(y, dtype=float)[rows], model.subset(keep), nav,
                       np.asarray(R, dtype=float)[np.ix_(rows, rows)],
                       gate=self.threshold(len(rows), local))
        if new.accepted:
            self.excluded.append((t, local, int(u), float(stat)))
            return new._replace(rows=rows)
        return inn

    def _readmit(self, local, f, y, model, nav, R, t, thr, inn):
        """The lockout guard on a measurement of ``local``: re-admitted, every filter's
        covariance inflated, when :func:`lockout_step` says so and it then passes the test."""
        lk = self.lockout
        i = lk.names.index(local)
        alpha = self.fdi_alphas[local]
        s, t_start = lk.track(i, t, inn.accepted, inn.nis, inn.r, inn.S, R,
                              row_ids(model, len(inn.r), inn.rows), alpha)
        if not s > 0.0:
            return inn
        saved = [(g, g.x, kept_cov(g)) for g in self.filters.values()]
        for g in self.filters.values():
            g.inflate(s)
        try:
            new = f.update(y, model, nav, R, gate=thr)
        except FilterError:
            new = None
        if new is None or not new.accepted:
            for g, x, P in saved:
                g.x = x
                _set_cov(g, P)
            return inn
        self.passes[local] = self.fdi_recovery
        lk.track(i, t, True, new.nis, new.r, new.S, R, row_ids(model, len(new.r), new.rows),
                 alpha)
        lk.episode(i, t_start, t, inn.nis, s, new.nis, len(new.r))
        return new

    def fuse(self) -> tuple[np.ndarray, np.ndarray]:
        """Global fusion of every filter (an isolated measurement leaves its filter with
        its share of the prior); then reset (in reset mode)."""
        use = self.filters
        names = list(use)
        xs = np.array([use[k].x for k in names])
        # every filter factored: square-root information fusion (no covariance inverted)
        factored = all(f.form == "square_root" for f in use.values())
        if factored:
            xg, Sg, traces, bad = sr_fuse(xs, np.array([use[k].S for k in names]))
        else:
            Ps = np.array([use[k].P for k in names])
            xg, Pg, traces, bad = fuse_information(xs, Ps)
        if bad >= 0:
            who = names[bad] if bad < len(names) else "fused information"
            raise FilterError(f"federated fusion: covariance of '{who}' is not positive "
                              f"definite")
        if factored:
            Pg = factor_product(Sg)
        else:
            dofs = [getattr(use[k], "covariance_dof", None) for k in names]
            if any(d is not None for d in dofs):
                Pg = _sampling_bias_correction(Pg, Ps, dofs, names)
        self.x, self.P = xg, Pg
        if self.reset:
            if self.sharing == "adaptive":
                self.beta.update(zip(names, policy.adaptive_shares(traces).tolist(),
                                     strict=True))
            for k, f in use.items():
                f.x = self.x.copy()
                if factored:
                    f.S = Sg / math.sqrt(self.beta[k])
                else:
                    f.P = self.P / self.beta[k]
        return self.x, self.P

    def snapshot(self) -> tuple:
        """Everything the filter carries from epoch to epoch (for re-running from the past,
        :meth:`restore`); the log keeps its entries up to this point."""
        return ([(f.x.copy(), kept_cov(f).copy(), f.step) for f in self.filters.values()],
                self.x.copy(), self.P.copy(), dict(self.beta), dict(self.passes),
                (len(self.log), len(self.excluded)), dict(self.qlog),
                self.lockout.snapshot())

    def restore(self, snap: tuple) -> None:
        """Return to a :meth:`snapshot` (log entries made since are dropped)."""
        filters, self.x, self.P, beta, passes, n_log, qlog, lockout = snap
        self.qlog = dict(qlog)
        self.lockout.restore(lockout)
        for f, (x, P, step) in zip(self.filters.values(), filters, strict=True):
            f.x, f.step = x.copy(), step
            _set_cov(f, P.copy())
        self.x, self.P = self.x.copy(), self.P.copy()
        self.beta, self.passes = dict(beta), dict(passes)
        del self.log[n_log[0]:]
        del self.excluded[n_log[1]:]

    def feedback(self) -> np.ndarray:
        """Hand the fused error estimate to the navigation system and zero it in the filters.

        Returns the correction that was removed (closed-loop error-state filtering).
        """
        dx = self.x.copy()
        self.x = np.zeros_like(dx)
        for f in self.filters.values():
            f.x = f.x - dx
        return dx

"""The navigator's cycle compiled: a run of filter epochs in one numba call.

The same cycle as :mod:`fednav.navigator.loop` (mechanize, predict, update, fuse, feed
back) for the error-state core, over arrays: the strapdown of :mod:`fednav.ins.
strapdown`, the error model of :mod:`fednav.ins.error_model`, the filters' own kernels
(:mod:`fednav.filters.kf`, :mod:`fednav.filters.ukf`, the federated fusion) and each
sensor's measurement kernels (:class:`fednav.sensors.measurement.Kernels`, passed in as
functions).  Nothing in an epoch goes back to the interpreter, so a Monte Carlo run and
a recorded file cost the same per epoch; the epochs of a stream are run as they become
ready, with the same operations as in one batch.

A system runs here when every part has a compiled form (:func:`why_not_compiled` says
which does not): local filters of the Kalman (``kf``, ``ekf``), unscented (``ukf``) or
simplified unscented (``sukf``) family, fusion-reset federation, sensors with kernels,
measurements used at their time of validity (``interpolate``) or at the epoch
(``none``), no constraint.  Every other system runs the Python loop; the test suite flies
both on the same data and finds them equal.
"""

from __future__ import annotations

import math
import warnings

import numba
import numpy as np
from numba.core.errors import NumbaExperimentalFeatureWarning

from ..core import earth
from ..core.kernels import cholesky_lower
from ..core.kernels import quat_to_dcm as _q2dcm
from ..filters.federated import _fuse
from ..filters.kf import _joseph_update, _propagate
from ..filters.ukf import _predict_moments, _sigma_points, _update
from ..ins import error_model as em
from ..ins.error_model import _interval, _transition
from ..ins.strapdown import _correct
from ..ins.strapdown import _run as _strapdown_run

#: Filter families the engine runs: the filter registry's names -> (time update,
#: measurement update) 0 Kalman (linear covariance, nonlinear mean) / 1 unscented.
FAMILIES = {"kf": (0, 0), "ekf": (0, 0), "ukf": (1, 1), "sukf": (1, 0)}
#: Failure codes of :func:`run_epochs` -> (phase, the error the Python loop would raise).
FAILURES = {1: ("", "navigation state became non-finite"),
            2: ("predict", "covariance is not positive definite (sigma points)"),
            3: ("predict", "state or covariance became NaN/inf"),
            4: ("update", "innovation covariance not positive definite"),
            5: ("update", "covariance is not positive definite"),
            6: ("", "covariance is not positive definite"),
            7: ("update", "covariance is not positive definite (sigma points)"),
            8: ("update", "state or covariance became NaN/inf")}
#: How a measurement's residual meets the INS (``TimingConfig.delay_compensation``).
HOWS = {"none": 0, "interpolate": 1}


def why_not_compiled(system, sensors: list, specs: dict) -> str | None:
    """None when the engine runs ``system`` (aiding ``sensors``), else why not."""
    f = system.filter
    if f.state != "error":
        return "the total-state navigator"
    if f.architecture != "federated":
        return "a centralized filter"
    if not f.reset:
        return "federation without reset"
    if system.constraint is not None:
        return f"the {system.constraint} constraint"
    types = {f.type_of(a) for a in sensors} | ({f.type} if f.master else set())
    for t in sorted(types):
        if t not in FAMILIES:
            return f"'{t}' filters"
    for a in sensors:
        if specs[a].kernels is None:
            return f"sensor '{a}' (no compiled model)"
        how = system.sensors[a].timing.delay_compensation
        if how not in HOWS:
            return f"delay compensation '{how}' ({a})"
    return None


@numba.njit(cache=True)
def _nav_buffers(lla, vel, src_p, src_v):
    for j in range(3):
        lla[j] = src_p[j]
        vel[j] = src_v[j]


@numba.njit(cache=True)
def run_epochs(k0, n_ep, state, comp, dtheta, dv, h_ref, gains, cst, noise, nsub, n_per,
               X, P, beta, passes, fam, c, Wm, Wc, thr, recovery, sharing,
               m_epoch, m_filter, m_sensor, m_how, m_t, m_z, m_R, m_dim, m_aux,
               residual_fns, jacobian_fns, predict_fns, linear,
               out_states, out_P, out_beta, out_Phi, out_Qd, out_dx, out_rows,
               out_nis, out_acc, out_r, out_S, out_bm, out_thr, out_tlog):
    """Fly epochs ``k0 + 1 .. k0 + n_ep`` (1-based) in place on ``state`` (the INS),
    ``comp`` (gyro and accelerometer compensation) and the filters ``X``, ``P``, ``beta``,
    ``passes`` (locals, then the master).

    ``cst`` = [dt, T, t0, k1, k2, 1/tau_g, 1/tau_a]; ``dtheta``, ``dv``, ``h_ref``: the
    epochs' IMU increments and baro heights; ``fam`` (nf, 2) each filter's time/
    measurement-update family; ``c``, ``Wm``, ``Wc`` its unscented constants; ``thr``
    (nf, 7) its chi-square threshold by dof (NaN: no detection); ``sharing`` 0 equal,
    1 fixed, 2 adaptive.  ``m_*``: the epochs' measurements in the order they are applied
    (epoch index, local filter, sensor, how, time of validity, z, R, dimension, kernel
    parameters).  Outputs per epoch and per measurement (``out_rows`` of zero length:
    no IMU-rate rows).  Returns (failure code, epoch, filter); code 0 when all flew."""
    dt, T, t0 = cst[0], cst[1], cst[2]
    k1g, k2g, itg, ita = cst[3], cst[4], cst[5], cst[6]
    nf, n = X.shape
    scale = em.SCALE
    rows_on = out_rows.shape[0] > 0
    dth = np.empty((n_per, 3))
    dvc = np.empty((n_per, 3))
    rq = np.empty((n_per, 4))
    rv = np.empty((n_per, 3))
    rp = np.empty((n_per, 3))
    lla = np.empty(3)
    vel = np.empty(3)
    omega = np.empty(3)
    row_q = np.empty(4)
    m = 0
    n_meas = m_epoch.shape[0]
    for e in range(n_ep):
        k = k0 + 1 + e
        b = e * n_per
        for i in range(n_per):
            for j in range(3):
                dth[i, j] = dtheta[b + i, j] - comp[j] * dt
                dvc[i, j] = dv[b + i, j] - comp[3 + j] * dt
        s0 = state.copy()
        _strapdown_run(state, dth, dvc, dt, h_ref[b:b + n_per], gains, rq, rv, rp)
        if not math.isfinite(state.sum()):
            return 1, k, -1
        params, Cm, Phi, Qd = _interval(s0, state, dvc.sum(axis=0), T, k1g, k2g, itg, ita,
                                        noise, scale)
        for f in range(nf):
            q_scale = 1.0 / beta[f]
            if fam[f, 0] == 0:  # Kalman: the mean through the nonlinear model
                x1 = _transition(X[f].copy().reshape(1, n), T, nsub, params, Cm, scale)[0]
                Pn, ok = _propagate(Phi, P[f], Qd, q_scale)
                if not ok or not math.isfinite(x1.sum()):
                    return 3, k, f
                X[f] = x1
                P[f] = Pn
            else:
                S = _sigma_points(X[f], P[f], c[f])
                if S.shape[0] == 0:
                    return 2, k, f
                Q = Qd if q_scale == 1.0 else q_scale * Qd
                x1, Pn, ok = _predict_moments(_transition(S, T, nsub, params, Cm, scale),
                                              Wm[f], Wc[f], Q)
                if not ok:
                    return 3, k, f
                X[f] = x1
                P[f] = Pn
        for j in range(3):
            omega[j] = dth[:, j].sum() / T
        C_ep = _q2dcm(state[0:4])
        while m < n_meas and m_epoch[m] == k:
            f = m_filter[m]
            s = m_sensor[m]
            d = m_dim[m]
            # the INS the residual compares with: at the epoch, or at the sample nearest
            # the time of validity moved by the remaining lag
            C = C_ep
            t_log = t0 + T * k
            _nav_buffers(lla, vel, state[7:10], state[4:7])
            if m_how[m] == 1:
                t_log = m_t[m]
                tk0 = t0 + T * (k - 1)
                jj = min(max(int(round((m_t[m] - tk0) / dt)), 0), n_per)
                lag = tk0 + jj * dt - m_t[m]
                if jj == 0:
                    _nav_buffers(lla, vel, s0[7:10], s0[4:7])
                    for j in range(4):
                        row_q[j] = s0[j]
                else:
                    _nav_buffers(lla, vel, rp[jj - 1], rv[jj - 1])
                    for j in range(4):
                        row_q[j] = rq[jj - 1, j]
                lla[0], lla[1], lla[2] = earth.moved_nb(
                    lla[0], lla[1], lla[2], -lag * vel[0], -lag * vel[1], -lag * vel[2])
                C = _q2dcm(row_q)
            y = np.empty(d)
            residual_fns[s](lla, vel, C, omega, m_z[m], m_aux[m], y)
            R = m_R[m, :d, :d].copy()
            H = np.zeros((d, n))
            if fam[f, 1] == 0 or linear[s]:
                jacobian_fns[s](lla, vel, C, omega, m_aux[m], H)
            if fam[f, 1] == 0:  # Kalman: Joseph form
                if linear[s]:
                    yhat = H @ X[f]
                else:
                    Z = np.empty((1, d))
                    predict_fns[s](lla, vel, C, omega, m_aux[m], X[f].copy().reshape(1, n), Z)
                    yhat = Z[0]
                r = y - yhat
                x1, Pn, Sm, ni, ok = _joseph_update(X[f], P[f], H, r, R)
                if not ok:
                    return 4, k, f
            else:
                Sg = _sigma_points(X[f], P[f], c[f])
                if Sg.shape[0] == 0:
                    return 7, k, f
                if linear[s]:
                    Z = Sg @ H.T
                else:
                    Z = np.empty((Sg.shape[0], d))
                    predict_fns[s](lla, vel, C, omega, m_aux[m], Sg, Z)
                x1, Pn, r, Sm, ni, ok = _update(Sg, Z, Wm[f], Wc[f], X[f], P[f], y, R)
                if not ok or not math.isfinite(ni):
                    return 4, k, f
            # chi-square fault detection (FederatedFilter.update)
            th = thr[f, d]
            gate = np.inf
            if not math.isnan(th):
                if passes[f] + 1 < recovery:
                    gate = -1.0
                    passes[f] = passes[f] + 1 if ni <= th else 0
                else:
                    gate = th
            accepted = not (ni > gate)
            if not math.isnan(th) and gate != -1.0:
                passes[f] = recovery if accepted else 0
            if accepted:
                if not math.isfinite(x1.sum() + Pn.sum()):
                    return 8, k, f
                if not cholesky_lower(Pn)[1]:
                    return 5, k, f
                X[f] = x1
                P[f] = Pn
            out_nis[m] = ni
            out_acc[m] = accepted
            out_r[m, :d] = r
            out_S[m, :d, :d] = Sm
            out_bm[m] = beta[f]
            out_thr[m] = th
            out_tlog[m] = t_log
            m += 1
        xg, Pg, traces, bad = _fuse(X, P)
        if bad >= 0:
            return 6, k, bad
        if sharing == 2:
            s_tr = traces.sum()
            for f in range(nf):
                beta[f] = 1.0 * traces[f] / s_tr
        for f in range(nf):
            X[f] = xg - xg  # reset to the fused estimate, then its feedback (zero)
            P[f] = Pg / beta[f]
            out_beta[e, f] = beta[f]
        dx = xg * scale
        _correct(state, dx[0:3], dx[3:6], dx[6:9])
        for j in range(3):
            comp[j] += dx[9 + j] + dx[12 + j]
            comp[3 + j] += dx[15 + j]
        out_states[e] = state
        out_P[e] = Pg
        if out_Phi.shape[0] > 0:
            out_Phi[e] = Phi
            out_Qd[e] = Qd
            out_dx[e] = xg
        if rows_on:
            r0 = e * n_per
            for i in range(n_per):
                for j in range(4):
                    out_rows[r0 + i, j] = rq[i, j]
                for j in range(3):
                    out_rows[r0 + i, 4 + j] = rv[i, j]
                    out_rows[r0 + i, 7 + j] = rp[i, j]
                    out_rows[r0 + i, 10 + j] = dth[i, j] / dt
            for j in range(10):  # the epoch row: after the feedback
                out_rows[r0 + n_per - 1, j] = state[j]
    return 0, -1, -1


class CompiledLoop:
    """The engine with the interface of :class:`~fednav.navigator.loop.PythonLoop`: it
    flies the epochs handed to :meth:`run` and keeps the same :class:`Record`.

    ``core``: the :class:`~fednav.navigator.loop.ErrorStateCore` (its INS state and
    compensation are flown in place); ``fed``: the federated filter as built (its
    filters' names, types, starting estimates and sharing; its arrays are flown here);
    ``meas``: the aiding sensors' :class:`~fednav.navigator.loop.Meas`, in aiding order."""

    def __init__(self, core, fed, meas, specs, t0, T, dt, n_per, record_rows,
                 record_cov, innovations):
        from scipy.stats import chi2

        from .loop import Record

        self.core, self.fed, self.meas = core, fed, meas
        self.t0, self.T, self.dt, self.n_per = float(t0), float(T), float(dt), int(n_per)
        self.record_rows, self.record_cov, self.innovations = (record_rows, record_cov,
                                                                innovations)
        self.names = list(fed.filters)
        filters = list(fed.filters.values())
        nf, n = len(filters), core.n
        self.X = np.array([f.x for f in filters])
        self.P = np.array([f.P for f in filters])
        self.beta = np.array([fed.beta[k] for k in self.names])
        self.passes = np.array([fed._passes.get(k, 0) for k in self.names], dtype=np.int64)
        self.fam = np.array([FAMILIES[type_name(f)] for f in filters], dtype=np.int64)
        n_sig = 2 * n + 1
        self.c = np.ones(nf)
        self.Wm = np.zeros((nf, n_sig))
        self.Wc = np.zeros((nf, n_sig))
        for i, f in enumerate(filters):
            if hasattr(f, "Wm"):
                self.c[i], self.Wm[i], self.Wc[i] = f.c, f.Wm, f.Wc
        self.thr = np.full((nf, 7), np.nan)
        for i, k in enumerate(self.names):
            a = fed.fdi_alphas.get(k)
            if a is not None:
                self.thr[i, 1:] = [float(chi2.ppf(1.0 - a, d)) for d in range(1, 7)]
        self.recovery = int(fed.fdi_recovery)
        self.sharing = {"equal": 0, "fixed": 1, "adaptive": 2}[fed.sharing]
        self.local_index = {k: i for i, k in enumerate(self.names)}
        self.sensor_index = {m.name: i for i, m in enumerate(meas)}
        kern = [specs[m.name].kernels for m in meas]
        self.residual_fns = tuple(k.residual for k in kern)
        self.jacobian_fns = tuple(k.jacobian for k in kern)
        self.predict_fns = tuple(k.predict for k in kern)
        self.linear = np.array([k.linear for k in kern])
        self.aux = {m.name: np.ascontiguousarray(np.resize(m.model.aux, 3), dtype=float)
                    for m in meas}
        self.comp = np.r_[core.comp_g, core.comp_a]
        self.gains = core.ins.baro_gains
        k1, k2, itg, ita, noise = em.model_constants(core.noise, core.baro_gains, core.baro_q)
        self.noise_vec = noise
        self.cst = np.array([self.dt, self.T, self.t0, k1, k2, itg, ita])
        self.rec = Record()
        self.k = 0
        s = core.state
        self.rec.states.append(s.copy())
        self.rec.P.append(fed.P.copy())
        self.Pg = fed.P.copy()
        if record_cov:
            self.rec.Phi.append(np.zeros((n, n)))
            self.rec.Qd.append(np.zeros((n, n)))
            self.rec.dx.append(np.zeros(n))
        if record_rows:
            self.rec.rows.append((s[0:4][None].copy(), s[4:7][None].copy(),
                                  s[7:10][None].copy(), None))
        self.log: list = []

    @property
    def comp_g(self) -> np.ndarray:
        return self.comp[:3]

    @property
    def comp_a(self) -> np.ndarray:
        return self.comp[3:]

    def fused_P(self) -> np.ndarray:
        return self.Pg

    def run(self, k0: int, k1: int, dtheta, dv, h_ref, todo: list) -> None:
        """Epochs ``k0 + 1 .. k1`` with their IMU data and ``todo`` = [(epoch, [(Meas,
        index), ...])]."""
        from ..filters import FilterError
        from .loop import InnovationRecord

        n_ep = k1 - k0
        if n_ep <= 0:
            return
        items = [(k, m, i) for k, lst in todo for m, i in lst]
        M = len(items)
        m_epoch = np.array([k for k, _, _ in items], dtype=np.int64)
        m_filter = np.array([self.local_index[m.name] for _, m, _ in items], dtype=np.int64)
        m_sensor = np.array([self.sensor_index[m.name] for _, m, _ in items], dtype=np.int64)
        m_how = np.array([HOWS[m.how] for _, m, _ in items], dtype=np.int64)
        m_t = np.array([m.t[i] for _, m, i in items], dtype=float)
        m_dim = np.array([len(m.R[i]) for _, m, i in items], dtype=np.int64)
        m_z = np.zeros((M, 6))
        m_R = np.zeros((M, 6, 6))
        m_aux = np.zeros((M, 3))
        for j, (_, m, i) in enumerate(items):
            z = m.z[i]
            m_z[j, :len(z)] = z
            d = m_dim[j]
            m_R[j, :d, :d] = m.R[i]
            m_aux[j] = self.aux[m.name]
        n, nf = self.X.shape[1], self.X.shape[0]
        out_states = np.empty((n_ep, len(self.core.state)))
        out_P = np.empty((n_ep, n, n))
        out_beta = np.empty((n_ep, nf))
        nc = n_ep if self.record_cov else 0
        out_Phi, out_Qd, out_dx = np.empty((nc, n, n)), np.empty((nc, n, n)), np.empty((nc, n))
        out_rows = np.empty((n_ep * self.n_per if self.record_rows else 0, 13))
        out_nis, out_acc = np.empty(M), np.empty(M, dtype=np.bool_)
        out_r, out_S = np.zeros((M, 6)), np.zeros((M, 6, 6))
        out_bm, out_thr, out_tlog = np.empty(M), np.empty(M), np.empty(M)
        args = (k0, n_ep, self.core.state, self.comp, np.ascontiguousarray(dtheta),
                np.ascontiguousarray(dv), np.ascontiguousarray(h_ref, dtype=float), self.gains,
                self.cst, self.noise_vec, self.core.nsub, self.n_per, self.X, self.P,
                self.beta, self.passes, self.fam, self.c, self.Wm, self.Wc, self.thr,
                self.recovery, self.sharing, m_epoch, m_filter, m_sensor, m_how, m_t, m_z,
                m_R, m_dim, m_aux, self.residual_fns, self.jacobian_fns, self.predict_fns,
                self.linear, out_states, out_P, out_beta, out_Phi, out_Qd, out_dx, out_rows,
                out_nis, out_acc, out_r, out_S, out_bm, out_thr, out_tlog)
        with warnings.catch_warnings():  # numba: first-class functions are "experimental"
            warnings.simplefilter("ignore", NumbaExperimentalFeatureWarning)
            code, k, f = run_epochs(*args)
        if code:
            phase, why = FAILURES[code]
            if code == 1:
                raise FilterError(f"strapdown INS at step {k}: {why}")
            if code == 6:
                raise FilterError(f"federated fusion: covariance of '{self.names[f]}' is "
                                  f"not positive definite (epoch {k})")
            raise FilterError(f"{self.fed.filters[self.names[f]].name} {phase} at step {k}: "
                              f"{why}")
        r = self.rec
        for e in range(n_ep):
            r.states.append(out_states[e].copy())
            r.P.append(out_P[e])
            r.beta.append(dict(zip(self.names, out_beta[e], strict=True)))
        self.Pg = out_P[-1].copy()
        if self.record_cov:
            r.Phi.extend(out_Phi)
            r.Qd.extend(out_Qd)
            r.dx.extend(out_dx)
        if self.record_rows:
            r.rows.append((out_rows[:, 0:4], out_rows[:, 4:7], out_rows[:, 7:10],
                           out_rows[:, 10:13]))
        for j, (_, m, i) in enumerate(items):
            d = int(m_dim[j])
            acc = bool(out_acc[j])
            self.log.append((float(out_tlog[j]), m.name, float(out_nis[j]), d,
                             float(out_thr[j]), not acc))
            if self.innovations:
                r.innovations.append(InnovationRecord(
                    m.name, float(out_tlog[j]), out_r[j, :d].copy(), out_S[j, :d, :d].copy(),
                    m.R[i], float(out_bm[j]), acc))
        self.k = k1


def type_name(f) -> str:
    """A filter's registry name (``kf local 'gnss'`` -> ``kf``)."""
    return f.name.split(" ", 1)[0]

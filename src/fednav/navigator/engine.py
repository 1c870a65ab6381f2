"""The navigator's cycle compiled: a run of filter epochs in one numba call.

The same cycle as :mod:`fednav.navigator.loop` (mechanize, predict, update, fuse, feed
back) for the error-state core, over arrays: the strapdown of :mod:`fednav.ins.
strapdown`, the error model of :mod:`fednav.ins.error_model`, the filters' own kernels
(:mod:`fednav.filters.kf`, :mod:`fednav.filters.ukf`, the federated fusion) and the
sensors' row models (:mod:`fednav.sensors.measurement`: each measurement arrives with the
rows its sensor's model describes).  Nothing in an epoch goes back to the interpreter,
so a Monte Carlo run and a recorded file cost the same per epoch; the epochs of a stream
are run as they become ready, with the same operations as in one batch.

:func:`run_epochs` is a sequence of named stages over typed records (numba named tuples,
:data:`Ins`, :data:`Bank`, :data:`Rules`, :data:`Sensors`, ...): :func:`mechanize_interval`,
:func:`interval_errors` and :func:`time_update`, :func:`apply_measurement` per measurement
(:func:`ins_at_validity`, the local update, the gate, :func:`lockout_guard`),
:func:`fuse_reset`, :func:`feed_back`, :func:`record_epoch`.  The stages are inlined into
it by numba (``inline="always"``: one compiled function, as quick to compile as one
written whole); the parts a system may lack — the square-root form's kernels, the raw
GNSS satellites' stage — are numba overloads compiled only for a system that has them
(a stub otherwise).  What the federated filter decides — the chi-square gate and
recovery, the satellite a failed test leaves out, the Q adaptation, sharing, the sample
nearest a time of validity — is :mod:`fednav.filters.policy`, which the Python
federated filter calls too.

A system runs here when every part has a compiled form (:func:`why_not_compiled` says
which does not): local filters of the Kalman (``kf``, ``ekf``), unscented (``ukf``) or
simplified unscented (``sukf``) family in either form, per filter (``form:
square_root``: the filter's lower Cholesky factor ``S`` is what is carried, flown with
the kernels of :mod:`fednav.filters.sr_kernels` that :mod:`fednav.filters.square_root`
calls, fused in the square-root information form when every filter is factored; the
record holds ``S S'``), fusion-reset federation, sensors with row models and raw GNSS
(:mod:`fednav.sensors.satellite_rows`), measurements used at their time of validity
(``interpolate``) or at the epoch (``none``), no constraint.  Every other system runs the
Python loop; the test suite flies both on the same data and finds them equal.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba
import numpy as np
from numba.core import types
from numba.extending import overload

from ..core import earth
from ..core.kernels import cholesky_lower
from ..core.kernels import quat_to_dcm as _q2dcm
from ..filters import policy
from ..filters import sr_kernels as srk
from ..filters.federated import drift_threshold, fuse_information, kept_cov, lockout_step
from ..filters.kf import joseph_update, propagate_cov
from ..filters.square_root import NOISE_Q, NOISE_R, REASONS, not_psd
from ..filters.ukf import predict_moments, sigma_points, sigma_update
from ..ins import error_model as em
from ..ins.error_model import interval_model, propagate_points, white_qd
from ..ins.states import follow_mean
from ..ins.strapdown import compensate, correct_state, mechanize
from ..sensors import satellite_rows as satrows
from ..sensors.measurement import (
    RowModel,
    View,
    bias_columns,
    row_jacobian,
    row_predict,
    row_residual,
)
from .record import Growing, InnovationRecord, Record

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
            8: ("update", "state or covariance became NaN/inf"),
            # the square-root form's (:mod:`fednav.filters.square_root`)
            9: ("predict", REASONS[srk.DOWNDATE]),
            10: ("update", REASONS[srk.DOWNDATE]),
            11: ("update", REASONS[srk.NOT_PD]),
            12: ("predict", not_psd(NOISE_Q)),
            13: ("update", not_psd(NOISE_R)),
            14: ("", "covariance is not positive definite")}
#: How a measurement's residual meets the INS (``TimingConfig.delay_compensation``).
HOWS = {"none": 0, "interpolate": 1}
#: The engine's row stages, by a measurement model's ``engine_rows`` (a
#: :class:`~fednav.sensors.measurement.RowModel`: ``rows``): 0 the row kernels of
#: :mod:`fednav.sensors.measurement` (fixed rows), 1 a raw GNSS epoch's satellites
#: (:mod:`fednav.sensors.satellite_rows`: as many rows as satellites, the receiver clock,
#: fault detection and exclusion of one satellite).
ROWS = {"rows": 0, "satellites": 1}


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
        if not specs[a].compiled:
            return f"sensor '{a}' (its model is Python)"
        model = system.sensors[a].measurement_model()
        if isinstance(model, RowModel) and (
                model.dim > 6 or (len(model.zindex) and int(max(model.zindex)) >= 6)):
            return f"sensor '{a}' (more than 6 rows or values)"
        how = system.sensors[a].timing.delay_compensation
        if how not in HOWS:
            return f"delay compensation '{how}' ({a})"
    return None


@numba.njit(cache=True)
def _sensor_frame(C, omega, geom):
    """``C M`` and ``M^T omega`` for a sensor of geometry ``geom`` (its rows 1..3: ``M =
    C_s^b``); ``C`` and ``omega`` themselves when ``M`` is the identity
    (:func:`fednav.sensors.measurement.sensor_frame`, which the Python models use)."""
    M = geom[1:4]
    if (M[0, 0] == 1.0 and M[1, 1] == 1.0 and M[2, 2] == 1.0 and M[0, 1] == 0.0
            and M[0, 2] == 0.0 and M[1, 0] == 0.0 and M[1, 2] == 0.0 and M[2, 0] == 0.0
            and M[2, 1] == 0.0):
        return C, omega
    Cs = np.zeros((3, 3))
    om = np.zeros(3)
    for i in range(3):
        for j in range(3):
            om[j] += M[i, j] * omega[i]
            for k in range(3):
                Cs[i, j] += C[i, k] * M[k, j]
    return Cs, om


@numba.njit(cache=True)
def _nav_buffers(lla, vel, src_p, src_v):
    for j in range(3):
        lla[j] = src_p[j]
        vel[j] = src_v[j]


@numba.njit(cache=True)
def _sr_code(code, nis):
    """A square-root update kernel's code (:mod:`fednav.filters.sr_kernels`) and NIS ->
    the engine's failure code (:data:`FAILURES`; 0: success), as
    :meth:`fednav.filters.square_root.SquareRootForm._sr_accept` reads them."""
    if code == srk.OK:
        return 0 if math.isfinite(nis) else 4
    if code == srk.NOT_FINITE:
        return 8
    if code == srk.DOWNDATE:
        return 10
    if code == srk.NOT_PD:
        return 11
    return 4


@numba.njit(cache=True)
def _biased_rows(bias, X, Z):
    """A row's additive sensor bias (its error-state column ``bias[r]``, -1: none) in the
    predicted residuals ``Z`` of the points ``X``: ``-db`` (:mod:`fednav.ins.states`)."""
    for r in range(bias.shape[0]):
        if bias[r] >= 0:
            for i in range(X.shape[0]):
                Z[i, r] -= X[i, bias[r]]


#: The INS and its error model, flown in place: ``state`` (the INS), ``comp`` (gyro and
#: accelerometer compensation), ``xa`` (the optional error states' totals, SI,
#: :mod:`fednav.ins.states`; ``trans`` their mean transition over an epoch; the states'
#: filter units ``scale``), the baro loop's ``gains``, ``cst`` = [dt, T, t0, k1, k2,
#: 1/tau_g, 1/tau_a, q_step, ln max q scale], the error model's ``noise`` vector,
#: ``nsub`` sub-steps of the error propagation and ``n_per`` IMU samples per epoch.
Ins = namedtuple("Ins", "state comp xa trans scale gains cst noise nsub n_per")
#: The filters (locals, then the master): estimates ``X``, covariances ``P`` (the lower
#: factor ``S``, ``P = S S'``, of a filter ``sr[f]`` in the square-root form), sharing
#: factors ``beta``, ln process-noise scales ``qlog`` (adapted in place), FDI ``passes``,
#: ``fam`` (nf, 2) each filter's time/measurement-update family (:data:`FAMILIES`) and its
#: unscented constants ``c``, ``Wm``, ``Wc``, ``cm`` (``sum Wc - 2``); ``factored``: ``sr``
#: when a filter is in the square-root form, else None (its engine then does not compile
#: the square-root kernels: :func:`factored_update`).
Bank = namedtuple("Bank", "X P beta qlog passes fam sr c Wm Wc cm factored")
#: Fault detection, sharing and the lockout guard: ``thr`` (nf, D + 1) each filter's
#: chi-square threshold by dof (NaN: no detection), ``recovery``, ``sharing`` (0 equal,
#: 1 fixed, 2 adaptive), ``thr_drift`` (nf, D + 1) the lockout guard's drift thresholds and
#: ``lk`` its settings and state (:data:`fednav.filters.federated.LockoutState`).
Rules = namedtuple("Rules", "thr recovery sharing thr_drift lk")
#: Per aiding sensor: its local filter, how its delay is met (:data:`HOWS`), dimension
#: (0 for raw GNSS: as many rows as satellites),
#: the rows of its model (kinds, value index), its geometry ((S, 4, 3): the lever arm in
#: its axes, then its mounting ``C_s^b``, :attr:`~fednav.sensors.measurement.RowModel.
#: geometry`), whether it is linear, its rows' bias columns (:func:`_biased_rows`), its
#: row stage (:data:`ROWS`) and that stage's figures ``par`` (S, 4) (satellites: the
#: elevation mask [rad], zenith 1-sigma of a pseudorange [m] and a range rate [m/s], the
#: clock block's first column; None in a system without: its engine then does not
#: compile the satellites' stage).
Sensors = namedtuple("Sensors", "filter how dim kinds zi geom linear bias kind par")
#: The measurements of a run of epochs in the order they are applied: epoch index,
#: sensor, time of validity [s], value, noise covariance (filter units).
Batch = namedtuple("Batch", "epoch sens t z R")
#: The IMU data of a run of epochs: increments and baro heights, ``n_per`` per epoch.
Imu = namedtuple("Imu", "dtheta dv h_ref")
#: Outputs per epoch (``Phi``, ``Qd``, ``dx`` and ``rows`` of zero length: not kept).
EpochOut = namedtuple("EpochOut", "states P beta Phi Qd dx rows")
#: Outputs per measurement: NIS, accepted, threshold, the time logged, the rows used
#: (``dof``; 0: none, no satellite above the mask), (of zero length unless asked for)
#: residual, its covariance, the filter's share, ``H`` and the rows' noise ``R``; ``re``
#: (M, 3): lockout start, NIS before and inflation of a re-admission, inflation 0 where
#: none; ``ex`` (M, 3): the unit fault detection left out (-1: none), its statistic, and
#: whether the receiver clock's totals moved by a jump (:func:`fednav.sensors.
#: satellite_rows.bind`).
MeasOut = namedtuple("MeasOut", "nis acc thr tlog dof r S bm re H R ex")
#: One measurement's rows (:func:`measurement_rows`): residual ``y``, noise ``R``, ``H``
#: when the row stage gives it (zero rows: the row kernels'), each row's ``keys`` for the
#: lockout guard and its unit (``groups``; empty: one unit) for fault exclusion.
Rows = namedtuple("Rows", "y R H keys groups")
#: One interval as the mechanization flew it: compensated increments, attitude, velocity
#: and position after each sample, the mean rate [rad/s]; buffers for the INS a
#: measurement compares with (position, velocity, attitude quaternion).
Interval = namedtuple("Interval", "dth dvc rq rv rp omega lla vel q")


@numba.njit(cache=True, inline="always")
def rows_jacobian(sensors, sn, view, H):
    """``H`` (d, n; zeroed by the caller) of sensor ``sn``'s rows against the INS
    ``view``: :func:`~fednav.sensors.measurement.row_jacobian` at its lever arm, -1 on
    each row's sensor-bias state."""
    d = H.shape[0]
    row_jacobian(sensors.kinds[sn, :d], view.lla, view.vel, view.C, view.omega,
                 sensors.geom[sn, 0], H)
    bias = sensors.bias[sn, :d]
    for rb in range(d):
        if bias[rb] >= 0:
            H[rb, bias[rb]] = -1.0


@numba.njit(cache=True)
def _kalman_rows(bank, f, sensors, sn, view, y, Hg):
    """``H`` of a measurement of sensor ``sn`` against the INS ``view`` (given ``Hg``, else
    the row kernels' with the rows' sensor-bias columns) and its residual ``y - h(x)``
    at local filter ``f``'s estimate (``H x`` for a linear model)."""
    x = bank.X[f]
    d, n = y.shape[0], x.shape[0]
    given = Hg.shape[0] > 0
    if given:
        H = Hg
    else:
        H = np.zeros((d, n))
        rows_jacobian(sensors, sn, view, H)
    if given or sensors.linear[sn]:
        yhat = H @ x
    else:
        Z = np.empty((1, d))
        xr = x.copy().reshape(1, n)
        row_predict(sensors.kinds[sn, :d], view.lla, view.vel, view.C, view.omega,
                    sensors.geom[sn, 0], xr, Z)
        _biased_rows(sensors.bias[sn, :d], xr, Z)
        yhat = Z[0]
    return H, y - yhat


@numba.njit(cache=True)
def _point_rows(sensors, sn, view, Sg, d, Hg):
    """The ``d`` rows of sensor ``sn`` at the sigma points ``Sg`` against the INS
    ``view``: ``Sg H'`` of a given ``Hg``, else the row kernels' with the sensor-bias
    columns."""
    if Hg.shape[0] > 0:
        return satrows.points_rows(Sg, Hg)
    Z = np.empty((Sg.shape[0], d))
    row_predict(sensors.kinds[sn, :d], view.lla, view.vel, view.C, view.omega,
                sensors.geom[sn, 0], Sg, Z)
    _biased_rows(sensors.bias[sn, :d], Sg, Z)
    return Z


@numba.njit(cache=True)
def _local_update(bank, f, sensors, sn, view, y, R, Hg):
    """Measurement update of local filter ``f`` with a measurement of sensor ``sn``
    (residual ``y`` against the INS ``view``, covariance ``R``): Kalman (Joseph form) or
    unscented by its family; a factored filter (``bank.sr[f]``: ``P`` is its lower factor
    ``S``) through :func:`factored_update`; the rows' sensor-bias columns,
    :func:`_biased_rows`.  ``Hg``: the rows' ``H`` of a linear model whose stage gave it
    (the satellites'), else of zero rows (the row kernels').  Returns (x, P or S,
    residual, its covariance, NIS, failure code 0 / 4 / 7 / 8 / 10 / 11 / 13)."""
    if bank.sr[f]:
        return factored_update(bank.factored, bank, f, sensors, sn, view, y, R, Hg)
    x, P = bank.X[f], bank.P[f]
    if bank.fam[f, 1] == 0:
        H, r = _kalman_rows(bank, f, sensors, sn, view, y, Hg)
        x1, Pn, Sm, ni, ok = joseph_update(x, P, H, r, R)
        return x1, Pn, r, Sm, ni, 0 if ok else 4
    Sg = sigma_points(x, P, bank.c[f])
    if Sg.shape[0] == 0:
        return x, P, y, R, np.nan, 7
    Z = _point_rows(sensors, sn, view, Sg, y.shape[0], Hg)
    x1, Pn, r, Sm, ni, ok = sigma_update(Sg, Z, bank.Wm[f], bank.Wc[f], x, P, y, R)
    return x1, Pn, r, Sm, ni, 0 if ok and math.isfinite(ni) else 4


@numba.njit(cache=True)
def _factored_update(bank, f, sensors, sn, view, y, R, Hg):
    """:func:`_local_update` of a filter in the square-root form (``P`` is its lower
    factor ``S``): the kernels of :mod:`fednav.filters.sr_kernels` that
    :mod:`fednav.filters.square_root` calls."""
    x, P = bank.X[f], bank.P[f]
    Rs, ok = srk.psd_sqrt(R)
    if not ok:
        return x, P, y, R, np.nan, 13
    if bank.fam[f, 1] == 0:
        H, r = _kalman_rows(bank, f, sensors, sn, view, y, Hg)
        x1, Sn, Sm, ni, code = srk.sr_kf_update(x, P, H, r, Rs)
        return x1, Sn, r, Sm, ni, _sr_code(code, ni)
    Sg, _ = srk.ukf_points(x, P, math.sqrt(bank.c[f]))
    Z = _point_rows(sensors, sn, view, Sg, y.shape[0], Hg)
    x1, Sn, Sm, ni, code, r = srk.sr_ukf_update(Z, P, bank.Wm[f][1], bank.cm[f], x, y, Rs)
    return x1, Sn, r, Sm, ni, _sr_code(code, ni)


def compiled_if(impl, stub):
    """A function called as ``f(part, *args)`` that runs ``impl(*args)`` when ``part`` is
    not None and ``stub(*args)`` when it is — from Python, and in compiled code by the
    *type* of ``part``, so that the engine of a system without the part compiles only
    the stub (cheap; never run there).  What a system uses is compiled, not what it
    might: the square-root form's kernels (``part``: ``Bank.factored``) and the raw GNSS
    satellites' stage (``Sensors.par``).  The overload is not inlined: numba's
    ``inline="always"`` on such overloads corrupted the square-root path's values
    (``tests/test_square_root_engine.py``, on a fresh kernel cache)."""
    def dispatch(part, *args):
        return (stub if part is None else impl)(*args)

    @overload(dispatch)
    def _typed(part, *args):
        chosen = stub if isinstance(part, types.NoneType) else impl

        def call(part, *args):
            return chosen(*args)
        return call
    return dispatch


@numba.njit(cache=True)
def _no_update(bank, f, sensors, sn, view, y, R, Hg):
    return bank.X[f], bank.P[f], y, R, np.nan, 13


#: :func:`_factored_update` where the system has a factored filter (``Bank.factored``).
factored_update = compiled_if(_factored_update, _no_update)


@numba.njit(cache=True)
def _factored_predict(ins, bank, f, Phi, Qd, adapted, Lq0, params, Cm):
    """Time update of filter ``f`` in the square-root form (the factor,
    ``SquareRootKalmanFilter`` / ``SquareRootSigma.predict``) with its noise ``Qd``
    (``adapted``: its own; else the factor ``Lq0`` of the shared one, made once and
    returned).  Returns (failure code, ``Lq0``)."""
    T, n = ins.cst[1], bank.X.shape[1]
    if adapted or Lq0.shape[0] == 0:
        Lq, ok = srk.psd_sqrt(Qd)
        if not ok:
            return 12, Lq0
        if not adapted:
            Lq0 = Lq
    else:
        Lq = Lq0
    sq = math.sqrt(1.0 / bank.beta[f])
    if bank.fam[f, 0] == 0:
        x1 = propagate_points(bank.X[f].copy().reshape(1, n), T, ins.nsub, params, Cm,
                              ins.scale)[0]
        Sn, ok = srk.sr_propagate(Phi, bank.P[f], Lq, sq)
        if not ok or not math.isfinite(x1.sum()):
            return 3, Lq0
    else:
        Xs, _ = srk.ukf_points(bank.X[f], bank.P[f], math.sqrt(bank.c[f]))
        x1, Sn, code = srk.sr_sigma_predict(
            propagate_points(Xs, T, ins.nsub, params, Cm, ins.scale), bank.Wm[f],
            bank.Wc[f], Lq, sq)
        if code != srk.OK:
            return 9 if code == srk.DOWNDATE else 3, Lq0
    bank.X[f] = x1
    bank.P[f] = Sn
    return 0, Lq0


@numba.njit(cache=True)
def _no_predict(ins, bank, f, Phi, Qd, adapted, Lq0, params, Cm):
    return 0, Lq0


@numba.njit(cache=True)
def _sr_fusion(X, S):
    """Square-root information fusion of the factors ``S`` (``sr_fuse``), with the fused
    covariance ``S_g S_g'``: (x_g, P_g, S_g, traces, bad)."""
    xg, Sg, traces, bad = srk.sr_fuse(X, S)
    return xg, srk.factor_product(Sg), Sg, traces, bad


@numba.njit(cache=True)
def _no_fusion(X, S):
    return X[0].copy(), S[0].copy(), S[0].copy(), np.zeros(X.shape[0]), 0


#: :func:`_factored_predict` and :func:`_sr_fusion` where the system has a factored filter.
factored_predict = compiled_if(_factored_predict, _no_predict)
factored_fusion = compiled_if(_sr_fusion, _no_fusion)


@numba.njit(cache=True, inline="always")
def mechanize_interval(ins, imu, e, iv):
    """Stage 1, mechanize: the IMU samples of epoch ``e`` (0-based in the run) compensated
    and flown by the strapdown, ``iv`` filled (:data:`Interval`).  Returns the INS at the
    interval's start."""
    n_per, dt = ins.n_per, ins.cst[0]
    b = e * n_per
    compensate(imu.dtheta[b:b + n_per], imu.dv[b:b + n_per], dt, ins.comp, ins.xa,
               int(ins.noise[7]), int(ins.noise[8]), iv.dth, iv.dvc)
    s0 = ins.state.copy()
    mechanize(ins.state, iv.dth, iv.dvc, dt, imu.h_ref[b:b + n_per], ins.gains, iv.rq, iv.rv,
              iv.rp)
    for j in range(3):
        iv.omega[j] = iv.dth[:, j].sum() / ins.cst[1]
    return s0


@numba.njit(cache=True, inline="always")
def interval_errors(ins, bank, s0, iv):
    """Stage 2a, the error model of the interval from ``s0`` to the INS now: (its
    nonlinear transition's ``params`` and ``Cm``, ``Phi``, ``Qd``, the white part ``Qw``
    of ``Qd`` when Q adapts, the fused prior's ``Qd`` the record keeps); the optional
    states' totals moved by their mean transition (:func:`fednav.ins.states.
    follow_mean`)."""
    T, q_step = ins.cst[1], ins.cst[7]
    params, Cm, Phi, Qd0 = interval_model(s0, ins.state, iv.dvc.sum(axis=0),
                                          iv.dth.sum(axis=0), T, ins.cst[3], ins.cst[4],
                                          ins.cst[5], ins.cst[6], ins.noise, ins.scale)
    if ins.trans.shape[0]:  # the optional totals follow their mean
        follow_mean(ins.trans, ins.xa)
    Qw = Qd0
    Qrec = Qd0
    if q_step > 0.0:  # the fused prior's (FederatedFilter.q_scale_fused)
        Qw = white_qd(Phi, ins.noise, T, ins.scale)
        Qrec = Qd0 + (policy.fused_q_scale(bank.beta, bank.qlog) - 1.0) * Qw
    return params, Cm, Phi, Qd0, Qw, Qrec


@numba.njit(cache=True, inline="always")
def time_update(ins, bank, Phi, Qd0, Qw, params, Cm):
    """Stage 2b, time update: every filter over the interval (``Phi``, ``Qd0``, its white
    part ``Qw``; ``params``, ``Cm`` the nonlinear transition,
    :func:`interval_errors`), each with its share ``Qd / beta`` and its adapted noise
    (:func:`fednav.filters.policy.adapted_qd`).  Returns (failure code, filter)."""
    T, q_step = ins.cst[1], ins.cst[7]
    nf, n = bank.X.shape
    Lq0 = np.empty((0, 0))  # the factor of Qd0 (square-root filters; once)
    for f in range(nf):
        q_scale = 1.0 / bank.beta[f]
        adapted = q_step > 0.0 and bank.qlog[f] > 0.0
        Qd = policy.adapted_qd(Qd0, Qw, bank.qlog[f]) if adapted else Qd0
        if bank.sr[f]:  # the factor (SquareRootKalmanFilter / SquareRootSigma.predict)
            code, Lq0 = factored_predict(bank.factored, ins, bank, f, Phi, Qd, adapted, Lq0,
                                         params, Cm)
            if code:
                return code, f
        elif bank.fam[f, 0] == 0:  # Kalman: the mean through the nonlinear model
            x1 = propagate_points(bank.X[f].copy().reshape(1, n), T, ins.nsub, params, Cm,
                                  ins.scale)[0]
            Pn, ok = propagate_cov(Phi, bank.P[f], Qd, q_scale)
            if not ok or not math.isfinite(x1.sum()):
                return 3, f
            bank.X[f] = x1
            bank.P[f] = Pn
        else:
            S = sigma_points(bank.X[f], bank.P[f], bank.c[f])
            if S.shape[0] == 0:
                return 2, f
            Q = Qd if q_scale == 1.0 else q_scale * Qd
            x1, Pn, ok = predict_moments(propagate_points(S, T, ins.nsub, params, Cm,
                                                          ins.scale), bank.Wm[f], bank.Wc[f],
                                         Q)
            if not ok:
                return 3, f
            bank.X[f] = x1
            bank.P[f] = Pn
    return 0, -1


@numba.njit(cache=True, inline="always")
def ins_at_validity(ins, iv, s0, how, t, k):
    """Stage 3a, the INS a measurement of time of validity ``t`` [s] compares with, into
    ``iv.lla``, ``iv.vel``: at epoch ``k`` (``how`` 0), or at the interval's sample nearest
    ``t`` moved back along its velocity by the lag left (``how`` 1,
    :func:`fednav.filters.policy.validity_sample`).  Returns its attitude ``C_b^n`` and
    the time the measurement is logged at [s]."""
    dt, T, t0 = ins.cst[0], ins.cst[1], ins.cst[2]
    lla, vel = iv.lla, iv.vel
    if how != 1:
        _nav_buffers(lla, vel, ins.state[7:10], ins.state[4:7])
        return _q2dcm(ins.state[0:4]), t0 + T * k
    jj, lag = policy.validity_sample(t, t0 + T * (k - 1), dt, ins.n_per)
    if jj == 0:
        _nav_buffers(lla, vel, s0[7:10], s0[4:7])
        for j in range(4):
            iv.q[j] = s0[j]
    else:
        _nav_buffers(lla, vel, iv.rp[jj - 1], iv.rv[jj - 1])
        for j in range(4):
            iv.q[j] = iv.rq[jj - 1, j]
    lla[0], lla[1], lla[2] = earth.moved_nb(lla[0], lla[1], lla[2], -lag * vel[0],
                                            -lag * vel[1], -lag * vel[2])
    return _q2dcm(iv.q), t


@numba.njit(cache=True, inline="always")
def lockout_guard(bank, rules, sensors, sn, view, rows, t_log, tested):
    """Stage 3c, the lockout guard (:func:`fednav.filters.federated.lockout_step`, the
    Python loop's too) on a measurement's ``rows`` (:data:`Rows`) of sensor ``sn``,
    ``tested`` = (x, P, r, S, NIS, accepted) as the local update and the gate left it.
    When the guard re-admits, every filter's covariance is inflated and the update made
    again.  Returns ``tested`` as it then stands, the inflation (0: none) and the
    lockout's start [s]."""
    x1, Pn, r, Sm, ni, accepted = tested
    f = sensors.filter[sn]
    y, R = rows.y, rows.R
    d = y.shape[0]
    s_in, t_start = lockout_step(f, t_log, accepted, ni, r, Sm, R, rows.keys,
                                 rules.thr_drift[f], rules.lk)
    if s_in > 0.0:
        P_saved = bank.P.copy()
        for g in range(bank.X.shape[0]):  # (Filter.inflate: a factor by sqrt(s))
            bank.P[g] = bank.P[g] * (math.sqrt(s_in) if bank.sr[g] else s_in)
        x2, P2, r2, S2, n2, code = _local_update(bank, f, sensors, sn, view, y, R, rows.H)
        if code == 0 and not n2 > rules.thr[f, d] and (bank.sr[f] or (
                math.isfinite(x2.sum() + P2.sum()) and cholesky_lower(P2)[1])):
            lockout_step(f, t_log, True, n2, r2, S2, R, rows.keys, rules.thr_drift[f],
                         rules.lk)
            return (x2, P2, r2, S2, n2, True), s_in, t_start
        bank.P[:] = P_saved
    return (x1, Pn, r, Sm, ni, accepted), 0.0, t_start


@numba.njit(cache=True)
def _take(A, rows):
    """``A[rows][:, rows]`` (a covariance's rows and columns kept)."""
    c = rows.shape[0]
    out = np.empty((c, c))
    for i in range(c):
        for j in range(c):
            out[i, j] = A[rows[i], rows[j]]
    return out


@numba.njit(cache=True)
def _satellite_rows(m, k, ins, sensors, sn, view, batch, mo):
    """The rows of a raw GNSS epoch (:func:`fednav.sensors.satellite_rows.bind`: the
    satellites above the mask, the receiver clock's jump test on the totals, the rows at
    the measurement's time) as :data:`Rows`."""
    p = sensors.par[sn]
    ic = int(p[3])
    dt = batch.t[m] - (ins.cst[2] + ins.cst[1] * k) if sensors.how[sn] == 1 else 0.0
    sat, y, H, moved = satrows.bind(batch.z[m, :satrows.WIDTH], view, sensors.geom[sn, 0],
                                    ins.xa[ic:ic + 2], dt, p[:3], ins.scale.shape[0], ic)
    R, groups, keys = satrows.noise(sat)
    mo.ex[m, 2] = 1.0 if moved else 0.0
    return Rows(y, R, H, keys, groups)


@numba.njit(cache=True)
def _no_rows(m, k, ins, sensors, sn, view, batch, mo):
    return Rows(np.empty(0), np.empty((0, 0)), np.empty((0, ins.scale.shape[0])),
                np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64))


@numba.njit(cache=True)
def _left_out(r, S, groups, thresholds):
    return policy.leave_one_out(r, S, groups, thresholds)


@numba.njit(cache=True)
def _none_left_out(r, S, groups, thresholds):
    return -1, np.nan, np.ones(groups.shape[0], dtype=np.bool_)


#: The satellites' stage and :func:`fednav.filters.policy.leave_one_out` where the system
#: has a raw GNSS sensor (``Sensors.par``).
satellite_rows = compiled_if(_satellite_rows, _no_rows)
left_out_unit = compiled_if(_left_out, _none_left_out)


@numba.njit(cache=True, inline="always")
def measurement_rows(m, k, ins, sensors, sn, view, batch, mo):
    """Stage 3b, the rows of measurement ``m`` (epoch ``k``) of sensor ``sn`` against the
    INS ``view`` in its axes, by its row stage (:data:`ROWS`): the row kernels
    (:func:`~fednav.sensors.measurement.row_residual`, the sensor's bias estimate taken
    out of its value; noise from the batch), or a raw GNSS epoch's satellites
    (:func:`fednav.sensors.satellite_rows.bind`, the Python model's own function: the
    satellites above the mask, the receiver clock's jump test on the totals, the rows at
    the measurement's time).  Returns its :data:`Rows`."""
    n = ins.scale.shape[0]
    if sensors.kind[sn] == 1:
        return satellite_rows(sensors.par, m, k, ins, sensors, sn, view, batch, mo)
    d = sensors.dim[sn]
    bias = sensors.bias[sn, :d]
    y = np.empty(d)
    row_residual(sensors.kinds[sn, :d], sensors.zi[sn, :d], view.lla, view.vel, view.C,
                 view.omega, batch.z[m], sensors.geom[sn, 0], y)
    for rb in range(d):  # the sensor's bias estimate taken out of its value
        if bias[rb] >= 0:
            y[rb] += ins.xa[bias[rb]]
    return Rows(y, batch.R[m, :d, :d].copy(), np.empty((0, n)), sensors.kinds[sn, :d].copy(),
                np.empty(0, dtype=np.int64))


@numba.njit(cache=True, inline="always")
def apply_measurement(m, k, ins, iv, s0, bank, rules, sensors, batch, mo):
    """Stage 3, measurement update: measurement ``m`` of the batch (epoch ``k``) — its
    rows against the INS at its time of validity in its sensor's axes
    (:func:`measurement_rows`), its local filter's update, the chi-square test
    (:func:`fednav.filters.policy.fdi_gate`, the Python federated filter's rule), a
    failed test of several units answered by leaving one out
    (:func:`fednav.filters.policy.leave_one_out`, the update made with the rest), the
    lockout guard, the Q adaptation; ``mo`` filled.  Returns (failure code, filter)."""
    sn = batch.sens[m]
    f = sensors.filter[sn]
    C, t_log = ins_at_validity(ins, iv, s0, sensors.how[sn], batch.t[m], k)
    # the INS as the sensor sees it: its axes' attitude C M, the rate in them
    # (sensors.measurement.sensor_frame)
    C, om = _sensor_frame(C, iv.omega, sensors.geom[sn])
    view = View(iv.lla, iv.vel, C, om)
    rw = measurement_rows(m, k, ins, sensors, sn, view, batch, mo)
    y, R, Hg, groups = rw.y, rw.R, rw.H, rw.groups
    d = y.shape[0]
    mo.dof[m] = d
    mo.ex[m, 0] = -1.0
    if d == 0:  # (no satellite above the mask: no update, nothing logged)
        return 0, -1
    x1, Pn, r, Sm, ni, code = _local_update(bank, f, sensors, sn, view, y, R, Hg)
    if code:
        return code, f
    th = rules.thr[f, d]
    gate = policy.fdi_gate(th, bank.passes[f], rules.recovery)
    accepted = policy.is_accepted(ni, gate)
    rows = np.arange(d)
    if not accepted and 0.0 <= gate < np.inf and groups.shape[0] > 0:
        # (FederatedFilter._exclude: one unit left out, the rest tested again)
        u, stat, keep = left_out_unit(sensors.par, r, Sm, groups, rules.thr[f])
        if u >= 0:
            kept = np.flatnonzero(keep)
            x2, P2, r2, S2, n2, code = _local_update(bank, f, sensors, sn, view, y[kept],
                                                     _take(R, kept), Hg[kept])
            if code:
                return code, f
            if policy.is_accepted(n2, rules.thr[f, kept.shape[0]]):
                x1, Pn, r, Sm, ni, accepted = x2, P2, r2, S2, n2, True
                rows = kept
                mo.ex[m, 0], mo.ex[m, 1] = u, stat
        th = rules.thr[f, rows.shape[0]]
    bank.passes[f] = policy.fdi_passes(th, gate, bank.passes[f], rules.recovery, ni)
    mo.re[m, 2] = 0.0
    if rules.lk.pos[f] and rules.lk.hold > 0.0:
        tested, s_in, t_start = lockout_guard(bank, rules, sensors, sn, view, rw, t_log,
                                              (x1, Pn, r, Sm, ni, accepted))
        if s_in > 0.0:  # re-admitted
            mo.re[m, 0], mo.re[m, 1], mo.re[m, 2] = t_start, ni, s_in
            x1, Pn, r, Sm, ni, accepted = tested
            bank.passes[f] = rules.recovery
            rows = np.arange(d)
    du = rows.shape[0]
    if accepted:  # (a factor's kernel checked it already)
        if not bank.sr[f] and not math.isfinite(x1.sum() + Pn.sum()):
            return 8, f
        if not bank.sr[f] and not cholesky_lower(Pn)[1]:
            return 5, f
        bank.X[f] = x1
        bank.P[f] = Pn
        if ins.cst[7] > 0.0:
            bank.qlog[f] = policy.adapt_qlog(bank.qlog[f], ins.cst[7], ni, du, ins.cst[8])
    mo.nis[m] = ni
    mo.acc[m] = 1.0 if accepted else 0.0
    mo.thr[m] = th
    mo.tlog[m] = t_log
    mo.dof[m] = du
    if mo.r.shape[0] > 0:  # the innovations themselves, when asked for
        mo.r[m, :du] = r
        mo.S[m, :du, :du] = Sm
        mo.bm[m] = bank.beta[f]
        if Hg.shape[0] > 0:
            for i in range(du):
                mo.H[m, i] = Hg[rows[i]]
        else:
            rows_jacobian(sensors, sn, view, mo.H[m, :d])
        mo.R[m, :du, :du] = _take(R, rows)
    return 0, -1


@numba.njit(cache=True, inline="always")
def fuse_reset(bank, sharing, out_P):
    """Stage 4, fusion and reset: every filter factored, the square-root information
    fusion, else the covariances (``S S'`` of the factored ones) fused
    (:meth:`~fednav.filters.federated.FederatedFilter.fuse`); the fused covariance into
    ``out_P``; adaptive sharing (:func:`fednav.filters.policy.adaptive_shares`); each
    filter reset to the fused estimate with ``P_g / beta``.  Returns (failure code,
    filter, the fused estimate)."""
    nf = bank.X.shape[0]
    all_sr = bank.sr.all()
    if all_sr:
        xg, Pg, Sg, traces, bad = factored_fusion(bank.factored, bank.X, bank.P)
    else:
        Ps = bank.P
        if bank.sr.any():
            Ps = bank.P.copy()
            for f in range(nf):
                if bank.sr[f]:
                    Ps[f] = srk.factor_product(bank.P[f])
        Sg = Ps[0]  # (unused here: numba types Sg the same on both branches)
        xg, Pg, traces, bad = fuse_information(bank.X, Ps)
    if bad >= 0:
        return 6, bad, xg
    out_P[:] = Pg
    if sharing == 2:
        bank.beta[:] = policy.adaptive_shares(traces)
    for f in range(nf):
        bank.X[f] = xg - xg  # reset to the fused estimate, then its feedback (zero)
        if all_sr:
            bank.P[f] = Sg / math.sqrt(bank.beta[f])
        elif bank.sr[f]:  # the factor of P_g / beta (SquareRootForm.P's setter)
            L, ok = cholesky_lower(Pg / bank.beta[f])
            if not ok:
                return 14, f, xg
            bank.P[f] = L
        else:
            bank.P[f] = Pg / bank.beta[f]
    return 0, -1, xg


@numba.njit(cache=True, inline="always")
def feed_back(ins, xg):
    """Stage 5, feedback: the fused error estimate ``xg`` (filter units) corrects the INS,
    the sensors' compensation and the optional states' totals."""
    dx = xg * ins.scale
    correct_state(ins.state, dx[0:3], dx[3:6], dx[6:9])
    for j in range(3):
        ins.comp[j] += dx[9 + j] + dx[12 + j]
        ins.comp[3 + j] += dx[15 + j]
    for j in range(18, dx.shape[0]):
        ins.xa[j] += dx[j]


@numba.njit(cache=True, inline="always")
def record_epoch(e, ins, iv, bank, Phi, Qrec, xg, eo):
    """Stage 6, the record of epoch ``e``: the INS after the feedback, the sharing
    factors, the interval's model and fused estimate (when kept) and its IMU-rate rows
    (when kept; the epoch's row after the feedback)."""
    eo.states[e] = ins.state
    eo.beta[e] = bank.beta
    if eo.Phi.shape[0] > 0:
        eo.Phi[e] = Phi
        eo.Qd[e] = Qrec
        eo.dx[e] = xg
    if eo.rows.shape[0] > 0:
        n_per, dt = ins.n_per, ins.cst[0]
        r0 = e * n_per
        for i in range(n_per):
            for j in range(4):
                eo.rows[r0 + i, j] = iv.rq[i, j]
            for j in range(3):
                eo.rows[r0 + i, 4 + j] = iv.rv[i, j]
                eo.rows[r0 + i, 7 + j] = iv.rp[i, j]
                eo.rows[r0 + i, 10 + j] = iv.dth[i, j] / dt
        for j in range(10):  # the epoch row: after the feedback
            eo.rows[r0 + n_per - 1, j] = ins.state[j]


@numba.njit(cache=True)
def run_epochs(k0, n_ep, ins, imu, bank, rules, sensors, batch, eo, mo):
    """Fly epochs ``k0 + 1 .. k0 + n_ep`` (1-based) in place on the INS ``ins`` and the
    filters ``bank`` with the IMU data ``imu`` and the measurements ``batch`` (records:
    :data:`Ins`, :data:`Imu`, :data:`Bank`, :data:`Rules`, :data:`Sensors`,
    :data:`Batch`), the outputs into ``eo`` and ``mo`` (:data:`EpochOut`,
    :data:`MeasOut`).  Each epoch: mechanize, the error model and time update, each of
    its measurements, fusion and reset, feedback, record.  Returns (failure code
    (:data:`FAILURES`), epoch, filter); code 0 when all flew."""
    n_per = ins.n_per
    iv = Interval(np.empty((n_per, 3)), np.empty((n_per, 3)), np.empty((n_per, 4)),
                  np.empty((n_per, 3)), np.empty((n_per, 3)), np.empty(3), np.empty(3),
                  np.empty(3), np.empty(4))
    m = 0
    n_meas = batch.epoch.shape[0]
    for e in range(n_ep):
        k = k0 + 1 + e
        s0 = mechanize_interval(ins, imu, e, iv)
        if not math.isfinite(ins.state.sum()):
            return 1, k, -1
        params, Cm, Phi, Qd0, Qw, Qrec = interval_errors(ins, bank, s0, iv)
        code, f = time_update(ins, bank, Phi, Qd0, Qw, params, Cm)
        if code:
            return code, k, f
        while m < n_meas and batch.epoch[m] == k:
            code, f = apply_measurement(m, k, ins, iv, s0, bank, rules, sensors, batch, mo)
            if code:
                return code, k, f
            m += 1
        code, f, xg = fuse_reset(bank, rules.sharing, eo.P[e])
        if code:
            return code, k, f
        feed_back(ins, xg)
        record_epoch(e, ins, iv, bank, Phi, Qrec, xg, eo)
    return 0, -1, -1


class CompiledLoop:
    """The engine with the interface of :class:`~fednav.navigator.loop.PythonLoop`: it
    flies the epochs handed to :meth:`run` and keeps the same
    :class:`~fednav.navigator.record.Record`, writing straight into its arrays.

    ``core``: the :class:`~fednav.navigator.loop.ErrorStateCore` (its INS state and
    compensation are flown in place); ``fed``: the federated filter as built (its
    filters' names, types, starting estimates and sharing; its arrays are flown here);
    ``meas``: the aiding sensors' :class:`~fednav.navigator.loop.Meas`, in aiding order."""

    def __init__(self, core, fed, meas, t0, T, dt, n_per, record_rows, record_cov,
                 innovations):
        self.core, self.fed, self.meas = core, fed, meas
        self.t0, self.T, self.dt, self.n_per = float(t0), float(T), float(dt), int(n_per)
        self.record_rows, self.record_cov, self.innovations = (record_rows, record_cov,
                                                                innovations)
        self.names = list(fed.filters)
        filters = list(fed.filters.values())
        nf, n = len(filters), core.n
        self.X = np.array([f.x for f in filters])
        #: per filter its covariance, or its lower factor S when ``sr``
        self.sr = np.array([f.form == "square_root" for f in filters], dtype=np.bool_)
        self.P = np.array([kept_cov(f) for f in filters])
        self.beta = np.array([fed.beta[k] for k in self.names])
        self.passes = np.array([fed.passes.get(k, 0) for k in self.names], dtype=np.int64)
        self.fam = np.array([FAMILIES[f.kind] for f in filters], dtype=np.int64)
        n_sig = 2 * n + 1
        self.c = np.ones(nf)
        self.Wm = np.zeros((nf, n_sig))
        self.Wc = np.zeros((nf, n_sig))
        self.cm = np.zeros(nf)
        for i, f in enumerate(filters):
            if hasattr(f, "Wm"):
                self.c[i], self.Wm[i], self.Wc[i] = f.c, f.Wm, f.Wc
                self.cm[i] = f.Wc.sum() - 2.0
        for m in meas:
            if not isinstance(m.model, RowModel) and getattr(m.model, "engine_rows",
                                                             None) not in ROWS:
                raise ValueError(f"sensor '{m.name}': its model has no compiled rows")
        sat = [ROWS[getattr(m.model, "engine_rows", "rows")] == 1 for m in meas]
        #: rows and values a measurement has at most
        own = [m.model for m, s in zip(meas, sat, strict=True) if s]
        D = self.D = max([6] + [model.max_rows for model in own])
        self.W = max([6] + [model.width for model in own])
        self.thr = np.full((nf, D + 1), np.nan)
        self.thr_drift = np.full((nf, D + 1), np.nan)  # (the lockout guard's)
        for i, k in enumerate(self.names):
            a = fed.fdi_alphas.get(k)
            if a is not None:
                self.thr[i, 1:] = [fed.threshold(d, k) for d in range(1, D + 1)]
                self.thr_drift[i, 1:] = [drift_threshold(d, a) for d in range(1, D + 1)]
        self.recovery = int(fed.fdi_recovery)
        self.lockout = fed.lockout  # (its state arrays are flown in place)
        self.lockout.widen(D)
        self.sharing = {"equal": 0, "fixed": 1, "adaptive": 2}[fed.sharing]
        # Per sensor (aiding order): its local filter, how, rows, lever, linearity, its row
        # stage and that stage's figures.
        S = len(meas)
        kinds, zi = np.zeros((S, D), dtype=np.int64), np.zeros((S, D), dtype=np.int64)
        bias = np.full((S, D), -1, dtype=np.int64)
        geom, par = np.zeros((S, 4, 3)), np.zeros((S, 4))
        for j, m in enumerate(meas):
            if sat[j]:  # (a raw GNSS epoch's: the antenna's lever arm, no mounting)
                geom[j] = np.vstack([m.model.lever, np.eye(3)])
                par[j] = np.r_[m.model.figures, core.layout.start(m.model.own_block)]
                continue
            kinds[j, :m.model.dim] = m.model.kinds
            zi[j, :m.model.dim] = m.model.zindex
            bias[j, :m.model.dim] = bias_columns(core.layout, m.model)
            geom[j] = np.asarray(m.model.geometry).reshape(4, 3)
        self.sensors = Sensors(
            np.array([self.names.index(m.name) for m in meas], dtype=np.int64),
            np.array([HOWS[m.how] for m in meas], dtype=np.int64),
            np.array([0 if s else m.model.dim for m, s in zip(meas, sat, strict=True)],
                     dtype=np.int64),
            kinds, zi, geom,
            np.array([bool(m.model.linear) for m in meas], dtype=np.bool_), bias,
            np.array(sat, dtype=np.int64), par if any(sat) else None)
        self.comp = np.r_[core.comp_g, core.comp_a]
        self.xa = core.xa  # (flown in place)
        self.trans = np.ascontiguousarray(core.layout.transition(self.T), dtype=float)
        self.scale = core.scale
        self.gains = core.ins.baro_loop
        k1, k2, itg, ita, noise = em.model_constants(core.noise, core.baro_gains, core.baro_q,
                                                     core.layout)
        self.noise_vec = noise
        self.cst = np.array([self.dt, self.T, self.t0, k1, k2, itg, ita, fed.q_step,
                             fed.q_logmax])
        self.qlog = np.array([fed.qlog[k] for k in self.names])
        self.rec = Record(len(core.state), n, nf, record_cov, record_rows, innovations)
        self.k = 0
        s = core.state
        self.rec.epoch(s, fed.P, None)
        self.Pg = fed.P.copy()
        if record_rows:
            self.rec.row_block(s[0:4][None], s[4:7][None], s[7:10][None],
                               np.full((1, 3), np.nan))
        # the FDI log: t, local filter, statistic, dof, threshold, accepted
        self._log = Growing((6,))
        r = self.rec
        self._outs = [r.states, r.P, r.beta] + ([r.Phi, r.Qd, r.dx] if record_cov else [])
        self._none_rows = np.empty((0, 13))
        self._none_cov = (np.empty((0, n, n)), np.empty((0, n, n)), np.empty((0, n)))
        self._none_inn = (np.empty((0, D)), np.empty((0, D, D)), np.empty(0),
                          np.empty((0, D, n)), np.empty((0, D, D)))

    def q_scales(self) -> dict[str, float]:
        """Each filter's process-noise scale now (1: the figures')."""
        return {k: float(np.exp(v)) for k, v in zip(self.names, self.qlog, strict=True)}

    def _rows_at_most(self, m_z, m_sens) -> int:
        """The most rows a measurement of this run can have: a row model's, or two per
        satellite of a raw GNSS epoch (its slots' numbers)."""
        D = int(self.sensors.dim.max(initial=1))
        for s in np.flatnonzero(self.sensors.kind).tolist():
            z = m_z[m_sens == s, :satrows.WIDTH].reshape(-1, satrows.SLOTS, satrows.NF)
            if len(z):
                D = max(D, 2 * int(np.isfinite(z[:, :, satrows.PRN]).sum(axis=1).max()))
        return D

    def _satellites_after(self, M, lg, m_sens, m_idx, m_epoch, out_re, out_ex, inn):
        """What a run's raw GNSS epochs leave besides the log: the satellites fault
        detection left out (:attr:`FederatedFilter.excluded`), the receiver clock's jumps
        (the model's ``clock_resets``), and the epochs with no satellite above the mask
        taken out of the log and the records (the Python loop logs nothing for them)."""
        for j in np.flatnonzero(out_ex[:M, 0] >= 0.0).tolist():
            self.fed.excluded.append((float(lg[j, 0]), self.names[self.sensors.filter[
                m_sens[j]]], int(out_ex[j, 0]), float(out_ex[j, 1])))
        for s, m in enumerate(self.meas):
            if self.sensors.kind[s]:
                m.model.clock_resets += int(out_ex[:M, 2][m_sens == s].sum())
        keep = lg[:M, 3] > 0.0
        if keep.all():
            return M, m_sens, m_idx, m_epoch, out_re, inn
        k = np.flatnonzero(keep)
        lg[:len(k)] = lg[:M][k]
        inn = tuple(a[k] if len(a) else a for a in inn)
        return len(k), m_sens[k], m_idx[k], m_epoch[k], out_re[k], inn

    @property
    def comp_g(self) -> np.ndarray:
        return self.comp[:3]

    @property
    def comp_a(self) -> np.ndarray:
        return self.comp[3:]

    def fused_P(self) -> np.ndarray:
        return self.Pg

    @property
    def log(self) -> list:
        """One entry per local measurement: t, local, statistic, dof, threshold, isolated."""
        return [(t, self.names[int(f)], nis, int(dof), thr, not acc)
                for t, f, nis, dof, thr, acc in self._log.view.tolist()]

    def run(self, k0: int, k1: int, dtheta, dv, h_ref, m_epoch, m_sens, m_idx) -> None:
        """Epochs ``k0 + 1 .. k1`` with their IMU data and measurements, in application
        order: epoch, sensor position in aiding order, index into that sensor's."""
        n_ep = k1 - k0
        if n_ep <= 0:
            return
        M = len(m_idx)
        m_t = np.empty(M)
        m_z = np.zeros((M, self.W))
        m_R = np.zeros((M, 6, 6))  # (the row models'; a satellite stage makes its own)
        if M:
            for s, m in enumerate(self.meas):
                sel = m_sens == s if len(self.meas) > 1 else slice(None)
                ii = m_idx[sel]
                if not len(ii):
                    continue
                d, dz = min(m.R.shape[1], 6), m.z.shape[1]
                m_t[sel] = m.t[ii]
                m_z[sel, :dz] = m.z[ii]
                m_R[sel, :d, :d] = m.R[ii][:, :d, :d]
        rec = self.rec
        e0 = rec.states.n
        for g in self._outs:
            if g.n + n_ep > len(g.a):
                g._room(n_ep)
        n_rows = n_ep * self.n_per if self.record_rows else 0
        out_rows = self._none_rows
        if n_rows:
            rec.rows._room(n_rows)
            out_rows = rec.rows.a[rec.rows.n:rec.rows.n + n_rows]
        if self.record_cov:
            out_Phi, out_Qd = rec.Phi.a[e0:e0 + n_ep], rec.Qd.a[e0:e0 + n_ep]
            out_dx = rec.dx.a[e0:e0 + n_ep]
        else:
            out_Phi, out_Qd, out_dx = self._none_cov
        log = self._log
        j0 = log.n
        log._room(M + 2)
        # columns of at least two rows: always strided views, one compiled signature
        lg = log.a[j0:j0 + max(M, 2)]
        if self.innovations:  # (as many rows as this run's measurements have)
            D = self._rows_at_most(m_z, m_sens)
            out_r, out_S, out_bm = np.zeros((M, D)), np.zeros((M, D, D)), np.empty(M)
            out_H, out_R = np.zeros((M, D, len(self.X[0]))), np.zeros((M, D, D))
        else:
            out_r, out_S, out_bm, out_H, out_R = self._none_inn
        out_re = np.zeros((max(M, 1), 3))
        out_ex = np.zeros((max(M, 1), 3))
        lk = self.lockout
        core = self.core
        ins = Ins(core.state, self.comp, self.xa, self.trans, self.scale, self.gains, self.cst,
                  self.noise_vec, core.nsub, self.n_per)
        bank = Bank(self.X, self.P, self.beta, self.qlog, self.passes, self.fam, self.sr,
                    self.c, self.Wm, self.Wc, self.cm, self.sr if self.sr.any() else None)
        rules = Rules(self.thr, self.recovery, self.sharing, self.thr_drift, lk.arrays())
        eo = EpochOut(rec.states.a[e0:e0 + n_ep], rec.P.a[e0:e0 + n_ep],
                      rec.beta.a[e0 - 1:e0 - 1 + n_ep], out_Phi, out_Qd, out_dx, out_rows)
        mo = MeasOut(lg[:, 2], lg[:, 5], lg[:, 4], lg[:, 0], lg[:, 3], out_r, out_S, out_bm,
                     out_re, out_H, out_R, out_ex)
        code, k, f = run_epochs(k0, n_ep, ins, Imu(dtheta, dv, h_ref), bank, rules,
                                self.sensors, Batch(m_epoch, m_sens, m_t, m_z, m_R), eo, mo)
        if code:
            from ..filters import FilterError

            phase, why = FAILURES[code]
            if code == 1:
                raise FilterError(f"strapdown INS at step {k}: {why}")
            if code == 6:
                who = self.names[f] if f < len(self.names) else "fused information"
                raise FilterError(f"federated fusion: covariance of '{who}' is "
                                  f"not positive definite (epoch {k})")
            if code == 14:  # the reset's factor of P_g / beta (SquareRootForm.P's setter)
                from ..filters.base import not_pd_error

                raise not_pd_error(rec.P.a[e0 + k - k0 - 1] / self.beta[f],
                                   f"{self.fed.filters[self.names[f]].name} covariance set "
                                   f"at step {k}")
            raise FilterError(f"{self.fed.filters[self.names[f]].name} {phase} at step {k}: "
                              f"{why}")
        for g in self._outs:
            g.n += n_ep
        if n_rows:
            rec.rows.n += n_rows
        self.Pg = rec.P.a[rec.P.n - 1]
        if M and self.sensors.kind.any():
            M, m_sens, m_idx, m_epoch, out_re, (out_r, out_S, out_bm, out_H, out_R) = \
                self._satellites_after(M, lg, m_sens, m_idx, m_epoch, out_re, out_ex,
                                       (out_r, out_S, out_bm, out_H, out_R))
        if M:
            lg[:M, 1] = self.sensors.filter[m_sens]
            for j in np.flatnonzero(out_re[:M, 2] > 0.0).tolist():  # re-admissions (few)
                lk.episode(int(lg[j, 1]), out_re[j, 0], lg[j, 0], out_re[j, 1], out_re[j, 2],
                           lg[j, 2], int(lg[j, 3]))
            log.n += M
            if self.innovations:  # (read-only views of this run's own arrays; each
                # sensor's R read once)
                for a in (out_r, out_S, out_H, out_R):
                    a.flags.writeable = False
                names = [m.name for m in self.meas]
                cols = zip(lg[:M, 3].astype(np.int64).tolist(), m_sens.tolist(),
                           lg[:M, 0].tolist(), out_bm[:M].tolist(),
                           (lg[:M, 5] != 0.0).tolist(), m_epoch.tolist(), strict=True)
                rec.innovations.extend(
                    InnovationRecord(names[s], t, out_r[j, :d], out_S[j, :d, :d],
                                     out_R[j, :d, :d], b, a, out_H[j, :d], e)
                    for j, (d, s, t, b, a, e) in enumerate(cols))
        self.k = k1

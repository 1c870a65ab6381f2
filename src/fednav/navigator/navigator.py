"""The navigator: one object that runs any described system, on a stream or a batch.

::

    nav = Navigator(system, InitialState(t=t0, lla=..., vel=..., euler=..., P0=...),
                    imu_period=0.005)
    nav.add_imu(t, gyro, accel)               # one sample, or (N,) times and (N, 3) blocks
    nav.add_measurement("gnss", t, z)         # z in the sensor's units (see its module)
    nav.solution()                            # the latest t, lla, ENU vel, Euler and sigmas
    res = nav.result()                        # everything: epochs, IMU-rate rows, FDI log

Filter epochs fall on ``t0 + k T`` (``T`` the system's filter period, a whole number of
IMU periods).  IMU sample ``i`` (time stamp ``t0 + i dt``) spans ``[t_i, t_i + dt]``; epoch
``k`` integrates samples ``(k-1) n .. k n - 1``.  A measurement is used at the first
epoch at or after its arrival (``t_arrival``, default its time of validity ``t``);
within an epoch the sensors take turns in the system's aiding order, each sensor's
measurements in time order.  Epoch ``k`` is processed once an IMU sample stamped at or
after ``t_k + hold_s`` has been added (so measurements may arrive out of order and late by
up to ``hold_s``) or when :meth:`result` is asked for.  Feeding data sample by sample or
in blocks processes the same epochs with the same operations: the results are equal.

All inputs are SI (rates rad/s, specific force m/s^2, angles rad, positions lat/lon
rad, height m, ENU velocities); each sensor's ``z`` is laid out as its module says
(:mod:`fednav.sensors`).
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field
from functools import cached_property

import numba
import numpy as np

from ..core import attitude as att
from ..core import earth
from ..filters import FederatedFilter, KalmanFilter
from ..ins import error_model as em
from ..ins.states import CORE, StateLayout, with_optional
from ..ins.strapdown import STATE_LLA, STATE_Q, STATE_VEL, Strapdown
from ..io.data import UNIFORM_TOLERANCE
from ..sensors.registry import SENSORS, total_models
from .engine import CompiledLoop, why_not_compiled
from .loop import (
    ErrorStateCore,
    Meas,
    Mechanization,
    PythonLoop,
    TotalStateCore,
    build_federation,
    compensated,
    position_sources,
)
from .record import Growing
from .system import System, imu_noise_model, sensor_model, state_layout
from .total import NAV_BIAS


@numba.njit(cache=True)
def stamp_tolerance(t):
    """How close two time stamps near ``t`` [s] count as the same: 1 ns, or four units in
    the last place of large stamps such as Unix time."""
    return max(1e-9, 4.0 * np.spacing(abs(t)))


@numba.njit(cache=True)
def epoch_at(t, t0, T):
    """The filter epoch at or after time ``t`` (0: at or before the start ``t0``): the
    first ``k`` with ``t0 + k T >= t - tol`` on the epoch grid as computed (``tol``:
    :func:`stamp_tolerance`).  One compiled source for one time (a stream) and for arrays
    (:func:`epochs_at`)."""
    x = t - stamp_tolerance(t)
    k = max(math.ceil((x - t0) / T), 0)
    if k > 0 and t0 + T * (k - 1) >= x:  # rounding at a grid point
        k -= 1
    if t0 + T * k < x:
        k += 1
    return k


@numba.njit(cache=True)
def epochs_at(t, t0, T):
    """:func:`epoch_at` of every time of ``t`` (1-D)."""
    out = np.empty(t.shape[0], dtype=np.int64)
    for i in range(t.shape[0]):
        out[i] = epoch_at(t[i], t0, T)
    return out


@numba.njit(cache=True)
def integrate_stamps(t0, dt, n, st, acc, pend, stamps, data, data_inc, out):
    """IMU samples stamped off the uniform grid, integrated onto it (the stream's form of
    :func:`fednav.io.data.regular_imu`): sample ``i``'s rates hold over its own interval
    ``[t_i, t_(i+1)]``, and the grid sample ``[t0 + m dt, t0 + (m+1) dt]`` receives the
    integral over its span.

    ``n``: grid samples made so far; ``st`` = [frontier F [s] (the integral into ``acc``
    reaches it), start stamp of the pending sample [s], pending given as increments (1)
    or rates (0), a sample pending (1/0)], ``acc`` (6,): the integral over ``[t0 + n dt,
    F]`` [rad, m/s], ``pend`` (6,): the pending sample's rates [rad/s, m/s^2] or
    increments [rad, m/s] — all updated in place.  ``stamps`` (N,) [s] and ``data`` (N, 6)
    the new samples (increments when ``data_inc``); the grid samples completed are written
    to ``out`` as increments (dtheta, dv); returns how many.  The latest sample stays
    pending until the next stamp says where its interval ends."""
    F = st[0]
    praw = st[1]
    pinc = st[2] > 0.5
    has = st[3] > 0.5
    r = np.empty(6)
    m = 0
    for j in range(stamps.shape[0]):
        s = stamps[j]
        if has:
            if pinc:
                d = s - praw
                for c in range(6):
                    r[c] = pend[c] / d
            else:
                for c in range(6):
                    r[c] = pend[c]
            x = F
            g = t0 + dt * (n + m + 1)
            while g <= s:
                for c in range(6):
                    out[m, c] = acc[c] + r[c] * (g - x)
                    acc[c] = 0.0
                m += 1
                x = g
                g = t0 + dt * (n + m + 1)
            for c in range(6):
                acc[c] += r[c] * (s - x)
            F = s
        for c in range(6):
            pend[c] = data[j, c]
        praw = s
        pinc = data_inc
        has = True
    st[0] = F
    st[1] = praw
    st[2] = 1.0 if pinc else 0.0
    st[3] = 1.0 if has else 0.0
    return m


def residual_covariances(model, noise) -> np.ndarray:
    """Each row's residual covariance R (N, r, r) [residual units squared] from its noise
    (N, m) 1-sigma or (N, m, m) covariance [units of z], by the sensor's measurement
    ``model`` — the one place a measurement's noise becomes R (one R, broadcast, when
    every row's noise is the same)."""
    noise = np.asarray(noise, dtype=float)
    if not len(noise):
        return np.zeros((0, 1, 1))
    if (noise == noise[0]).all():
        R0 = model.R(noise[0])
        return np.broadcast_to(R0, (len(noise),) + R0.shape)
    return np.array([model.R(s) for s in noise])


def declared_latency(system: System) -> dict[str, float]:
    """The latency each aiding sensor declares (``sensors.NAME.timing``: ``latency_s``,
    the upper end of ``latency_range_s`` or the largest of ``latency_list_s``) [s], for
    the sensors whose ``delay_compensation`` is ``interpolate`` (the default: a delayed
    measurement is used at its time of validity within the epochs the navigator holds);
    sensors with another strategy bridge their delays themselves and are left out."""
    out = {}
    for a in system.aiding_sensors():
        tm = getattr(system.sensors[a], "timing", None)
        if tm is None or tm.delay_compensation != "interpolate":
            continue
        if tm.latency_range_s is not None:
            lat = float(tm.latency_range_s[1])
        elif tm.latency_list_s is not None:
            lat = float(max(tm.latency_list_s))
        else:
            lat = float(tm.latency_s or 0.0)
        if lat > 0.0:
            out[a] = lat
    return out


def _positive(name: str, value, zero: bool = False) -> float:
    """``value`` as a float, or a one-line ValueError naming ``name``: a positive number
    (``zero``: or zero) of seconds."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not (math.isfinite(v) and (v > 0.0 or (zero and v == 0.0))):
        raise ValueError(f"Navigator: {name} must be a {'non-negative' if zero else 'positive'}"
                         f" number of seconds, got {value!r}")
    return v


class HealthWarning(UserWarning):
    """The health monitor found something wrong with a run (:meth:`Navigator.health`)."""


class LateMeasurementWarning(UserWarning):
    """A measurement came later than the navigator holds its epochs for: dropped, or used
    at a later epoch than its time of validity's (said once per sensor and navigator)."""


#: Measurement models of the total-state navigator, by sensor (each sensor's
#: ``SensorSpec.total``; kept for 0.1's name).
TOTAL_MODELS = total_models()


@dataclass
class InitialState:
    """Where the navigator starts.

    ``P0`` is the covariance of the 18 error states in the filter units of
    :mod:`fednav.ins.error_model` (``x_filter = x_SI / SCALE``), ENU error states:

    ========  =====================================================  ==============
    rows      error state                                            filter unit
    ========  =====================================================  ==============
    0:3       platform misalignment phi east, north, up              arcmin
    3:6       velocity error east, north, up                         m/s
    6:9       position error east, north, up                         m
    9:12      gyro constant drift, body x right, y forward, z up     deg/h
    12:15     gyro first-order Gauss–Markov drift, body x, y, z      deg/h
    15:18     accelerometer bias, body x, y, z                       mg
    ========  =====================================================  ==============

    (entries the squares of those units: 1 sigma of 0.1 deg east misalignment is
    ``P0[0, 0] = 36``).  The optional states of ``filter.states`` follow, added by the
    navigator (:mod:`fednav.ins.states`).  :meth:`from_sigmas` builds it from the 1-sigma
    of each block in named units, as ``fednav process`` does from ``initial.sigma``.

    Parameters
    ----------
    t : float
        Time of the first epoch, the time stamp of the first IMU sample [s].
    lla : ndarray, shape (3,)
        Geodetic latitude, longitude [rad] and ellipsoidal height [m] (WGS-84).
    vel : ndarray, shape (3,)
        Velocity east, north, up [m/s] (local-level ENU frame).
    euler : ndarray, shape (3,)
        Attitude [pitch, roll, heading] [rad] of the body (right-forward-up) in ENU;
        heading from north toward east.
    P0 : ndarray, shape (18, 18)
        Initial error covariance in the filter units of :mod:`fednav.ins.error_model`
        [arcmin, m/s, m, deg/h, mg squared], ENU error states (the table above).
    gyro_bias : ndarray, shape (3,), optional
        Gyro bias to compensate from the start, body axes [rad/s]; None: zero.
    accel_bias : ndarray, shape (3,), optional
        Accelerometer bias to compensate from the start, body axes [m/s^2]; None: zero.
    """

    t: float
    lla: np.ndarray
    vel: np.ndarray
    euler: np.ndarray
    P0: np.ndarray
    gyro_bias: np.ndarray | None = None
    accel_bias: np.ndarray | None = None

    @classmethod
    def from_sigmas(cls, t: float, lla, vel, euler, *, attitude_deg, velocity_mps,
                    position_m, gyro_bias_deg_h=None, accel_bias_mg=None,
                    gyro_markov_deg_h=None, system: System | None = None, gyro_bias=None,
                    accel_bias=None) -> InitialState:
        """An initial state whose P0 is built from the 1-sigma of each block.

        Each sigma is one value (every axis) or three, in the order the table of the
        class docstring gives; the conversion is the processing path's
        (:func:`fednav.navigator.system.covariance_from_sigmas`, ``diag((sigma /
        SCALE)^2)``, a zero sigma floored at 1e-6 filter units).

        Parameters
        ----------
        t : float
            Time of the first epoch [s].
        lla : ndarray, shape (3,)
            Latitude, longitude [rad] and ellipsoidal height [m] (WGS-84).
        vel : ndarray, shape (3,)
            Velocity east, north, up [m/s].
        euler : ndarray, shape (3,)
            Attitude [pitch, roll, heading] [rad], body right-forward-up in ENU.
        attitude_deg : float or ndarray, shape (3,)
            1-sigma of the platform misalignment [phi east, phi north, phi up] [deg].
        velocity_mps : float or ndarray, shape (3,)
            1-sigma of the velocity error east, north, up [m/s].
        position_m : float or ndarray, shape (3,)
            1-sigma of the position error east, north, up [m].
        gyro_bias_deg_h : float or ndarray, shape (3,), optional
            1-sigma of the gyro constant drift, body x right, y forward, z up [deg/h];
            None: the ``system``'s IMU figures.
        accel_bias_mg : float or ndarray, shape (3,), optional
            1-sigma of the accelerometer bias, body axes [mg]; None: the ``system``'s.
        gyro_markov_deg_h : float or ndarray, shape (3,), optional
            1-sigma of the gyro Gauss–Markov drift, body axes [deg/h]; None: the
            ``system``'s, or 0 without one.
        system : System, optional
            The system description whose IMU figures give the bias sigmas left out
            (as ``fednav process`` takes them).
        gyro_bias : ndarray, shape (3,), optional
            Gyro bias to compensate from the start, body axes [rad/s].
        accel_bias : ndarray, shape (3,), optional
            Accelerometer bias to compensate from the start, body axes [m/s^2].

        Returns
        -------
        InitialState
            With P0 (18, 18) in filter units [arcmin, m/s, m, deg/h, mg squared].

        Raises
        ------
        ValueError
            One line naming a sigma of the wrong shape, negative or not a number, or a
            bias sigma missing without a ``system``.
        """
        from ..core import units
        from .system import covariance_from_sigmas, imu_figures

        def vec(name, v, what):
            a = np.asarray(v, dtype=float)
            if a.shape != (3,):
                raise ValueError(f"InitialState.from_sigmas: {name} has shape {a.shape}; "
                                 f"give {what}")
            if not np.isfinite(a).all():
                raise ValueError(f"InitialState.from_sigmas: {name} is not finite: "
                                 f"{a.tolist()}")
            return a

        def sig(name, v, axes):
            if v is None:
                return None
            a = np.asarray(v, dtype=float)
            if a.ndim > 1 or a.size not in (1, 3):
                raise ValueError(f"InitialState.from_sigmas: {name} has {a.size} values "
                                 f"(shape {a.shape}); give one or three ({axes})")
            if not (np.isfinite(a).all() and (a >= 0).all()):
                raise ValueError(f"InitialState.from_sigmas: {name} must be >= 0 and "
                                 f"finite, got {a.tolist()}")
            return np.broadcast_to(a.ravel(), (3,)).copy()

        enu, body = "east, north, up", "body x right, y forward, z up"
        lla = vec("lla", lla, "[lat, lon] [rad] and h [m]")
        if abs(lla[0]) > np.pi / 2:
            raise ValueError(f"InitialState.from_sigmas: latitude {lla[0]:g} is not in "
                             f"radians (|lat| <= pi/2)")
        vel = vec("vel", vel, "the velocity east, north, up [m/s]")
        euler = vec("euler", euler, "[pitch, roll, heading] [rad]")
        att_sd = sig("attitude_deg", attitude_deg, "phi east, north, up")
        vel_sd = sig("velocity_mps", velocity_mps, enu)
        pos_sd = sig("position_m", position_m, enu)
        gb = sig("gyro_bias_deg_h", gyro_bias_deg_h, body)
        gm = sig("gyro_markov_deg_h", gyro_markov_deg_h, body)
        ab = sig("accel_bias_mg", accel_bias_mg, body)
        for name, v in (("attitude_deg", att_sd), ("velocity_mps", vel_sd),
                        ("position_m", pos_sd)):
            if v is None:
                raise ValueError(f"InitialState.from_sigmas: {name} is needed")
        gb = None if gb is None else units.deg_per_h(gb)
        gm = None if gm is None else units.deg_per_h(gm)
        ab = None if ab is None else units.milli_g(ab)
        if gb is None or ab is None or gm is None:
            if system is None:
                if gb is None or ab is None:
                    raise ValueError("InitialState.from_sigmas: give gyro_bias_deg_h and "
                                     "accel_bias_mg, or system= to take them from its IMU "
                                     "figures")
                gm = np.zeros(3)
            else:
                from .system import imu_noise_model

                _, gb0, ab0 = imu_noise_model(system, 1.0)
                gb = np.full(3, gb0) if gb is None else gb
                ab = np.full(3, ab0) if ab is None else ab
                if gm is None:
                    gm = np.full(3, imu_figures(system.imu)["gyro_markov"] or 0.0)
        P0 = covariance_from_sigmas(units.deg(att_sd), vel_sd, pos_sd, gb, gm, ab)
        return cls(float(t), lla, vel, euler, P0, gyro_bias, accel_bias)


@dataclass
class Snapshot:
    """The navigation solution at one time (:meth:`Navigator.solution`).

    Attributes
    ----------
    t : float
        Time of the solution, the last IMU sample's [s].
    lla : ndarray, shape (3,)
        Latitude, longitude [rad] and ellipsoidal height [m] (WGS-84).
    vel : ndarray, shape (3,)
        Velocity east, north, up [m/s].
    euler : ndarray, shape (3,)
        Attitude [pitch, roll, heading] [rad], body right-forward-up in ENU.
    sigma : ndarray, shape (9,)
        1-sigma of the last epoch's fused estimate: attitude errors phi east, north, up
        [rad], velocity errors east, north, up [m/s], position errors east, north, up [m].
    levels : dict or None
        The protection levels and alert state, from an
        :class:`~fednav.navigator.integrity_stream.IntegrityNavigator` (None otherwise).
    """

    t: float
    lla: np.ndarray
    vel: np.ndarray
    euler: np.ndarray
    sigma: np.ndarray
    levels: dict | None = None


@dataclass
class NavResult:
    """What a run of the navigator produced (:meth:`Navigator.result`).

    Per filter epoch ``k = 0..K`` (0: the start).  The IMU-rate solution is
    :attr:`forward` (and :attr:`smoothed`), the per-filter consistency
    :attr:`consistency`, the health monitor's warnings :meth:`health`.

    Attributes
    ----------
    t : ndarray, shape (K+1,)
        Epoch times [s].
    states : ndarray, shape (K+1, 22)
        INS state after each epoch's feedback, :mod:`fednav.ins.strapdown` layout
        (``STATE_Q`` quaternion body to ENU [-], ``STATE_VEL`` ENU velocity [m/s],
        ``STATE_LLA`` latitude, longitude [rad], height [m]).
    P : ndarray, shape (K+1, n, n)
        Fused error covariance after each epoch, in filter units [arcmin, m/s, m, deg/h,
        mg squared] (:mod:`fednav.ins.error_model`, ENU error states).
    beta : dict of str to ndarray
        Sharing factor of each local filter after each epoch, shape (K,) [-].
    fdi : list of tuple
        One entry per local measurement: (time [s], local filter, chi-square statistic,
        degrees of freedom, threshold, isolated).
    innovations : list of InnovationRecord
        Every measurement's innovation, when the navigator was asked to keep them.
    Phi : ndarray, shape (K+1, n, n), or None
        Transition of the interval ending at each epoch (entry 0 zero) [-], with
        ``record_covariance``.
    Qd : ndarray, shape (K+1, n, n), or None
        Process noise of the interval ending at each epoch, filter units squared
        [arcmin, m/s, m, deg/h, mg squared], with ``record_covariance``.
    dx : ndarray, shape (K+1, n), or None
        Correction fed back at each epoch, filter units [arcmin, m/s, m, deg/h, mg], with
        ``record_covariance``.
    rows : dict of str to ndarray, or None
        With ``record_rows``: at every IMU sample the quaternion ``q`` [-], ENU velocity
        ``vel`` [m/s], ``lla`` [rad, rad, m] and body rate ``omega`` [rad/s] (row ``k n``
        holds the state after epoch k's feedback).
    data_quality : dict
        What the input checks did (late measurements dropped, ...), counts [-].
    engine : str
        ``"compiled"`` or ``"python"``: which engine ran.
    dt : float
        IMU period [s].
    smooth : bool
        Whether :attr:`smoothed` is computed (the system's ``smoother``).
    readmissions : list of dict
        One per time fault isolation had locked out every position source for
        ``filter.fdi_readmit_s`` and re-admitted one: ``local``, ``t_start_s``, ``t_s``,
        ``duration_s`` [s], ``nis_per_dof`` before and ``nis_per_dof_after`` [-] and the
        covariance's ``inflation`` [-].
    layout : StateLayout
        The optional error states after the 18 (:mod:`fednav.ins.states`; ``n`` = 18
        without).
    optional : dict of str to dict
        Per optional block at the end of the run: its ``estimate`` (the total the
        navigator applied, SI: a fraction for scale factors, metres for the GNSS error)
        and ``sigma`` (the last fused covariance's 1-sigma, SI), each per axis.
    row_kinds : dict of str to ndarray
        Each aiding sensor's row kinds [-] (:mod:`fednav.sensors.measurement`), what
        :meth:`health` groups its innovations by.
    constraints : tuple of str
        The aiding sensors [-] whose sigma is a softness (ZUPT, NHC, ZARU): judged on
        the high side of the NIS band only.
    excluded : list of tuple
        One per unit of a measurement that fault detection left out while the rest was
        used (a raw GNSS epoch's faulty satellite): (time [s], local filter, unit — the
        satellite's number —, the chi-square statistic of the rows kept).
    """

    t: np.ndarray
    states: np.ndarray
    P: np.ndarray
    beta: dict
    fdi: list
    innovations: list = field(default_factory=list)
    Phi: np.ndarray | None = None
    Qd: np.ndarray | None = None
    dx: np.ndarray | None = None
    rows: dict | None = None
    data_quality: dict = field(default_factory=dict)
    engine: str = "python"
    dt: float = float("nan")
    smooth: bool = False
    readmissions: list = field(default_factory=list)
    layout: StateLayout = CORE
    optional: dict = field(default_factory=dict)
    row_kinds: dict = field(default_factory=dict)
    constraints: tuple = ()
    excluded: list = field(default_factory=list)

    @cached_property
    def _imu_rate(self):
        from .solution import imu_rate

        return imu_rate(self, self.smooth)

    @property
    def forward(self):
        """The forward :class:`~fednav.navigator.solution.Solution` at every IMU sample
        (with its 1-sigma)."""
        return self._imu_rate[0]

    @property
    def smoothed(self):
        """The RTS-smoothed solution at every IMU sample (when the system asks for the
        smoother), else None."""
        return self._imu_rate[1]

    @property
    def consistency(self) -> dict:
        """Per local filter: mean NIS per degree of freedom, fraction isolated, count —
        with innovations recorded, ``nis_per_dof`` against the centralized filter's
        innovation covariance and the local filter's own beside it as
        ``gate_nis_per_dof`` (:func:`~fednav.navigator.health.centralized_consistency`,
        what ``fednav process`` reports); without, the local filter's own."""
        from .health import centralized_consistency
        from .solution import consistency

        if self.innovations:
            return centralized_consistency(self.fdi, self.innovations)
        return consistency(self.fdi)

    def health(self, imu=None, fixes=None, figures: dict | None = None,
               band=(0.5, 2.0)) -> list[str]:
        """The health monitor's warnings about the run (never a refusal).

        From its fault-detection log: the run's NIS/dof per local filter outside
        ``band`` (and, with innovations recorded, each row kind's), the sliding windows'
        NIS/dof and long isolations (:func:`fednav.navigator.health.run_health`).  With
        the data fed, also stuck axes and the fixes' positions against their velocities;
        with the IMU's figures, gravity, Earth rate and levelling at rest; with IMU-rate
        rows and covariances recorded, the fixes' residuals' bias per axis and their
        time offset from the IMU by correlation.

        Parameters
        ----------
        imu : ImuData, optional
            The IMU data fed (:class:`fednav.io.ImuData`: SI units, body
            right-forward-up).
        fixes : GnssData, optional
            The position fixes fed (the GNSS's, or any sensor registered as giving
            fixes; :class:`fednav.io.GnssData`: lat/lon [rad], h [m], ENU velocity
            [m/s]).
        figures : dict, optional
            The IMU's noise figures in SI units by ``imu:`` key (``gyro_arw_rad_sqrt_s``
            ...), for the checks at rest.
        band : tuple of float
            The NIS/dof band [low, high] (``health.nis_band`` of the system description).

        Returns
        -------
        list of str
            One line per warning; empty when all is well.
        """
        from .health import local_nis, readmission_warnings, row_nis, run_health

        sol = (self.forward if self.rows is not None and self.Phi is not None
               and len(self.states) > 1 else None)
        rows = row_nis(self.innovations, self.row_kinds) if self.innovations else None
        means = local_nis(self.innovations) if self.innovations else None
        return (run_health(self.fdi, imu, fixes, sol, figures, band=band, rows=rows,
                           constraints=self.constraints, means=means)
                + readmission_warnings(self.readmissions))

    @property
    def sigma(self) -> np.ndarray:
        """1-sigma of the fused estimate per epoch (K+1, n), SI (NaN where the filter has
        no such state)."""
        n = self.P.shape[-1]
        var = np.diagonal(self.P, axis1=1, axis2=2)
        if n == self.layout.n:
            return np.sqrt(var) * self.layout.scale(em.SCALE)
        out = np.full((len(var), em.N_STATES), np.nan)
        out[:, NAV_BIAS] = var
        return np.sqrt(out) * em.SCALE


class Navigator:
    """The closed loop of a navigation system: mechanize, predict, update, fuse, feed back.

    Fed online (:meth:`add_imu` and :meth:`add_measurement` as data arrive, with
    :meth:`solution` at any time) or offline (whole arrays at once), it gives the same
    result (:meth:`result`).  Frames: ENU navigation frame, body right-forward-up, SI
    units and radians (``docs/conventions.md``).

    Parameters
    ----------
    system : System
        The system description (:func:`fednav.load_system`): IMU figures, aiding sensors,
        filters, fault detection, delays, smoother.
    initial : InitialState or None
        Where it starts (position, velocity, attitude, P0); None with ``mechanization``.
    imu_period : float
        IMU sample period [s].
    imu_errors : ImuErrors, optional
        The IMU file's error figures (:class:`fednav.io.ImuErrors`, SI units), used
        where the system leaves a figure out.
    record_rows : bool
        Keep the solution at every IMU sample (what ``fednav process`` writes).
    record_covariance : bool
        Keep each interval's transition and noise and each epoch's correction (what the
        IMU-rate sigmas and the smoother need); a Monte Carlo run that reads only the
        epochs turns both off.
    innovations : bool
        Keep every measurement's innovation (what ``fednav tune`` reads).
    hold_s : float, optional
        How long after an epoch its measurements may still arrive [s]: epoch ``k`` runs
        once an IMU sample stamped ``t_k + hold`` has come.  The navigator holds at least
        as long as the system's aiding sensors declare (:func:`declared_latency`: the
        largest ``sensors.NAME.timing.latency_s``, ``latency_range_s`` or
        ``latency_list_s`` of the ``interpolate`` sensors, plus one IMU period), so that a
        measurement within its declared latency is used at its time of validity; None:
        just that.  :attr:`hold_s` is the hold in force.
    engine : str
        ``"auto"`` (compiled when every part of the system has a compiled form, else
        Python; the environment variable ``FEDNAV_ENGINE`` can set it for a whole
        program), ``"compiled"`` or ``"python"``.  :attr:`engine` says which runs,
        :attr:`why_python` why not the compiled one.
    mechanization : Mechanization, optional
        A core of the caller's (:class:`fednav.navigator.loop.Mechanization`, e.g. paper
        001's launch frame) flown instead of the ENU error-state INS, with its
        federation and measurement models (the loop is then Python).  The total-state
        and caller's cores record no IMU-rate rows or interval covariances.
    """

    def __init__(self, system: System, initial: InitialState | None, imu_period: float, *,
                 imu_errors=None, record_rows: bool = True, record_covariance: bool = True,
                 innovations: bool = False, hold_s: float | None = None,
                 engine: str = "auto", mechanization: Mechanization | None = None):
        self.system = system
        self.dt = _positive("imu_period", imu_period)
        f = system.filter
        period = f.period_s if f.period_s is not None else self.dt
        self.n_per = max(1, int(round(period / self.dt)))
        self.T = self.n_per * self.dt
        self.t0 = float(initial.t if mechanization is None else mechanization.t0)
        if not math.isfinite(self.t0):
            raise ValueError(f"Navigator: the initial time is not a number ({self.t0})")
        #: the latency each ``interpolate`` sensor declares [s] (:func:`declared_latency`)
        self.latency = declared_latency(system)
        held = max(self.latency.values(), default=0.0)
        self.hold_s = max(0.0 if hold_s is None else _positive("hold_s", hold_s, zero=True),
                          held + self.dt if held > 0.0 else 0.0)
        # the IMU stamps: on the grid t0 + i dt (within _snap), else integrated onto it
        self._snap = UNIFORM_TOLERANCE * self.dt
        self._jit = None  # (st, acc, pend) of integrate_stamps once stamps jitter
        self._warned: set = set()
        if mechanization is not None or f.state == "total":
            record_rows = record_covariance = False  # (these cores make neither)
        self.record_rows = record_rows
        self.aiding = system.aiding_sensors()
        self.quality = {"late_measurements_dropped": 0}
        #: per sensor: how long its measurements may be late and still be used at their
        #: time of validity [s] (the hold for ``interpolate``, 0: at the first epoch
        #: after their arrival, which the other delay strategies bridge)
        self._late_ok: dict[str, float] = {}
        self._used: dict[str, np.ndarray | None] = {}
        self._mech = mechanization
        roles = system.roles()
        #: the sensor whose heights damp the vertical channel (the barometer), if any
        self._damper = roles.get("damping")
        loop = None if self._damper is None else system.sensors[self._damper].loop()
        if mechanization is None:
            self.ins = Strapdown(np.asarray(initial.lla, dtype=float),
                                 np.asarray(initial.vel, dtype=float),
                                 np.asarray(initial.euler, dtype=float), self.dt, loop)
        else:
            self.ins = mechanization.core.ins
        self._damping = getattr(self.ins, "baro", None) is not None
        total = self._total = mechanization is None and f.state == "total"
        #: the error state's optional blocks (:mod:`fednav.ins.states`)
        self.layout = state_layout(system) if mechanization is None and not total else CORE
        self._imu_dth = Growing((3,))
        self._imu_dv = Growing((3,))
        self._h_ref = Growing((), np.nan)
        self._t_last = None
        self._meas: dict[str, Meas] = {}
        self._bucket: dict[str, dict[int, list[int]]] = {}  # sensor -> epoch -> indices
        self._snaps: dict[int, tuple] = {}  # epoch -> loop snapshot (recompute)
        for a in self.aiding:
            cfg = system.sensors[a]
            if total and SENSORS[a].total is None:
                raise ValueError(f"the total-state navigator has no model of sensor '{a}' "
                                 f"(it has {', '.join(total_models())})")
            model = (SENSORS[a].total if total else sensor_model(system, a)) \
                if mechanization is None else mechanization.models[a]
            self._meas[a] = Meas(a, model, cfg.timing.delay_compensation, cfg.timing,
                                 SENSORS[a].angles)
            self._bucket[a] = {}
            self._late_ok[a] = (self.hold_s if cfg.timing.delay_compensation == "interpolate"
                                else 0.0)
            # the components of z its model reads (NaN elsewhere: what it does not measure)
            self._used[a] = (np.asarray(model.zindex, dtype=np.int64)
                             if hasattr(model, "zindex") else None if mechanization
                             is not None else np.arange(self._widths(a, None)[0]))
        self._constraint = None
        if "constraint" in roles:  # (air data, for the wind constraint)
            cfg = system.sensors[roles["constraint"]]
            self._constraint = Meas(roles["constraint"], cfg.measurement_model(), "none",
                                    cfg.timing)
        if mechanization is not None:
            if engine == "compiled":
                raise ValueError(f"the compiled engine cannot run {mechanization.name}")
            self.engine, self.why_python = "python", mechanization.name
            self.loop = PythonLoop(mechanization.core, mechanization.federation,
                                   [self._meas[a] for a in self.aiding], False, None, self.t0,
                                   self.T, self.dt, self.n_per, record_rows,
                                   record_covariance, innovations)
            return
        noise, _, _ = imu_noise_model(system, self.dt, imu_errors)
        self.noise = noise
        P0 = np.asarray(initial.P0, dtype=float)
        comp0 = tuple(np.zeros(3) if b is None else np.asarray(b, dtype=float)
                      for b in (initial.gyro_bias, initial.accel_bias))
        if not self.aiding:
            self.loop = None  # a free INS
            self.engine, self.why_python = "compiled", None
            self._free = Growing((len(self.ins.state),))
            self._free.append(self.ins.state)
            self._free_comp = comp0
            return
        if total:
            from .total import total_state_ukf

            ukf = total_state_ukf(system, self.ins, P0, noise, self.T)
            core = TotalStateCore(ukf)
            fed = FederatedFilter(
                {a: KalmanFilter(np.zeros(15), np.eye(15), name=f"local '{a}'")
                 for a in self.aiding}, None,
                sharing="equal" if f.sharing == "adaptive" else f.sharing,
                fixed=f.fixed_factors, reset=True, fdi_alpha=f.fdi_alpha,
                fdi_recovery=f.fdi_recovery, fdi_readmit_s=f.fdi_readmit_s,
                positions=position_sources(self.aiding))
        else:
            baro_q = (0.0 if self._damper is None
                      else system.sensors[self._damper].damping_noise())
            layout = self.layout
            core = ErrorStateCore(self.ins, noise, self.T, f.substeps, baro_q, *comp0, layout)
            central = f.architecture == "centralized"
            names = ["central"] if central else self.aiding
            fed = build_federation(system, names, with_optional(P0, layout), layout.n)
        if f.q_adaptation is not None:
            fed.adapt_q(self.T / f.q_adaptation.time_constant_s, f.q_adaptation.max_scale)
        meas = [self._meas[a] for a in self.aiding]
        self.why_python = why_not_compiled(system, self.aiding, SENSORS)
        if engine == "auto":
            engine = os.environ.get("FEDNAV_ENGINE", "auto")
        if engine not in ("auto", "compiled", "python"):
            raise ValueError(f"engine must be auto, compiled or python, got '{engine}'")
        if engine == "compiled" and self.why_python is not None:
            raise ValueError(f"the compiled engine cannot run {self.why_python}")
        if engine != "python" and self.why_python is None:
            self.engine = "compiled"
            self.loop = CompiledLoop(core, fed, meas, self.t0, self.T, self.dt, self.n_per,
                                     record_rows, record_covariance, innovations)
        else:
            self.engine = "python"
            if self.why_python is None:
                self.why_python = "asked for"
            self.loop = PythonLoop(core, fed, meas, f.architecture == "centralized",
                                   self._constraint, self.t0, self.T, self.dt, self.n_per,
                                   record_rows, record_covariance, innovations)

    # ------------------------------------------------------------------------ input
    def add_imu(self, t, gyro=None, accel=None, *, dtheta=None, dv=None) -> None:
        """Add IMU sample(s): rates, or increments over each sample's interval.

        A sample stamped ``t`` holds over the interval that *starts* at ``t`` (the first
        sample is stamped ``t0``; docs/conventions.md): a logger's increments, stamped at
        the end of their interval, are passed at ``t - dt``.  Time stamps on the grid
        ``t0 + i dt`` (within 1e-3 of a period, :data:`fednav.io.data.UNIFORM_TOLERANCE`)
        are taken as its samples.  Stamps that
        jitter — real-time stamps, a clock that drifts from the nominal period — are
        integrated onto the grid as :func:`fednav.io.data.regular_imu` does for a file:
        each sample's rates hold over its own interval, from its stamp to the next one,
        and each grid sample receives the integral over its span, so no increment is
        dropped or counted twice and time is the stamps' (a sample's increments are
        spread over the grid by its own duration, not assumed to be one period).  From
        the first stamp off the grid on, the latest sample waits for the next stamp to
        close its interval.  A stream of jittered stamps gives the batch's result on the
        same data (``fednav.process_data``, which resamples with ``regular_imu``) to
        rounding: 4e-11 m, 1e-11 m/s and 1e-15 rad on the 240 s drive of
        ``tests/test_stream.py`` with 2 ms of jitter at 100 Hz (the sample before the
        first stamp off the grid was taken on the grid; from there on the two integrate
        alike).

        Accepted: a first stamp within half a period of the start ``t0``, then stamps
        each after the one before by less than two periods (jitter of up to half a
        period either side of the grid).  A stamp not after the one before, or a gap of
        two periods or more (a missing sample), is a ValueError naming the stamp.

        Parameters
        ----------
        t : float or ndarray, shape (N,)
            Time stamp(s) [s], increasing by about the IMU period.
        gyro : ndarray, shape (3,) or (N, 3), optional
            Angular rate, body right-forward-up [rad/s].
        accel : ndarray, shape (3,) or (N, 3), optional
            Specific force, body right-forward-up [m/s^2].
        dtheta : ndarray, shape (3,) or (N, 3), optional
            Angle increments over the sample, body axes [rad] (instead of ``gyro``).
        dv : ndarray, shape (3,) or (N, 3), optional
            Velocity increments over the sample, body axes [m/s] (instead of ``accel``).
        """
        rates = gyro is not None
        if rates and accel is None or not rates and (dtheta is None or dv is None):
            raise ValueError("add_imu: give gyro and accel (rates), or dtheta and dv "
                             "(increments)")
        if np.ndim(t) == 0:  # one sample: no block checks
            t = float(t)
            if self._jit is None and abs(t - (self.t0 + self._imu_dth.n * self.dt)) \
                    <= self._snap:  # on the grid (the common case: no arrays made)
                if rates:
                    dth = np.multiply(gyro, self.dt)
                    dvv = np.multiply(accel, self.dt)
                else:
                    dth, dvv = np.asarray(dtheta, dtype=float), np.asarray(dv, dtype=float)
                if dth.shape != (3,) or dvv.shape != (3,):
                    self._bad_imu_shape(1, dth, dvv)
                self._imu_dth.append(dth)
                self._imu_dv.append(dvv)
                if self._h_ref.n < self._imu_dth.n:
                    self._h_ref.grow(1)
                self._t_last = t
                if self.hold_s or self._imu_dth.n % self.n_per == 1 % self.n_per:
                    self._advance(final=False)  # (a sample that starts an interval)
                return
            a, b = (gyro, accel) if rates else (dtheta, dv)
            self._add_jittered(np.array([t]), np.asarray(a, dtype=float).reshape(1, -1),
                               np.asarray(b, dtype=float).reshape(1, -1), not rates)
            self._advance(final=False)
            return
        t = np.asarray(t, dtype=float).ravel()
        if not len(t):
            return
        a = np.asarray(gyro if rates else dtheta, dtype=float)
        b = np.asarray(accel if rates else dv, dtype=float)
        if a.size != 3 * len(t) or b.size != 3 * len(t):
            self._bad_imu_shape(len(t), a, b)
        a, b = a.reshape(-1, 3), b.reshape(-1, 3)
        j = 0  # (stamps jittered before: every sample integrated)
        if self._jit is None:
            n = self._imu_dth.n
            off = np.abs(t - (self.t0 + self.dt * np.arange(n, n + len(t)))) > self._snap
            j = int(np.argmax(off)) if off.any() else len(t)
        if j:  # the samples on the grid, as they are
            self._imu_dth.extend(a[:j] * self.dt if rates else a[:j])
            self._imu_dv.extend(b[:j] * self.dt if rates else b[:j])
            self._t_last = float(t[j - 1])
        if j < len(t):
            self._add_jittered(t[j:], a[j:], b[j:], not rates)
        if self._h_ref.n < self._imu_dth.n:
            self._h_ref.grow(self._imu_dth.n - self._h_ref.n)
        self._advance(final=False)

    def _bad_imu_shape(self, n: int, a, b) -> None:
        raise ValueError(f"add_imu: {n} time stamp(s) with rotation data of shape "
                         f"{np.shape(a)} and velocity data of shape {np.shape(b)} (expected "
                         f"({n}, 3) each, or (3,) for one sample)")

    def _add_jittered(self, t: np.ndarray, a: np.ndarray, b: np.ndarray, inc: bool) -> None:
        """Samples stamped ``t`` off the grid: checked, then integrated onto the grid
        (:func:`integrate_stamps`); ``a``, ``b`` (N, 3) rates or (``inc``) increments."""
        if a.shape != (len(t), 3) or b.shape != (len(t), 3):
            self._bad_imu_shape(len(t), a, b)
        n0 = self._imu_dth.n
        prev = self._t_last
        d = np.diff(t, prepend=np.nan if prev is None else prev)
        if prev is None and not abs(t[0] - self.t0) < 0.5 * self.dt:
            raise ValueError(f"add_imu: the first sample is stamped {t[0]:.6f} s, the "
                             f"navigator starts at {self.t0:.6f} s (a stamp may lie up to "
                             f"half an IMU period, {0.5 * self.dt:g} s, from it; a "
                             f"sample is stamped where its interval starts: increments "
                             f"stamped at its end, as loggers do, are passed at t - dt)")
        bad = ~(d > 0.0) | (d >= 2.0 * self.dt)
        if prev is None:
            bad[0] = False
        if bad.any():
            i = int(np.argmax(bad))
            before = prev if i == 0 else t[i - 1]
            why = ("not after the one before: time stamps must increase" if not d[i] > 0.0
                   else "a gap of a missing sample or more")
            raise ValueError(f"add_imu: sample {self._samples_in(n0) + i} is stamped "
                             f"{t[i]:.6f} s, {t[i] - before:.6f} s after the one before "
                             f"({why}; the IMU period is {self.dt:g} s and a stamp may "
                             f"jitter by up to half of it)")
        if self._jit is None:  # the first stamp off the grid: integrate from here on
            st, acc, pend = np.array([self.t0, self.t0, 0.0, 0.0]), np.zeros(6), np.zeros(6)
            if n0:  # the last sample on the grid holds until this stamp
                st[:] = (self.t0 + n0 * self.dt, self.t0 + (n0 - 1) * self.dt, 0.0, 1.0)
                pend[:3] = self._imu_dth.view[n0 - 1] / self.dt
                pend[3:] = self._imu_dv.view[n0 - 1] / self.dt
            self._jit = (st, acc, pend, [n0])
        st, acc, pend, count = self._jit
        out = np.empty((int((t[-1] - st[0]) / self.dt) + 3, 6))
        m = integrate_stamps(self.t0, self.dt, n0, st, acc, pend, np.ascontiguousarray(t),
                             np.ascontiguousarray(np.hstack([a, b])), inc, out)
        count[0] += len(t)
        if m:
            self._imu_dth.extend(out[:m, :3])
            self._imu_dv.extend(out[:m, 3:])
            if self._h_ref.n < self._imu_dth.n:
                self._h_ref.grow(self._imu_dth.n - self._h_ref.n)
        self._t_last = float(t[-1])

    def _samples_in(self, n_grid: int) -> int:
        """Samples added so far (grid samples until the stamps jittered, then counted)."""
        return n_grid if self._jit is None else self._jit[3][0]

    def add_measurement(self, sensor: str, t: float, z, *, sigma=None, R=None,
                        t_arrival: float | None = None, cov=None) -> None:
        """Add one measurement of an aiding sensor.

        It is used at the filter epoch of its time of validity when it comes within the
        hold (:attr:`hold_s`: the latency the system declares), else at the first epoch
        after its arrival (``interpolate`` then reaches back only within that epoch's
        interval); one that comes after that epoch has run is dropped.  Either is
        counted in :attr:`quality` (``late_measurements_deferred``,
        ``late_measurements_dropped``) and said once per sensor with a
        :class:`LateMeasurementWarning` naming the key to set
        (``sensors.NAME.timing.latency_s``).  Bad input — an unknown sensor, ``z`` of the
        wrong length, NaN where the sensor's model reads ``z``, ``R`` of the wrong shape,
        an arrival before the time of validity — is a ValueError naming it.

        Parameters
        ----------
        sensor : str
            The sensor's registered name (``"gnss"``, ``"star"``, ``"baro"`` ...).
        t : float
            Time of validity [s].
        z : ndarray
            The measurement in the sensor's layout and units [rad, m, m/s ...]
            (``docs/data-formats.md``; GNSS: lat, lon [rad], h [m], velocity east,
            north, up [m/s]; NaN in the components the sensor does not measure).
        sigma : ndarray, optional
            1-sigma of each component of ``z`` [units of z; latitude/longitude in north
            and east metres].
        R : ndarray, optional
            The residual covariance instead of ``sigma`` [units of the sensor's residual,
            squared]; neither: the system's figures.
        t_arrival : float, optional
            When the measurement reached the navigator [s]; default ``t``.
        cov : ndarray, optional
            Its covariance (m, m) instead of ``sigma``, for a sensor whose model takes
            one (the velocity sensor's) [units of z squared].
        """
        m = self._meas.get(sensor)
        if cov is not None:
            self.add_measurements(sensor, [t], np.atleast_2d(z),
                                  cov=np.asarray(cov, dtype=float)[None],
                                  t_arrival=None if t_arrival is None else [t_arrival])
            return
        if R is not None and m is not None and m.how != "recompute" and len(m) \
                and not self._total:
            # the common case of a stream: one value with its noise, appended in place
            t = float(t)
            ta = t if t_arrival is None else float(t_arrival)
            z = np.asarray(z, dtype=float)
            R = np.asarray(R, dtype=float)
            used = self._used[sensor]
            if z.shape != m.z.shape[1:] or R.shape != m.R.shape[1:] or not math.isfinite(
                    t + ta + (z.sum() if used is None else z[used].sum()) + R.sum()) \
                    or ta < t - 1e-9:  # (the checks and their one-line errors)
                self.add_measurements(sensor, [t], z.reshape(1, -1), R=R[None],
                                      t_arrival=[ta])
                return
            if sensor == self._damper and self._damping:  # (as add_measurements: kept if late)
                self._baro_heights(np.array([t]), z[:1])
            k = int(epoch_at(ta, self.t0, self.T))
            h = self._late_ok[sensor]
            if h:
                k0 = int(epoch_at(t, self.t0, self.T))
                k = max(k0, int(epoch_at(ta - h, self.t0, self.T)))
            if self.loop is not None and 0 < k <= self.loop.k:
                self._late(sensor, "dropped", 1, t, ta)
                return
            if h and k > k0 or not h and ta > t and m.how == "interpolate" and k > int(
                    epoch_at(t, self.t0, self.T)):
                self._late(sensor, "deferred", 1, t, ta)
            self._bucket[sensor].setdefault(k, []).append(len(m))
            m.append(t, ta, z, R, k)
            return
        self.add_measurements(sensor, [t], np.atleast_2d(z),
                              sigma=None if sigma is None else np.atleast_2d(sigma),
                              R=None if R is None else np.asarray(R, dtype=float)[None],
                              t_arrival=None if t_arrival is None else [t_arrival])

    def add_measurements(self, sensor: str, t, z, *, sigma=None, R=None,
                         t_arrival=None, cov=None) -> None:
        """Add several measurements of one sensor (see :meth:`add_measurement`).

        Parameters
        ----------
        sensor : str
            The sensor's registered name.
        t : ndarray, shape (N,)
            Times of validity [s].
        z : ndarray, shape (N, m)
            The measurements in the sensor's layout [rad, m, m/s ...].
        sigma : ndarray, shape (m,) or (N, m), optional
            1-sigma of each component, one row for all or one per measurement [units of
            z].
        R : ndarray, shape (N, r, r), optional
            Residual covariances instead of ``sigma`` [residual units squared].
        t_arrival : ndarray, shape (N,), optional
            Arrival times [s]; default ``t``.
        cov : ndarray, shape (N, m, m), optional
            Each measurement's covariance instead of ``sigma``, for a sensor whose model
            takes one (the velocity sensor's, with correlated axes) [units of z squared].
        """
        m = self._meas.get(sensor)
        if cov is not None:  # (the model makes R of it, as of sigma)
            cov = np.asarray(cov, dtype=float)
            if sigma is not None or R is not None:
                raise ValueError(f"{sensor}: give one of sigma, cov and R")
            if cov.ndim != 3 or cov.shape[1] != cov.shape[2] or len(cov) != np.size(t):
                raise ValueError(f"{sensor}: cov has shape {cov.shape}; give one (m, m) "
                                 f"covariance per measurement [units of z squared]")
            if m is not None and not self._total and hasattr(m.model, "R"):
                R = residual_covariances(m.model, cov)
            else:
                sigma = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
        if m is None:
            if self._constraint is not None and sensor == self._constraint.name:
                m = self._constraint
            elif sensor not in SENSORS:
                raise ValueError(f"unknown sensor '{sensor}'; registered: "
                                 f"{', '.join(sorted(SENSORS))}")
        t = np.asarray(t, dtype=float).ravel()
        if not len(t):
            return  # (a sensor that delivered nothing: a stop detector before any stop)
        ta = t if t_arrival is None else np.asarray(t_arrival, dtype=float).ravel()
        z = self._check_measurements(sensor, m, t, z, sigma, R, ta)
        if sensor == self._damper and self._damping:
            self._baro_heights(t, z[:, 0])
        if m is None:
            return  # configured but not aiding (a baro that only damps, say)
        cfg = self.system.sensors[sensor]
        if self._total and R is not None and sigma is None:
            raise ValueError(f"{sensor}: the total-state navigator takes each measurement's "
                             f"noise as sigma, not R")
        if sigma is None and R is None:
            sigma = cfg.sigma()
            if sigma is None:
                raise ValueError(f"{sensor}: no noise given and none in the system "
                                 f"description (sensors.{sensor})")
        one_sigma = sigma is not None and np.ndim(sigma) == 1  # the same for every row
        if sigma is not None:
            sigma = np.broadcast_to(np.asarray(sigma, dtype=float), (len(t),) + np.shape(
                sigma)[-1:]) if one_sigma else np.asarray(sigma, dtype=float)
        epochs = self._epoch_of(ta)
        h = self._late_ok.get(sensor, 0.0)
        if h or m.how == "interpolate" and t is not ta:
            valid = self._epoch_of(t)
            if h:
                epochs = np.maximum(valid, self._epoch_of(ta - h))
        keep = np.ones(len(t), dtype=bool)
        if self.loop is not None:
            late = (epochs > 0) & (epochs <= self.loop.k)
            if late.any():
                i = int(np.argmax(late))
                self._late(sensor, "dropped", int(late.sum()), t[i], ta[i])
            keep = ~late
        if m.how == "interpolate" and (h or t is not ta) and m is not self._constraint:
            deferred = keep & (epochs > valid)
            if deferred.any():
                i = int(np.argmax(np.where(deferred, ta - t, -np.inf)))
                self._late(sensor, "deferred", int(deferred.sum()), t[i], ta[i])
        t, ta, z, epochs = t[keep], ta[keep], z[keep], epochs[keep]
        if sigma is not None:
            sigma = sigma[keep]
        if R is not None:
            R = np.asarray(R, dtype=float)[keep]
        elif m is self._constraint or not hasattr(m.model, "R"):
            R = np.full((len(t), 1, 1), np.nan)
        else:
            R = residual_covariances(m.model, sigma)
        if sigma is None:
            sigma = np.full((len(t), z.shape[1]), np.nan)
        capture = np.maximum(self._epoch_of(t), 1) if m.how == "recompute" else epochs
        bucket = self._bucket.get(sensor)
        if bucket is not None:
            first = len(m)
            for j, k in enumerate(epochs.tolist()):
                bucket.setdefault(k, []).append(first + j)
        m.add(t, ta, z, R, sigma, epochs, capture)

    def _widths(self, sensor: str, m) -> tuple[int, ...] | None:
        """How many values one measurement of ``sensor`` may have: those of the ones
        before, else its registered columns less trailing ones a file may leave out
        (:attr:`fednav.sensors.spec.Column.absent`); a caller's mechanization: any at
        first (None)."""
        if m is not None and len(m):
            return (m.z.shape[1],)
        if self._mech is not None and m is not None:
            return None
        cols = SENSORS[sensor].columns
        need = max((i + 1 for i, c in enumerate(cols) if c.absent is None), default=1)
        return tuple(range(need, len(cols) + 1))

    def _check_measurements(self, sensor: str, m, t, z, sigma, R, ta) -> np.ndarray:
        """Bad measurement input as one line naming the sensor and what is wrong; ``z``
        as (N, m)."""
        n = len(t)
        z = np.asarray(z, dtype=float)
        want = self._widths(sensor, m)
        if z.ndim > 2 or z.ndim == 2 and len(z) != n:
            raise ValueError(f"{sensor}: z has shape {z.shape} for {n} time(s) of validity "
                             f"(one row per measurement)")
        per = z.size // n if z.size % n == 0 else None
        if not per or (want is not None and per not in want):
            names = ", ".join(c.name for c in SENSORS[sensor].columns) if sensor in SENSORS \
                else ""
            takes = " or ".join(map(str, want)) if want else "?"
            raise ValueError(f"{sensor}: a measurement has {z.size // n if n else z.size} "
                             f"value(s) (z of shape {z.shape} for {n} time(s)); {sensor} "
                             f"takes {takes} ({names}, in SI units: rad, m, m/s)")
        z = z.reshape(n, -1)
        bad_t = ~np.isfinite(t)
        if bad_t.any():
            raise ValueError(f"{sensor}: a time of validity is not a number "
                             f"(t = {t[int(np.argmax(bad_t))]})")
        if len(ta) != n or not np.isfinite(ta).all():
            raise ValueError(f"{sensor}: t_arrival must be {n} finite time(s) [s], got "
                             f"{np.asarray(ta).tolist()[:5]}")
        early = ta < t - 1e-9
        if early.any():
            i = int(np.argmax(early))
            raise ValueError(f"{sensor}: the measurement valid at {t[i]:.6f} s arrives at "
                             f"{ta[i]:.6f} s, before the time it describes")
        used = self._used.get(sensor)
        if used is not None and m is not None and len(used) and used.max() >= z.shape[1]:
            raise ValueError(f"{sensor}: a measurement has {z.shape[1]} value(s); its model "
                             f"reads z[{int(used.max())}] (the system's sensors.{sensor} "
                             f"settings measure more than the data hold)")
        if used is not None and m is not None:
            bad = ~np.isfinite(z[:, used]).all(axis=1)
            if bad.any():
                i = int(np.argmax(bad))
                cols = [int(c) for c in used if not np.isfinite(z[i, c])]
                names = SENSORS[sensor].columns if sensor in SENSORS else ()
                which = ", ".join(f"z[{c}]" + (f" ({names[c].name})" if c < len(names)
                                               else "") for c in cols)
                raise ValueError(f"{sensor}: the measurement at t = {t[i]:.6f} s has NaN/inf "
                                 f"in {which}, which its model reads")
        if R is not None:
            R = np.asarray(R, dtype=float)
            d = getattr(m.model, "dim", None) if m is not None else None
            if R.ndim != 3 or len(R) != n or (d is not None and R.shape[1:] != (d, d)):
                raise ValueError(f"{sensor}: R has shape {R.shape[1:] if R.ndim == 3 else R.shape}"
                                 f" per measurement; {sensor}'s residual takes ({d}, {d}) "
                                 f"[residual units squared]")
            if not np.isfinite(R).all():
                raise ValueError(f"{sensor}: R is not finite (a NaN/inf in the noise of "
                                 f"the measurement at t = {t[0]:.6f} s or later)")
        if sigma is not None:
            sg = np.asarray(sigma, dtype=float)
            if sg.ndim > 2 or (sg.ndim == 2 and len(sg) != n):
                raise ValueError(f"{sensor}: sigma has shape {sg.shape}; give one row "
                                 f"({z.shape[1]},) or one per measurement ({n}, "
                                 f"{z.shape[1]}) [units of z]")
            if used is not None and m is not None and sg.shape[-1:] == (z.shape[1],) \
                    and not np.isfinite(sg[..., used]).all():
                raise ValueError(f"{sensor}: sigma has NaN/inf where the model reads z")
        return z

    def _late(self, sensor: str, what: str, count: int, t: float, ta: float) -> None:
        """Count measurements that came later than the navigator holds for (``what``:
        ``dropped`` or ``deferred``) and say so once per sensor."""
        key = f"late_measurements_{what}"
        self.quality[key] = self.quality.get(key, 0) + count
        if (sensor, what) in self._warned:
            return
        self._warned.add((sensor, what))
        m = self._meas.get(sensor)
        how = m.how if m is not None else "interpolate"
        declared = self.latency.get(sensor)
        if ta > t:
            late = f"arrived {ta - t:.3f} s after its time of validity ({t:.3f} s)"
        else:
            late = (f"valid at {t:.3f} s came when the IMU stream had reached "
                    f"{self._t_last if self._t_last is not None else t:.3f} s")
        said = (f"sensors.{sensor}.timing.latency_s = {declared:g} s declared"
                if declared else f"no latency declared in sensors.{sensor}.timing")
        if how == "interpolate":
            fix = (f"set sensors.{sensor}.timing.latency_s (or latency_range_s, "
                   f"latency_list_s) to the largest latency: the navigator then holds each "
                   f"epoch that long and uses every measurement at its time of validity")
        else:
            fix = ("pass its arrival time (t_arrival), or hold the epochs longer "
                   "(Navigator(hold_s=...))")
        if what == "dropped":
            did = (f"after its filter epoch had run (epochs are held {self.hold_s:g} s; "
                   f"{said}): dropped")
        else:
            did = (f"later than the epochs are held ({self.hold_s:g} s; {said}): used at the "
                   f"first filter epoch after its arrival, where interpolate reaches back "
                   f"only within that epoch's {self.T:g} s, so the solution degrades")
        warnings.warn(f"{sensor}: a measurement {late}, {did} (counted in "
                      f"data_quality['{key}']; said once); {fix}", LateMeasurementWarning,
                      stacklevel=4)

    def add_series(self, series) -> None:
        """Add one sensor's whole series, recorded or simulated.

        Parameters
        ----------
        series : Series
            A :class:`fednav.io.data.Series` (``read_sensor_csv``'s, ``Prepared.series``'
            or a simulated :class:`fednav.sensors.base.MeasurementSeries`): its sensor's
            ``name``, times of validity and arrival [s], values ``z`` and each row's
            1-sigma or covariance in the sensor's units (neither: the system's figures).
        """
        self.add_measurements(series.name, series.t, series.z, sigma=series.sigma,
                              cov=series.cov, t_arrival=series.t_arrival)

    @property
    def row_kinds(self) -> dict[str, np.ndarray]:
        """Each aiding sensor's row kinds (:mod:`fednav.sensors.measurement`; sensors whose
        model is not rows are left out): what the health monitor groups a sensor's
        innovations by."""
        return {a: m.model.kinds for a, m in self._meas.items()
                if getattr(m.model, "kinds", None) is not None}

    def _epoch_of(self, t) -> np.ndarray:
        """The epoch at or after each time (:func:`epoch_at`)."""
        t = np.asarray(t, dtype=float)
        return epochs_at(np.ascontiguousarray(t.ravel()), self.t0, self.T).reshape(t.shape)

    def _baro_heights(self, t, h) -> None:
        """Baro heights for the vertical-channel loop at the IMU sample whose interval holds
        their time (the loop holds the last INS - baro difference; a height measured
        between samples is used from the start of its sample, less than one IMU period
        early)."""
        idx = np.floor((np.asarray(t, dtype=float) - self.t0) / self.dt + 1e-6).astype(int)
        ok = idx >= 0
        need = int(idx[ok].max()) + 1 if ok.any() else 0
        if need > self._h_ref.n:
            self._h_ref.grow(need - self._h_ref.n)
        self._h_ref.view[idx[ok]] = h[ok]

    # ------------------------------------------------------------------- processing
    def _todo(self, k: int, now: int) -> list:
        """The measurements of epoch ``k``: [(sensor position in aiding order, indices
        in time order)], in the order they are applied; ``recompute`` sensors: those of
        validity epoch ``k`` that arrived by epoch ``now``."""
        out = []
        for s, a in enumerate(self.aiding):
            m = self._meas[a]
            if m.how == "recompute":
                idx = np.flatnonzero((m.capture == k) & (m.epoch <= now)).tolist()
            else:
                idx = self._bucket[a].get(k)
                if not idx:
                    continue
                if len(idx) > 1:
                    t = m.t
                    idx = sorted(idx, key=lambda i: t[i])
            if idx:
                out.append((s, idx))
        return out

    def _schedule(self, k0: int, k1: int):
        """The measurements of epochs ``k0 + 1 .. k1`` in the order :meth:`_todo` applies
        them, as arrays: epoch, sensor position in aiding order, index (the compiled
        engine's form): from the epochs' lists when they are few (a stream), else by one
        sort of the measurements of those epochs (a batch)."""
        n_meas = sum(len(self._meas[a]) for a in self.aiding)
        if (k1 - k0) * len(self.aiding) < n_meas:
            ep, sens, idx = [], [], []
            for k in range(k0 + 1, k1 + 1):
                for s, ii in self._todo(k, k):
                    ep += [k] * len(ii)
                    sens += [s] * len(ii)
                    idx += ii
            return (np.array(ep, dtype=np.int64), np.array(sens, dtype=np.int64),
                    np.array(idx, dtype=np.int64))
        parts = []
        for s, a in enumerate(self.aiding):
            m = self._meas[a]
            if not len(m):
                continue
            e = m.epoch
            ii = np.flatnonzero((e > k0) & (e <= k1))
            if len(ii):
                parts.append((e[ii], np.full(len(ii), s, dtype=np.int64), ii, m.t[ii]))
        if not parts:
            z = np.zeros(0, dtype=np.int64)
            return z, z, z
        e, sens, idx, t = (np.concatenate(x) for x in zip(*parts, strict=True))
        order = np.lexsort((t, sens, e))  # stable: equal times keep their arrival order
        return e[order], sens[order], idx[order]

    def _pairs(self, todo) -> list:
        """:meth:`_todo` as [(Meas, index)] (the Python loop's form)."""
        return [(self._meas[self.aiding[s]], i) for s, idx in todo for i in idx]

    def _advance(self, final: bool) -> None:
        n = self._imu_dth.n
        done = self.loop.k if self.loop is not None else self._free.n - 1
        k_max = n // self.n_per
        if not final and self._t_last is not None:
            # epochs the stream has passed by hold_s (measurements can no longer arrive)
            k_max = min(k_max, math.floor((self._t_last - self.hold_s - self.t0) / self.T
                                          + 1e-9))
        if k_max <= done:
            return
        sl = slice(done * self.n_per, k_max * self.n_per)
        if isinstance(self.loop, CompiledLoop):
            self.loop.run(done, k_max, self._imu_dth.view[sl], self._imu_dv.view[sl],
                          self._h_ref.view[sl], *self._schedule(done, k_max))
            return
        if self.loop is None:  # a free INS: every interval in one compiled call
            gb, ab = self._free_comp
            self._free.extend(self.ins.run_intervals(
                self._imu_dth.view[sl] - gb * self.dt, self._imu_dv.view[sl] - ab * self.dt,
                self._h_ref.view[sl], self.n_per))
            return
        for k in range(done + 1, k_max + 1):
            dth, dv, h_ref = self._imu(k)
            recompute = [m for m in self._meas.values() if m.how == "recompute"]
            if not recompute:
                self.loop.cycle(k, dth, dv, h_ref, self._pairs(self._todo(k, k)))
                continue
            if not self._snaps:
                self._snaps[0] = self.loop.snapshot()
            # re-run the filter from the earliest epoch of validity of what arrived now
            j = k
            for m in recompute:
                for i in self._bucket[m.name].get(k, []):
                    j = min(j, int(m.capture[i]))
            if j < k:
                self.loop.restore(self._snaps[j - 1])
                for e in range(j, k):
                    self.loop.cycle(e, *self._imu(e), self._pairs(self._todo(e, k)),
                                    replay=True)
                    self._snaps[e] = self.loop.snapshot()
            self.loop.cycle(k, dth, dv, h_ref, self._pairs(self._todo(k, k)))
            self._snaps[k] = self.loop.snapshot()

    def _imu(self, k: int):
        """The IMU increments and baro heights of epoch ``k``'s interval."""
        sl = slice((k - 1) * self.n_per, k * self.n_per)
        h = self._h_ref.view[sl] if self._h_ref.n >= k * self.n_per else \
            np.full(self.n_per, np.nan)
        return self._imu_dth.view[sl], self._imu_dv.view[sl], h

    # ------------------------------------------------------------------------ output
    def solution(self) -> Snapshot:
        """The latest solution: the last epoch's state mechanized through the IMU samples
        added since (no filter update in between).

        Returns
        -------
        Snapshot
            Time [s], lat/lon [rad], height [m], ENU velocity [m/s], Euler angles [rad]
            and the last epoch's 1-sigma.
        """
        if not isinstance(self.ins, Strapdown):
            raise ValueError(f"solution() gives the ENU solution; the navigator flies "
                             f"{self.why_python}: read result().states")
        self._advance(final=False)
        k = self.loop.k if self.loop is not None else self._free.n - 1
        n = self._imu_dth.n
        tmp = Strapdown.__new__(Strapdown)
        tmp.__dict__.update(self.ins.__dict__)
        tmp.state = self.ins.state.copy()
        sl = slice(k * self.n_per, n)
        if n > k * self.n_per:
            loop = self.loop
            comp_g, comp_a = self._free_comp if loop is None else (loop.comp_g, loop.comp_a)
            dth, dvc = compensated(self._imu_dth.view[sl], self._imu_dv.view[sl], self.dt,
                                   comp_g, comp_a, getattr(loop, "xa", None), self.layout)
            tmp.run(dth, dvc, self._h_ref.view[sl], record=False)
        s = tmp.state
        if self.loop is not None:
            P = self.loop.fused_P()
            sd = np.sqrt(np.diagonal(P)[:9]) * em.SCALE[:9]
        else:
            sd = np.full(9, np.nan)
        return Snapshot(self.t0 + n * self.dt, s[STATE_LLA].copy(), s[STATE_VEL].copy(),
                        att.quat_to_euler(s[STATE_Q]), sd)

    def solution_at(self, t: float) -> Snapshot:
        """The solution at a chosen time.

        * From the last filter epoch on: the epoch's state mechanized through the IMU
          samples added since, the sample that holds ``t`` for the part of its interval
          before ``t`` (its rates taken as constant over it); beyond the latest sample,
          the strapdown runs on the latest sample's rates held constant (bias-compensated
          as the filter compensates them), in steps of at most one IMU period.  The
          1-sigma is the last epoch's fused covariance propagated by the error model
          over ``[t_k, t]`` (:func:`fednav.ins.error_model.interval_process`: ``Phi P
          Phi' + Qd`` with the system's IMU noise; a total-state navigator has no error
          model to do so: NaN).
        * Before the last epoch, with the IMU-rate rows recorded (``record_rows`` and
          ``record_covariance``, the defaults): the rows interpolated to ``t`` (linearly,
          the quaternion normalised), the 1-sigma as :attr:`NavResult.forward`'s
          (linear in time from the corrected covariance of the interval's start to the
          predicted one of its end).  Equal to the forward solution at its rows.
        * Earlier (before the start, or before the last epoch without the rows): a
          ValueError saying where the kept history begins.

        Parameters
        ----------
        t : float
            The time [s].

        Returns
        -------
        Snapshot
            ``t`` [s], lat/lon [rad], height [m], ENU velocity [m/s], Euler angles
            [pitch, roll, heading] [rad] and the 1-sigma of attitude [rad], velocity
            [m/s] and position [m] errors (ENU).
        """
        if not isinstance(self.ins, Strapdown):
            raise ValueError(f"solution_at() gives the ENU solution; the navigator flies "
                             f"{self.why_python}: read result().states")
        try:
            t = float(t)
        except (TypeError, ValueError):
            t = float("nan")
        if not math.isfinite(t):
            raise ValueError("solution_at: t must be a time [s], a finite number")
        self._advance(final=False)
        loop = self.loop
        k = loop.k if loop is not None else self._free.n - 1
        tk = self.t0 + k * self.T
        if t < tk - stamp_tolerance(t):
            return self._solution_from_rows(t, k)
        dt, n, i0 = self.dt, self._imu_dth.n, k * self.n_per
        comp_g, comp_a = self._free_comp if loop is None else (loop.comp_g, loop.comp_a)
        xa = getattr(loop, "xa", None)
        tmp = Strapdown.__new__(Strapdown)
        tmp.__dict__.update(self.ins.__dict__)
        tmp.state = self.ins.state.copy()
        s0 = self.ins.state.copy()
        whole = min(max(int(math.floor((t - tk) / dt + 1e-9)), 0), n - i0)
        sums = np.zeros((2, 3))
        if whole:
            sl = slice(i0, i0 + whole)
            dth, dvc = compensated(self._imu_dth.view[sl], self._imu_dv.view[sl], dt,
                                   comp_g, comp_a, xa, self.layout)
            tmp.run(dth, dvc, self._h_ref.view[sl], record=False)
            sums += dth.sum(axis=0), dvc.sum(axis=0)
        rest = t - (tk + whole * dt)
        if rest > 1e-9 * dt:
            j = i0 + whole
            if j < n:  # a part of the next sample, at its rates
                rate = np.r_[self._imu_dth.view[j], self._imu_dv.view[j]] / dt
                steps = 1
            elif n or self._jit is not None:  # beyond the latest sample: its rates held
                rate = self._latest_rates()
                steps = max(1, math.ceil(rest / dt - 1e-9))
            else:
                raise ValueError("solution_at: no IMU sample yet to carry the solution "
                                 "forward from")
            h = rest / steps
            raw = np.repeat(rate[None] * h, steps, axis=0)
            dth, dvc = compensated(raw[:, :3], raw[:, 3:], h, comp_g, comp_a, xa,
                                   self.layout)
            tmp.dt = h
            tmp.run(dth, dvc, None, record=False)
            sums += dth.sum(axis=0), dvc.sum(axis=0)
        st = tmp.state
        sd = np.full(9, np.nan)
        if loop is not None:
            P = loop.fused_P()
            core, span = loop.core, t - tk
            if span > 1e-9 * dt and not isinstance(core, ErrorStateCore):
                P = None
            elif span > 1e-9 * dt:
                nsub = max(core.nsub, math.ceil(core.nsub * span / self.T))
                proc = em.interval_process(s0, st, sums[1], span, core.noise,
                                           core.baro_gains, core.baro_q, nsub, sums[0],
                                           core.layout)
                P = proc.Phi @ P @ proc.Phi.T + proc.Qd
            if P is not None:
                sd = np.sqrt(np.diagonal(P)[:9]) * em.SCALE[:9]
        return Snapshot(t, st[STATE_LLA].copy(), st[STATE_VEL].copy(),
                        att.quat_to_euler(st[STATE_Q]), sd)

    def _latest_rates(self) -> np.ndarray:
        """The latest IMU sample's rates [rad/s, m/s^2] (6,): the sample waiting for its
        next stamp once stamps jitter, else the last on the grid."""
        if self._jit is not None:
            st, _, pend, _ = self._jit
            if st[3] > 0.5:
                return pend / self.dt if st[2] > 0.5 else pend.copy()
        n = self._imu_dth.n
        return np.r_[self._imu_dth.view[n - 1], self._imu_dv.view[n - 1]] / self.dt

    def _solution_from_rows(self, t: float, k: int) -> Snapshot:
        """:meth:`solution_at` before the last epoch ``k``: from the recorded rows."""
        loop = self.loop
        rec = getattr(loop, "rec", None)
        if t < self.t0 - stamp_tolerance(t):
            raise ValueError(f"solution_at: {t:.6f} s is before the start "
                             f"({self.t0:.6f} s)")
        if rec is None or rec.rows is None or rec.Phi is None:
            raise ValueError(f"solution_at: {t:.6f} s is before the kept history, which "
                             f"begins at the last filter epoch ({self.t0 + k * self.T:.6f} "
                             f"s); a Navigator with record_rows=True and "
                             f"record_covariance=True keeps every IMU sample")
        rows = rec.rows.view
        x = (t - self.t0) / self.dt
        i = min(max(int(math.floor(x)), 0), len(rows) - 2)
        f = min(max(x - i, 0.0), 1.0)
        a, b = rows[i], rows[i + 1]
        q1 = b[0:4] if a[0:4] @ b[0:4] >= 0.0 else -b[0:4]
        q = (1.0 - f) * a[0:4] + f * q1
        q /= np.linalg.norm(q)
        vel = (1.0 - f) * a[4:7] + f * b[4:7]
        lla = (1.0 - f) * a[7:10] + f * b[7:10]
        lla[1] = earth.wrap_lon(float(a[8] + f * earth.wrap_lon(float(b[8] - a[8]))))
        e = min(max(math.ceil((t - self.t0) / self.T - 1e-9), 1), k)
        ff = (t - (self.t0 + (e - 1) * self.T)) / self.T
        P = rec.P.view
        if ff >= 1.0 - 1e-9:
            var = np.diagonal(P[e])[:9]
        else:
            Phi = rec.Phi.view[e]
            prior = Phi[:9] @ P[e - 1] @ Phi[:9].T + rec.Qd.view[e][:9, :9]
            var = (1.0 - ff) * np.diagonal(P[e - 1])[:9] + ff * np.diagonal(prior)
        return Snapshot(t, lla, vel, att.quat_to_euler(q), np.sqrt(var) * em.SCALE[:9])

    @property
    def models(self) -> dict:
        """Each aiding sensor's measurement model as the navigator flies it, by name."""
        return {a: m.model for a, m in self._meas.items()}

    def result(self) -> NavResult:
        """Process every complete epoch and return what the run produced.

        Its arrays are views of the navigator's records, which only grow: they keep their
        values when more data are added (a later ``result()`` has the later epochs too).

        Returns
        -------
        NavResult
            Epoch states and covariances; the IMU-rate solution as ``forward`` (and
            ``smoothed``), the consistency and the health checks.
        """
        self._advance(final=True)
        if self.loop is None:
            st = self._free.view
            K = len(st) - 1
            return NavResult(self.t0 + self.T * np.arange(K + 1), st,
                             np.full((K + 1, em.N_STATES, em.N_STATES), np.nan), {}, [],
                             data_quality=dict(self.quality), dt=self.dt)
        r = self.loop.rec
        K = r.n_epochs
        names = list(self.loop.fed.filters)
        beta = {nm: r.beta.view[:, j].copy() for j, nm in enumerate(names)}
        rows = None
        if r.rows is not None:
            a = r.rows.view
            if len(a) > 1:
                a[0, 10:13] = self._imu_dth.view[0] / self.dt  # the first sample's rate
            rows = {"q": a[:, 0:4], "vel": a[:, 4:7], "lla": a[:, 7:10], "omega": a[:, 10:13]}
        cov = r.covariance
        return NavResult(self.t0 + self.T * np.arange(K + 1), r.states.view, r.P.view, beta,
                         list(self.loop.log), list(r.innovations or []),
                         r.Phi.view if cov else None, r.Qd.view if cov else None,
                         r.dx.view if cov else None, rows, dict(self.quality), self.engine,
                         self.dt, self.system.smoother,
                         [dict(e) for e in self.loop.fed.readmissions], self.layout,
                         self._optional(), self.row_kinds, self._constraints(),
                         list(getattr(self.loop.fed, "excluded", [])))

    def _constraints(self) -> tuple:
        """The aiding sensors that are constraints (their sigma a softness: ZUPT, NHC,
        ZARU)."""
        return tuple(a for a in self.aiding
                     if SENSORS[a].pseudo or SENSORS[a].detector is not None)

    def health(self, imu=None, fixes=None, figures: dict | None = None) -> list[str]:
        """The health monitor's warnings now (:meth:`NavResult.health` of
        :meth:`result`, with the system's ``health.nis_band``), each also said once
        through Python's ``warnings`` module (:class:`HealthWarning`) — what a stream
        polls.  Every complete epoch is processed first, as :meth:`result` does.

        Parameters
        ----------
        imu : ImuData, optional
            The IMU data fed (:class:`fednav.io.ImuData`), for the checks on the data.
        fixes : GnssData, optional
            The position fixes fed (:class:`fednav.io.GnssData`).
        figures : dict, optional
            The IMU's noise figures in SI units by ``imu:`` key, for the checks at rest.

        Returns
        -------
        list of str
            One line per warning; empty when all is well.
        """
        import warnings

        out = self.result().health(imu, fixes, figures, band=self.system.health.nis_band)
        said = self.__dict__.setdefault("_health_said", set())
        for w in out:
            key = w.split(":")[0][:60]  # (the same check on the same sensor: said once)
            if key not in said:
                said.add(key)
                warnings.warn(w, HealthWarning, stacklevel=2)
        return out

    def _optional(self) -> dict:
        """Each optional block's total and 1-sigma now (:attr:`NavResult.optional`)."""
        lay = self.layout
        if not lay.blocks:
            return {}
        P = self.loop.fused_P()
        sd = np.sqrt(np.diagonal(P)) * lay.scale(em.SCALE)
        xa = self.loop.xa
        return {name: {"estimate": xa[i:i + m].copy(), "sigma": sd[i:i + m].copy()}
                for name in lay.names for i, m in [(lay.start(name), lay.size(name))]}

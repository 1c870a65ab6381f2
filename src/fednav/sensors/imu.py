"""IMU error model: constant bias, white noise, bias random walk, first-order Gauss–Markov.

All quantities SI and per body axis (x right, y forward, z up):
gyro [rad/s] / [rad/sqrt(s)], accelerometer [m/s^2] / [m/s/sqrt(s)].
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numba
import numpy as np
from pydantic import Field, field_validator, model_validator

from ..core import mounting, units
from ..core.config import _Model, simulation_only


@dataclass(frozen=True)
class ImuErrors:
    """IMU error specification; every field is a scalar (all axes) or a per-axis triple.

    ``*_bias``: constant bias; with
    ``random_bias`` true it is the 1-sigma of a per-run random draw instead of the value.
    ``gyro_arw`` [rad/sqrt(s)] and ``accel_vrw`` [m/s/sqrt(s)]: white noise on the rates.
    ``*_bias_rw``: bias random walk [unit/sqrt(s)].  ``*_markov_sigma`` and
    ``*_markov_tau``: first-order Gauss–Markov bias (steady-state sigma, correlation time).
    ``gyro_scale``, ``accel_scale``: scale-factor error (a fraction; the sensor reads ``(1
    + s) x``), with ``random_bias`` the 1-sigma of a per-run draw.
    """

    gyro_bias: float | tuple = 0.0
    gyro_arw: float | tuple = 0.0
    gyro_bias_rw: float | tuple = 0.0
    gyro_markov_sigma: float | tuple = 0.0
    gyro_markov_tau: float | tuple = np.inf
    accel_bias: float | tuple = 0.0
    accel_vrw: float | tuple = 0.0
    accel_bias_rw: float | tuple = 0.0
    accel_markov_sigma: float | tuple = 0.0
    accel_markov_tau: float | tuple = np.inf
    gyro_scale: float | tuple = 0.0
    accel_scale: float | tuple = 0.0
    random_bias: bool = False


@dataclass
class ImuErrorState:
    """The realised error of one run: bias time series (N, 3) for gyro and accelerometer,
    and the scale-factor errors (3,) (fractions)."""

    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    gyro_scale: np.ndarray | None = None
    accel_scale: np.ndarray | None = None


def _axes(v) -> np.ndarray:
    """A scalar or per-axis specification as an array of 3."""
    return np.broadcast_to(np.asarray(v, dtype=float), (3,)).copy()


@numba.njit(cache=True)
def _ar1(e, a):
    """y[k] = a y[k-1] + e[k], y[-1] = 0: the recursion ``scipy.signal.lfilter([1], [1, -a],
    e)`` makes, with the same operations (equal to the bit, tested), without importing
    scipy.signal (0.7 s) in every worker process."""
    y = np.empty_like(e)
    z = 0.0
    for k in range(e.shape[0]):
        y[k] = z + e[k]
        z = y[k] * a
    return y


def _markov(n, dt, sigma, tau, rng):
    """Stationary first-order Gauss–Markov sequence (n, 3), exact discretisation.

    ``sigma`` and ``tau`` are per axis (scalars broadcast)."""
    sigma, tau = _axes(sigma), _axes(tau)
    out = np.zeros((n, 3))
    for i in range(3):
        if sigma[i] == 0 or not np.isfinite(tau[i]):
            continue  # no draw: a disabled process leaves the random stream untouched
        a = np.exp(-dt / tau[i])
        w = rng.standard_normal(n)
        e = w * sigma[i] * np.sqrt(1.0 - a * a)
        e[0] = w[0] * sigma[i]  # start in steady state
        out[:, i] = _ar1(e, a)
    return out


def corrupt_imu(dtheta, dv, dt: float, errors: ImuErrors, rng: np.random.Generator):
    """Add the IMU errors to ideal increments; returns (dtheta_meas, dv_meas, ImuErrorState).

    Every parameter may be a scalar (all axes) or a per-axis triple.  Biases are
    integrated over each interval as constant; white noise adds ``arw * sqrt(dt)`` per
    angle increment (``vrw * sqrt(dt)`` per velocity increment); a scale-factor error
    ``s`` makes ``(1 + s) dtheta`` (drawn last, from the same generator, and only when
    given: the other draws do not change).  The drawn scale factors are the state's
    ``gyro_scale``, ``accel_scale``.
    """
    dtheta = np.asarray(dtheta, dtype=float)
    dv = np.asarray(dv, dtype=float)
    n = dtheta.shape[0]
    if dtheta.shape != (n, 3) or dv.shape != (n, 3):
        raise ValueError(f"corrupt_imu: increments must be (N, 3), got {dtheta.shape} and "
                         f"{dv.shape}")

    def bias(const, rw, msig, mtau):
        c = _axes(const)
        if errors.random_bias:
            c = c * rng.standard_normal(3)
        b = np.tile(c, (n, 1))
        rw = _axes(rw)
        if np.any(rw):
            b = b + np.cumsum(rng.standard_normal((n, 3)) * rw * np.sqrt(dt), axis=0)
        return b + _markov(n, dt, msig, mtau, rng)

    gb = bias(errors.gyro_bias, errors.gyro_bias_rw, errors.gyro_markov_sigma,
              errors.gyro_markov_tau)
    ab = bias(errors.accel_bias, errors.accel_bias_rw, errors.accel_markov_sigma,
              errors.accel_markov_tau)
    dth = dtheta + gb * dt + rng.standard_normal((n, 3)) * _axes(errors.gyro_arw) * np.sqrt(dt)
    dvm = dv + ab * dt + rng.standard_normal((n, 3)) * _axes(errors.accel_vrw) * np.sqrt(dt)
    sg, sa = _axes(errors.gyro_scale), _axes(errors.accel_scale)
    if errors.random_bias:
        sg = sg * rng.standard_normal(3) if sg.any() else sg
        sa = sa * rng.standard_normal(3) if sa.any() else sa
    if sg.any():
        dth = dth + sg * dtheta
    if sa.any():
        dvm = dvm + sa * dv
    return dth, dvm, ImuErrorState(gb, ab, sg, sa)


# ---------------------------------------------------------------- the ``imu:`` section
#: Each IMU figure: its key in engineering units and the conversion to SI, and its key
#: in SI (a section gives a figure by at most one of its keys).
FIGURES = {
    "gyro_bias": ("gyro_bias_deg_h", units.deg_per_h, "gyro_bias_radps"),
    "gyro_markov": ("gyro_markov_deg_h", units.deg_per_h, "gyro_markov_radps"),
    "gyro_tau": ("gyro_markov_tau_s", None, "gyro_tau_s"),
    "gyro_arw": ("gyro_arw_deg_sqrt_h", units.deg_per_sqrt_h, "gyro_arw_rad_sqrt_s"),
    "accel_bias": ("accel_bias_ug", units.micro_g, "accel_bias_mps2"),
    "accel_markov": ("accel_markov_ug", units.micro_g, "accel_markov_mps2"),
    "accel_tau": ("accel_markov_tau_s", None, "accel_tau_s"),
    "accel_vrw": ("accel_vrw_ug_sqrt_hz", units.micro_g, "accel_vrw_mps_sqrt_s"),
}
_NONNEG = Field(None, ge=0.0)
_POS = Field(None, gt=0.0)

#: IMU grade presets: every figure of :data:`FIGURES` (SI keys), for data that come
#: without them.  Orders of magnitude of each class as Groves (*Principles of GNSS,
#: Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed., 2013, sec. 4.4 and
#: table 4.1) gives them, set toward the noisy end of the class — a filter that trusts a
#: preset too much diverges, one that trusts it too little only converges slower:
#:
#: * ``consumer`` — phone / autopilot MEMS (ICM-20602, BMI088 class) on a vibrating
#:   vehicle: turn-on bias 0.5 deg/s and 0.2 m/s^2, white noise 10 deg/sqrt(h) and
#:   0.03 m/s/sqrt(s);
#: * ``industrial`` — calibrated MEMS units (ADIS16488 class): 0.05 deg/s, 5 mg,
#:   0.3 deg/sqrt(h), 2 mg/sqrt(Hz) (vibration included);
#: * ``tactical`` — FOG / high-end MEMS: 1 deg/h, 1 mg, 0.05 deg/sqrt(h), 100 ug/sqrt(Hz);
#: * ``navigation`` — RLG / FOG navigation grade: 0.01 deg/h, 50 ug, 0.002 deg/sqrt(h),
#:   20 ug/sqrt(Hz).
#:
#: Each has a Gauss–Markov bias instability of a tenth of its turn-on bias (300 s
#: correlation; 3600 s for navigation grade).
GRADES: dict[str, dict[str, float]] = {
    name: {"gyro_bias_radps": units.deg_per_h(gb), "gyro_markov_radps": units.deg_per_h(gb) / 10,
           "gyro_tau_s": tau, "gyro_arw_rad_sqrt_s": units.deg_per_sqrt_h(arw),
           "accel_bias_mps2": units.micro_g(ab), "accel_markov_mps2": units.micro_g(ab) / 10,
           "accel_tau_s": tau, "accel_vrw_mps_sqrt_s": units.micro_g(vrw)}
    for name, gb, arw, ab, vrw, tau in (
        # (gyro bias [deg/h], ARW [deg/sqrt h], accel bias [ug], VRW [ug/sqrt Hz], tau [s])
        ("consumer", 1800.0, 10.0, 20_000.0, 3_000.0, 300.0),
        ("industrial", 180.0, 0.3, 5_000.0, 2_000.0, 300.0),
        ("tactical", 1.0, 0.05, 1_000.0, 100.0, 300.0),
        ("navigation", 0.01, 0.002, 50.0, 20.0, 3600.0))}


#: Scale-factor error 1-sigma [ppm] of each grade (Groves 2013, table 4.1 and sec. 4.4:
#: MEMS 1e3-1e4 ppm, tactical 100-1000, navigation 10-100), toward the class's larger end.
GRADE_SCALE_PPM = {"consumer": {"gyro": 10_000.0, "accel": 10_000.0},
                   "industrial": {"gyro": 3_000.0, "accel": 3_000.0},
                   "tactical": {"gyro": 500.0, "accel": 500.0},
                   "navigation": {"gyro": 50.0, "accel": 100.0}}


class ImuConfig(_Model):
    """IMU error figures, per axis (isotropic); each in whichever unit its key names.

    Turn-on bias (1-sigma of a constant; with ``random_bias`` a simulation draws it per
    run): ``gyro_bias_deg_h`` or ``gyro_bias_radps``, ``accel_bias_ug`` or
    ``accel_bias_mps2``.  First-order Gauss–Markov bias instability and its correlation
    time: ``gyro_markov_deg_h`` / ``_radps`` with ``gyro_markov_tau_s`` (or
    ``gyro_tau_s``), ``accel_markov_ug`` / ``_mps2`` with ``accel_markov_tau_s`` (or
    ``accel_tau_s``).  White noise as a density: ``gyro_arw_deg_sqrt_h`` /
    ``gyro_arw_rad_sqrt_s``, ``accel_vrw_ug_sqrt_hz`` / ``accel_vrw_mps_sqrt_s``; or per
    *sample* (``gyro_white_deg_h``, ``accel_white_ug``: converted with the IMU period).
    Bias random walk: ``gyro_bias_rw_deg_h_sqrt_h``, ``accel_bias_rw_ug_sqrt_h`` (the
    bias grows by that much per square-root hour).  Scale-factor error
    ``gyro_scale_ppm``, ``accel_scale_ppm`` [ppm]: the 1-sigma the optional scale-factor
    states (``filter.states``) start from (a ``grade`` gives the filter one when left
    out); a simulation applies the value given as the error itself (with ``random_bias``
    as the 1-sigma of a per-run draw), and none when it is left out.
    ``gyro_scale_tau_s``, ``accel_scale_tau_s`` [s]: the filter's scale-factor states as
    first-order Gauss–Markov processes with that correlation time (their stationary
    1-sigma the ``*_scale_ppm``; KF-GINS's model); left out, random constants (a
    simulation's scale factors are constants either way).

    A figure left out is unknown: recorded data take it from the data file (NaveGo's IMU
    struct), a simulation takes it as zero (infinite for correlation times).
    ``max_bridge_s``: the longest run of faulty samples (NaN/inf/absurd) in a recorded
    IMU file bridged by holding the last good one (docs/reliability.md).  ``mounting``:
    the recorded file's IMU axes in the body (axis letters or Euler angles,
    :mod:`fednav.core.mounting`), applied where the file is read.
    """

    gyro_bias_deg_h: float | None = _NONNEG
    gyro_bias_radps: float | None = _NONNEG
    gyro_markov_deg_h: float | None = _NONNEG
    gyro_markov_radps: float | None = _NONNEG
    gyro_markov_tau_s: float | None = _POS
    gyro_tau_s: float | None = _POS
    gyro_arw_deg_sqrt_h: float | None = _NONNEG
    gyro_arw_rad_sqrt_s: float | None = _NONNEG
    gyro_white_deg_h: float | None = _NONNEG
    gyro_bias_rw_deg_h_sqrt_h: float | None = _NONNEG
    accel_bias_ug: float | None = _NONNEG
    accel_bias_mps2: float | None = _NONNEG
    accel_markov_ug: float | None = _NONNEG
    accel_markov_mps2: float | None = _NONNEG
    accel_markov_tau_s: float | None = _POS
    accel_tau_s: float | None = _POS
    accel_white_ug: float | None = _NONNEG
    accel_vrw_ug_sqrt_hz: float | None = _NONNEG
    accel_vrw_mps_sqrt_s: float | None = _NONNEG
    accel_bias_rw_ug_sqrt_h: float | None = _NONNEG
    gyro_scale_ppm: float | None = _NONNEG
    accel_scale_ppm: float | None = _NONNEG
    gyro_scale_tau_s: float | None = _POS
    accel_scale_tau_s: float | None = _POS
    random_bias: bool = Field(False, json_schema_extra=simulation_only(
        "the recording's IMU has the biases it has"))
    max_bridge_s: float = Field(0.1, gt=0.0)
    #: how the IMU's axes in a recorded file are mounted in the body (axis letters such
    #: as ``FRD``, ``FLU``, ``NED``, or ``{euler_deg: [pitch, roll, heading]}``,
    #: :mod:`fednav.core.mounting`); None: the file format's own axes (fednav CSV
    #: right-forward-up, NaveGo and PX4 forward-right-down)
    mounting: str | dict | None = None
    #: a preset (:data:`GRADES`) for the figures neither this section nor the data file
    #: gives: consumer, industrial, tactical or navigation
    grade: Literal["consumer", "industrial", "tactical", "navigation"] | None = None

    @field_validator("mounting")
    @classmethod
    def _mounting(cls, v):
        return mounting.validate(v)

    @model_validator(mode="after")
    def _one_key_per_figure(self):
        for eng, _, si in FIGURES.values():
            if getattr(self, eng) is not None and getattr(self, si) is not None:
                raise ValueError(f"give {eng} or {si}, not both")
        return self

    def si(self, figure: str) -> float | None:
        """Figure ``figure`` (a key of :data:`FIGURES`) in SI, None when not given."""
        eng, to_si, si = FIGURES[figure]
        v = getattr(self, eng)
        if v is not None:
            return float(v) if to_si is None else float(to_si(v))
        v = getattr(self, si)
        return None if v is None else float(v)

    def preset(self, figure: str) -> float | None:
        """Figure ``figure`` of the section's ``grade`` (SI), None without a grade."""
        return None if self.grade is None else GRADES[self.grade][FIGURES[figure][2]]

    def _or(self, figure: str, default: float = 0.0) -> float:
        v = self.si(figure)
        if v is None:
            v = self.preset(figure)
        return default if v is None else v

    # -- the figures of a simulation (unknown = 0, correlation time unknown = infinite)
    def arw(self, dt: float) -> float:
        """Gyro white noise [rad/sqrt(s)], the density and the per-sample figure."""
        return float(np.hypot(self._or("gyro_arw"),
                              units.deg_per_h(self.gyro_white_deg_h or 0.0) * np.sqrt(dt)))

    def vrw(self, dt: float) -> float:
        """Accelerometer white noise [m/s/sqrt(s)], per sample and as a density."""
        return float(np.hypot(units.micro_g(self.accel_white_ug or 0.0) * np.sqrt(dt),
                              self._or("accel_vrw")))

    def gyro_rw(self) -> float:
        return float(units.deg_per_h(self.gyro_bias_rw_deg_h_sqrt_h or 0.0)
                     / np.sqrt(units.HOUR))

    def accel_rw(self) -> float:
        return float(units.micro_g(self.accel_bias_rw_ug_sqrt_h or 0.0) / np.sqrt(units.HOUR))

    def errors(self, dt: float) -> ImuErrors:
        """The simulated IMU's errors (:func:`corrupt_imu`)."""
        inf = float("inf")
        return ImuErrors(
            gyro_bias=self._or("gyro_bias"), gyro_arw=self.arw(dt),
            gyro_bias_rw=self.gyro_rw(), accel_bias_rw=self.accel_rw(),
            gyro_markov_sigma=self._or("gyro_markov"),
            gyro_markov_tau=self._or("gyro_tau", inf),
            accel_bias=self._or("accel_bias"), accel_vrw=self.vrw(dt),
            accel_markov_sigma=self._or("accel_markov"),
            accel_markov_tau=self._or("accel_tau", inf),
            gyro_scale=(self.gyro_scale_ppm or 0.0) * 1e-6,
            accel_scale=(self.accel_scale_ppm or 0.0) * 1e-6, random_bias=self.random_bias)

    def scale_tau(self, which: str) -> float:
        """Correlation time [s] of the ``gyro`` or ``accel`` scale-factor state (inf: a
        random constant)."""
        v = getattr(self, f"{which}_scale_tau_s")
        return float("inf") if v is None else float(v)

    def scale_sigma(self, which: str) -> float | None:
        """1-sigma of the ``gyro`` or ``accel`` scale-factor error (a fraction): the
        section's ``*_scale_ppm``, else its grade's (:data:`GRADE_SCALE_PPM`), else None."""
        v = getattr(self, f"{which}_scale_ppm")
        if v is None and self.grade is not None:
            v = GRADE_SCALE_PPM[self.grade][which]
        return None if v is None else float(v) * 1e-6

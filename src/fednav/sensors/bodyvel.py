"""Velocity sensors in body axes and zero-velocity updates: odometer, DVL, ZUPT.

* ``odometer`` — forward speed of the point at its lever arm (a wheel's axle), body
  axes.  Section ``sensors.odometer``: ``sigma_mps``, ``lever_m`` (body
  right-forward-up, m), ``period_s``.  File columns: ``t_s, speed_mps``.
* ``dvl`` — 3-axis velocity of the point at its lever arm in body axes (a Doppler
  velocity log, a body-mounted velocity sensor).  Section ``sensors.dvl``:
  ``sigma_mps`` (one value or [right, forward, up]), ``lever_m``, ``period_s``.  File
  columns: ``t_s, vR_mps, vF_mps, vU_mps``.
* ``nhc`` — non-holonomic constraint: the wheel-ground contact point of a land vehicle
  (``lever_m``) moves neither sideways nor up; ``sigma_mps`` (lateral, vertical);
  without a file ``fednav process`` applies it every ``period_s`` (default: each filter
  epoch).  File columns (if any): ``t_s, vR_mps, vU_mps`` (zeros).
* ``zupt`` — zero-velocity update: the vehicle stands still (ENU velocity zero) at the
  listed times.  Section ``sensors.zupt``: ``sigma_mps`` (how still "still" is: engine
  vibration, a rocking hull), ``period_s`` (how often a stop is used), and for
  simulation ``stationary_below_mps`` (the true speed under which the vehicle counts as
  stopped).  File columns: ``t_s, vE_mps, vN_mps, vU_mps`` (zeros: the rows of a
  stop detector's output); without a file ``fednav process`` detects the stops itself
  (:func:`detect_stops`).

Residuals (linear in the error state, compiled rows of
:mod:`fednav.sensors.measurement`): odometer and DVL ``C^T v + omega x l - z`` (body
right, forward, up; the attitude error couples through ``-(c_j x v) . phi``); ZUPT
``v - z`` (ENU).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import Field, field_validator

from ..core.config import simulation_only
from .base import MeasurementSeries, flight_times
from .measurement import BVEL_F, BVEL_R, BVEL_U, VEL_E, VEL_N, VEL_U, RowModel
from .spec import Column, SensorConfig, SensorSpec

_V3 = tuple[float, float, float]


@dataclass(frozen=True)
class BodyVelocitySensor:
    """Velocity of the sensor's point in its own axes (``truth``: the trajectory seen
    from it, :class:`~fednav.sensors.base.SensorView`) with white noise ``sigma`` (per
    component of ``axes``: 0 right, 1 forward, 2 up) every ``period`` [s]."""

    kind: str
    axes: tuple[int, ...]
    sigma: tuple
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        v = truth.at(t)["vel_sensor"][:, list(self.axes)]
        sig = np.broadcast_to(np.asarray(self.sigma, dtype=float), (len(self.axes),))
        z = v + rng.standard_normal(v.shape) * sig
        return MeasurementSeries(self.kind, t, z, sig.copy(), t_avail)


@dataclass(frozen=True)
class StandstillDetector:
    """Zero measurements (velocity: ZUPT; angular rate: ZARU) every ``period`` [s] while
    the true speed is below ``below`` [m/s] (an ideal stop detector); the noise ``sigma``
    is not drawn (the vehicle really stands still: ``sigma`` says how still the filter
    takes that to be)."""

    sigma: float
    below: float
    period: float
    kind: str = "zupt"

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        idx = np.rint((t - truth.t[0]) / truth.dt).astype(int)
        still = np.linalg.norm(truth.vel[idx], axis=1) < self.below
        t = t[still]
        if t_avail is not None:
            t_avail = np.asarray(t_avail)[still]
        return MeasurementSeries(self.kind, t, np.zeros((len(t), 3)), np.full(3, self.sigma),
                                 t_avail)


@dataclass(frozen=True)
class ZeroPseudo:
    """Pseudo-measurements ``z = 0`` of ``dim`` components every ``period`` [s] (a
    constraint the vehicle always obeys: no noise is drawn, ``sigma`` says how softly
    the filter takes it)."""

    kind: str
    sigma: tuple
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        sig = np.asarray(self.sigma, dtype=float)
        return MeasurementSeries(self.kind, t, np.zeros((len(t), len(sig))), sig.copy(),
                                 t_avail)


class _Diagonal(RowModel):
    def R(self, sigma) -> np.ndarray:
        return np.diag(np.broadcast_to(np.asarray(sigma, dtype=float), (self.dim,)) ** 2)


class OdometerSpeed(_Diagonal):
    """Odometer: residual = INS-derived forward speed of the wheel point - measured [m/s]."""

    kind = "odometer"
    rows = ((BVEL_F, 0),)


class DvlVelocity(_Diagonal):
    """DVL: residual = INS-derived body velocity (right, forward, up) of the sensor's point
    - measured [m/s]."""

    kind = "dvl"
    rows = ((BVEL_R, 0), (BVEL_F, 1), (BVEL_U, 2))


class NonHolonomic(_Diagonal):
    """Non-holonomic constraint: residual = INS-derived body velocity (right, up) of the
    wheel-ground contact point - 0 [m/s]."""

    kind = "nhc"
    rows = ((BVEL_R, 0), (BVEL_U, 1))


class ZeroVelocity(_Diagonal):
    """ZUPT: residual = INS velocity (ENU) - 0 [m/s]."""

    kind = "zupt"
    rows = ((VEL_E, 0), (VEL_N, 1), (VEL_U, 2))


class OdometerConfig(SensorConfig):
    """Odometer: 1-sigma of the forward speed [m/s], lever arm of the measuring wheel's
    contact point (body right-forward-up, m), and its ``scale`` factor on recorded data
    (measured = scale x true speed: a worn or under-inflated tyre; ``auto``: estimated
    against the GNSS speed, :func:`odometer_scale`); ``fednav process`` divides it out."""

    sigma_mps: float = Field(gt=0.0)
    scale: float | Literal["auto"] = 1.0

    @field_validator("scale")
    @classmethod
    def _scale(cls, v):
        if v != "auto" and not 0.5 < v < 2.0:
            raise ValueError(f"an odometer scale factor is near 1 (0.5..2), got {v}")
        return v

    def sensor(self) -> BodyVelocitySensor:
        return BodyVelocitySensor("odometer", (1,), (self.sigma_mps,), self.period_s)

    def model(self) -> OdometerSpeed:
        return OdometerSpeed()

    def sigma(self) -> np.ndarray:
        return np.array([self.sigma_mps])


class DvlConfig(SensorConfig):
    """DVL / body velocity sensor: 1-sigma (one value or [right, forward, up] m/s) and
    lever arm (body right-forward-up, m)."""

    sigma_mps: float | _V3

    def sensor(self) -> BodyVelocitySensor:
        return BodyVelocitySensor("dvl", (0, 1, 2), tuple(self.sigma()), self.period_s)

    def model(self) -> DvlVelocity:
        return DvlVelocity()

    def sigma(self) -> np.ndarray:
        return np.broadcast_to(np.asarray(self.sigma_mps, dtype=float), (3,)).copy()


class NhcConfig(SensorConfig):
    """Non-holonomic constraint of a land vehicle: the wheel-ground contact point (lever
    arm, body right-forward-up, m: the rear axle's middle for a car) moves neither
    sideways nor up; 1-sigma of the lateral and vertical velocity that allows [m/s]
    (tyre slip, suspension, a road's camber).  Without a file, ``fednav process`` applies
    it every ``period_s`` (default: every filter epoch)."""

    sigma_mps: float | tuple[float, float] = (0.1, 0.1)

    def _sig(self) -> tuple[float, float]:
        s = np.broadcast_to(np.asarray(self.sigma_mps, dtype=float), (2,))
        if np.any(s <= 0):
            from ..core.config import ConfigError

            raise ConfigError("sensors.nhc.sigma_mps: sigmas must be positive")
        return tuple(map(float, s))

    def sensor(self) -> ZeroPseudo:
        return ZeroPseudo("nhc", self._sig(), self.period_s)

    def model(self) -> NonHolonomic:
        return NonHolonomic()

    def sigma(self) -> np.ndarray:
        return np.array(self._sig())


class StopConfig(SensorConfig):
    """What updates at stops share: in simulation, stops are where the true speed is
    below ``stationary_below_mps``; on recorded data without a file, where the
    stand-still detector (:func:`detect_stops`) finds them: its window
    ``detect_window_s`` [s], its false-alarm probability ``detect_alpha`` (a still
    window called moving), and the GNSS horizontal speed a stop must stay under where a
    fix lies within 1 s (``max_gnss_speed_mps``)."""

    stationary_below_mps: float = Field(default=1e-3, gt=0.0, json_schema_extra=simulation_only(
        "recorded stops come from the file or the stand-still detector (detect_*)"))
    detect_window_s: float = Field(default=0.5, gt=0.0)
    detect_alpha: float = Field(default=1e-3, gt=0.0, lt=1.0)
    max_gnss_speed_mps: float = Field(default=0.3, gt=0.0)


class ZuptConfig(StopConfig):
    """Zero-velocity updates: 1-sigma of "still" [m/s]; stops as :class:`StopConfig`."""

    sigma_mps: float = Field(default=0.02, gt=0.0)

    def sensor(self) -> StandstillDetector:
        return StandstillDetector(self.sigma_mps, self.stationary_below_mps, self.period_s)

    def model(self) -> ZeroVelocity:
        return ZeroVelocity()

    def sigma(self) -> np.ndarray:
        return np.full(3, self.sigma_mps)


#: GNSS speed [m/s] above which an odometer sample counts for its scale factor.
SCALE_SPEED = 2.0


def odometer_scale(t, speed, gnss) -> tuple[float, float] | None:
    """The odometer's scale factor ``k`` (measured = ``k`` x true forward speed) and its
    1-sigma, from the GNSS speed (3-D, interpolated at the odometer's times ``t`` [s],
    not across a gap in the fixes) at the samples faster than :data:`SCALE_SPEED`: the
    least-squares slope of ``speed`` [m/s] on it (a constant ``k``: tyre wear and
    pressure change it slowly).  Sideslip
    and the antenna's lever arm in turns leave a bias of a few 1e-4.  None without GNSS
    velocities or with fewer than 20 such samples."""
    if gnss is None or gnss.vel is None or len(gnss.t) < 2:
        return None
    t = np.asarray(t, dtype=float)
    inside = (t >= gnss.t[0]) & (t <= gnss.t[-1])
    # only between fixes that are near each other (not across an outage)
    j = np.clip(np.searchsorted(gnss.t, t), 1, len(gnss.t) - 1)
    inside &= (gnss.t[j] - gnss.t[j - 1]) <= 2.0 * float(np.median(np.diff(gnss.t)))
    g = np.linalg.norm(np.column_stack([np.interp(t, gnss.t, gnss.vel[:, j])
                                        for j in range(3)]), axis=1)
    m = inside & (g > SCALE_SPEED) & np.isfinite(speed)
    if m.sum() < 20:
        return None
    o, g = np.asarray(speed, dtype=float)[m], g[m]
    k = float(o @ g / (g @ g))
    res = o - k * g
    per_fix = max(1.0, m.sum() / max(1, np.sum((gnss.t >= t[m][0]) & (gnss.t <= t[m][-1]))))
    sigma = float(np.sqrt(res @ res / (len(o) - 1) / (g @ g) * per_fix))
    return k, sigma


def calibrate_odometer(data, gnss, section: OdometerConfig | None):
    """The odometer's speeds divided by its scale factor (``section.scale``; or, with
    ``auto``, the one :func:`odometer_scale` finds against the GNSS speed), with what
    was seen: (data, {quality}, [warnings]) — :attr:`SensorSpec.calibrate` of the
    odometer."""
    from dataclasses import replace

    given = 1.0 if section is None else section.scale
    seen = odometer_scale(data.t, data.z[:, 0], gnss)
    quality, warnings = {}, []
    if seen is not None:
        quality["odometer_scale_seen"] = round(seen[0], 5)
        quality["odometer_scale_sigma"] = round(seen[1], 5)
    if given == "auto":
        if seen is None:
            from ..core.config import ConfigError

            raise ConfigError(f"{data.source}: sensors.odometer.scale: auto needs GNSS "
                              f"velocities while faster than 2 m/s (20 odometer samples)")
        use = seen[0]
    else:
        use = float(given)
        if seen is not None and abs(seen[0] - use) > max(0.005, 3.0 * seen[1]):
            warnings.append(f"{data.source}: the odometer reads {seen[0]:.4f} x the GNSS "
                            f"speed (+-{seen[1]:.4f}), its scale is taken as {use:g}: "
                            f"sensors.odometer.scale (or auto) corrects it")
    if use != 1.0:
        data = replace(data, z=data.z / use,
                       sigma=None if data.sigma is None else data.sigma / use)
    return data, quality, warnings


def detect_stops(imu, gnss, section: StopConfig, noise, gyro_bias: float,
                 period: float, t0: float) -> np.ndarray:
    """Times [s] on the filter's epoch grid ``t0 + k period`` (every ``section.period_s``
    when it is a multiple) whose whole interval the vehicle stands still: every IMU
    sample of it in a still window of the SHOE detector
    (:func:`fednav.ins.stops.stationary`, thresholds from the filter's IMU white noise
    ``noise.gyro_arw``, ``noise.accel_vrw`` and the turn-on ``gyro_bias``), and the GNSS
    horizontal speed below ``section.max_gnss_speed_mps`` where a fix lies within 1 s —
    from the fixes' velocity, or from their positions' differences over 2 s (with a
    3-sigma allowance for their noise) for position-only receivers; during an outage the
    IMU alone decides.  Vibration beyond the data
    sheet's noise (an idling engine) makes windows "moving": fewer stops, never false
    ones; a vehicle cruising without any vibration (a simulation) would look still, which
    the GNSS gate catches while there is GNSS."""
    from ..ins.stops import stationary

    dt = imu.period()
    still = stationary(imu.gyro, imu.accel, dt, noise.gyro_arw, noise.accel_vrw, gyro_bias,
                       section.detect_window_s, section.detect_alpha)
    step = max(1, int(round((section.period_s or period) / period))) * period
    t = t0 + step * np.arange(1, int(np.floor((imu.t[-1] - t0) / step + 1e-9)) + 1)
    # an epoch is still when no moving sample lies in (t - step, t]
    moving = np.concatenate([[0], np.cumsum(~still)])
    hi = np.searchsorted(imu.t, t, side="right")
    lo = np.searchsorted(imu.t, t - step, side="right")
    ok = (moving[hi] - moving[lo]) == 0
    if gnss is not None and len(gnss.t) > 1:
        j = np.clip(np.searchsorted(gnss.t, t), 1, len(gnss.t) - 1)
        j = np.where(np.abs(gnss.t[j - 1] - t) < np.abs(gnss.t[j] - t), j - 1, j)
        near = np.abs(gnss.t[j] - t) <= 1.0
        if gnss.vel is not None:
            speed = np.hypot(gnss.vel[j, 0], gnss.vel[j, 1])
            limit = section.max_gnss_speed_mps
        else:  # position-only: the speed of the positions over +-1 s
            vel, sigma = gnss.position_velocity(1.0)
            speed = np.hypot(vel[j, 0], vel[j, 1])
            near &= np.isfinite(sigma[j])
            limit = np.maximum(section.max_gnss_speed_mps, 3.0 * np.where(
                np.isfinite(sigma[j]), sigma[j], 0.0))
        ok &= ~(near & (speed > limit))
    return t[ok]


ODOMETER = SensorSpec("odometer", "odometer: forward speed in body axes at its lever arm",
                      OdometerConfig, OdometerSpeed, columns=(Column("speed_mps"),),
                      calibrate=calibrate_odometer)
DVL = SensorSpec("dvl", "DVL / body velocity sensor: velocity in body axes right, forward, "
                 "up at its lever arm", DvlConfig, DvlVelocity,
                 columns=(Column("vR_mps"), Column("vF_mps"), Column("vU_mps")))
NHC = SensorSpec("nhc", "non-holonomic constraint: no lateral or vertical velocity at the "
                 "wheel-ground contact (land vehicles)", NhcConfig, NonHolonomic,
                 columns=(Column("vR_mps"), Column("vU_mps")), pseudo=True)
ZUPT = SensorSpec("zupt", "zero-velocity update: ENU velocity zero while stopped (no "
                  "file: stops detected from the IMU)", ZuptConfig, ZeroVelocity,
                  columns=(Column("vE_mps"), Column("vN_mps"), Column("vU_mps")),
                  detector=detect_stops)

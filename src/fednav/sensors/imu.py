"""IMU error model: constant bias, white noise, bias random walk, first-order Gauss–Markov.

All quantities SI and per body axis (x right, y forward, z up):
gyro [rad/s] / [rad/sqrt(s)], accelerometer [m/s^2] / [m/s/sqrt(s)].
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np


@dataclass(frozen=True)
class ImuErrors:
    """IMU error specification; every field is a scalar (all axes) or a per-axis triple.

    ``*_bias``: constant bias; with
    ``random_bias`` true it is the 1-sigma of a per-run random draw instead of the value.
    ``gyro_arw`` [rad/sqrt(s)] and ``accel_vrw`` [m/s/sqrt(s)]: white noise on the rates.
    ``*_bias_rw``: bias random walk [unit/sqrt(s)].  ``*_markov_sigma`` and
    ``*_markov_tau``: first-order Gauss–Markov bias (steady-state sigma, correlation time).
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
    random_bias: bool = False


@dataclass
class ImuErrorState:
    """The realised error of one run: bias time series (N, 3) for gyro and accelerometer."""

    gyro_bias: np.ndarray
    accel_bias: np.ndarray


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
    angle increment (``vrw * sqrt(dt)`` per velocity increment).
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
    return dth, dvm, ImuErrorState(gb, ab)

"""The total-state navigator's master filter (paper 003): its models from the system."""

from __future__ import annotations

import numpy as np

from ..ins import error_model as em
from ..ins.total_state import TotalStateUKF

#: Positions of the total-state filter's 15 states in the 18-state error layout.
NAV_BIAS = np.r_[0:12, 15:18]


def total_state_models(P18: np.ndarray, noise: em.ImuNoiseModel, T: float):
    """P0 (15, 15), Qw (6, 6), Qb (6, 6) and bias decay (6,) of the total-state UKF.

    Bias states (filter units deg/h, mg) start from the 18-state ``P18``'s constant/Markov
    bias sigma and follow a first-order Gauss–Markov process with the IMU model's
    correlation time (random walk when it is infinite), driven by the bias random walk and
    the Markov noise; ``Qw`` is the white gyro/accelerometer noise averaged over one
    interval.
    """
    P0 = P18[np.ix_(NAV_BIAS, NAV_BIAS)]
    decay = np.r_[np.full(3, np.exp(-T / noise.gyro_markov_tau)),
                  np.full(3, np.exp(-T / noise.accel_markov_tau))]
    qb = np.r_[np.full(3, noise.gyro_bias_rw**2 * T
                       + (1 - decay[0] ** 2) * noise.gyro_markov_sigma**2),
               np.full(3, noise.accel_bias_rw**2 * T
                       + (1 - decay[3] ** 2) * noise.accel_markov_sigma**2)]
    bscale = np.r_[em.SCALE[9:12], em.SCALE[15:18]]
    Qw = np.diag(np.r_[np.full(3, noise.gyro_arw**2 / T), np.full(3, noise.accel_vrw**2 / T)])
    return P0, Qw, np.diag(qb / bscale**2), decay


def total_state_ukf(system, ins, P18, noise, T: float) -> TotalStateUKF:
    """The master filter of ``system`` flying ``ins``."""
    f = system.filter
    P0, Qw, Qb, decay = total_state_models(P18, noise, T)
    return TotalStateUKF(ins, P0, Qw, Qb, decay, f.alpha, f.beta, f.kappa)

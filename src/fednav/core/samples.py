"""IMU samples and their time stamps, as docs/conventions.md writes them: a sample
stamped ``t_k`` holds over ``[t_k, t_k+1]`` (from its stamp to the next one).  The one
place of the two things every check and alignment that integrates or interpolates the
samples needs."""

from __future__ import annotations

import numpy as np


def held_integral(t, x) -> np.ndarray:
    """The integral from ``t[0]`` to each stamp ``t[k]`` of samples ``x`` (N, ...) held
    from their stamps (``t`` (N,) [s]): ``sum_{j<k} x_j (t_j+1 - t_j)``, 0 at ``t[0]``;
    the last sample, whose interval ends after the last stamp, adds nothing."""
    x = np.asarray(x, dtype=float)
    d = np.diff(np.asarray(t, dtype=float)).reshape(-1, *([1] * (x.ndim - 1)))
    return np.concatenate([np.zeros((1, *x.shape[1:])), np.cumsum(x[:-1] * d, axis=0)])


def midpoints(t) -> np.ndarray:
    """The times [s] samples stamped ``t`` (N,) [s] stand for as points of the signal:
    their intervals' middles, ``t + dt / 2`` (``dt`` the mean interval: uniform after
    :func:`fednav.io.data.regular_imu`)."""
    t = np.asarray(t, dtype=float)
    return t + 0.5 * float((t[-1] - t[0]) / (len(t) - 1))

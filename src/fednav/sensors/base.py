"""Time-stamped measurement series shared by all aiding sensors."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np


@dataclass
class MeasurementSeries:
    """Measurements of one sensor.

    ``t`` (N,) time the measurement describes [s]; ``t_avail`` (N,) time it becomes
    available to the filter [s] (equal to ``t`` without latency); ``z`` (N, m) values in
    the sensor's natural units (radians, metres ...); ``sigma`` (m,) 1-sigma noise of each
    component of ``z``, in metric units for latitude/longitude (north/east metres), else in
    the component's own units; ``kind`` names the measurement model that interprets ``z``.
    A simulated sensor's :class:`~fednav.io.data.Series` (``name``, ``t_arrival``,
    ``source``, ``cov``, ``absent``, ``quality`` give it the recorded series' fields).
    """

    kind: str
    t: np.ndarray
    z: np.ndarray
    sigma: np.ndarray
    t_avail: np.ndarray | None = None

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float)
        self.z = np.atleast_2d(np.asarray(self.z, dtype=float))
        if self.t_avail is None:
            self.t_avail = self.t.copy()
        self.t_avail = np.asarray(self.t_avail, dtype=float)
        if self.t_avail.shape != self.t.shape:
            raise ValueError(f"{self.kind}: {len(self.t)} times but {len(self.t_avail)} "
                             f"availability times")
        if np.any(self.t_avail < self.t - 1e-9):
            raise ValueError(f"{self.kind}: a measurement is available before it is taken")
        if len(self.t) and np.any(np.diff(self.t) <= 0):
            raise ValueError(f"{self.kind}: measurement times must be strictly increasing")
        if self.z.shape[0] != len(self.t):
            raise ValueError(f"{self.kind}: {len(self.t)} times but {self.z.shape[0]} values")
        self._check_values()

    def _check_values(self) -> None:
        """Every value finite (a series whose measurements leave some out says so here,
        e.g. the raw GNSS's empty satellite slots)."""
        if not np.all(np.isfinite(self.z)):
            raise ValueError(f"{self.kind}: non-finite measurement values")

    # -- the fields of a recorded series (fednav.io.data.Series)
    cov: ClassVar[None] = None
    absent: ClassVar[tuple] = ()

    @property
    def name(self) -> str:
        return self.kind

    @property
    def t_arrival(self) -> np.ndarray:
        return self.t_avail

    @property
    def source(self) -> str:
        return f"simulated {self.kind}"

    @property
    def quality(self) -> dict:
        return {}


def position_noise_to_llh(lla, d_neu):
    """Add metric offsets ``d_neu`` = (north, east, up) [m] to positions ``lla`` (N, 3)."""
    from ..core.earth import move_enu

    return move_enu(lla, np.asarray(d_neu, dtype=float)[..., [1, 0, 2]])


def sample_times(t_end: float, period: float, t0: float | None = None) -> np.ndarray:
    """Sample instants ``period, 2*period, ...`` up to ``t_end`` (or starting at ``t0``)."""
    if period <= 0:
        raise ValueError(f"sensor period must be positive, got {period}")
    start = period if t0 is None else t0
    n = int(np.floor((t_end - start) / period + 1e-9)) + 1
    return start + period * np.arange(max(n, 0))


def flight_times(truth, period: float, t=None) -> np.ndarray:
    """``t`` when given (explicit capture times), else every ``period`` over the flight."""
    if t is not None:
        return np.asarray(t, dtype=float)
    return sample_times(truth.t[-1], period, truth.t[0] + period)


class SensorView:
    """A true trajectory as one sensor sees it: from its point at ``lever`` (body
    right-forward-up, m) and in its axes (``M = C_s^b``, None: the body's).

    The one place the simulator applies a sensor's lever arm and mounting
    (:meth:`fednav.sensors.spec.SensorConfig.simulate` hands every sensor's simulator
    this view): :meth:`at` gives the position ``lla`` and ENU velocity ``vel`` of the
    sensor's point (``earth.lever_arm_point``: ``move_enu(lla, C l)`` and ``vel + C
    (omega x l)``, the body rate from the true angle increments), the attitude of its axes
    ``C`` (``C_b^n M``) and ``euler``, the point's velocity in its axes ``vel_sensor``
    (``C^T vel``) and the wind; everything else (``t``, ``dt``, the IMU's own ``vel`` for
    a stop detector) is the trajectory's.  Without a lever arm or mounting the values are
    the trajectory's own, to the bit."""

    def __init__(self, truth, lever, M):
        self.truth = truth
        self.lever = np.asarray(lever, dtype=float)
        self.M = M

    @classmethod
    def of(cls, truth, lever=None, M=None) -> SensorView:
        """``truth`` seen from ``lever`` in axes ``M`` (a view of a view sees through)."""
        if isinstance(truth, SensorView):
            truth = truth.truth
        return cls(truth, np.zeros(3) if lever is None else lever, M)

    def __getattr__(self, name):
        return getattr(self.__dict__["truth"], name)

    def at(self, times) -> dict[str, np.ndarray]:
        from ..core import attitude, earth

        tr = self.truth
        out = dict(tr.at(times))
        idx = np.rint((np.asarray(times) - tr.t[0]) / tr.dt).astype(int)
        C = attitude.euler_to_dcm(out["euler"])
        if np.any(self.lever):
            w = tr.dtheta[np.maximum(idx - 1, 0)] / tr.dt
            out["lla"], out["vel"] = earth.lever_arm_point(out["lla"], out["vel"], C, w,
                                                           self.lever)
        if self.M is not None:
            C = C @ self.M
            out["euler"] = attitude.dcm_to_euler(C)
        out["C"] = C
        out["vel_sensor"] = np.einsum("nji,nj->ni", C, out["vel"])
        return out

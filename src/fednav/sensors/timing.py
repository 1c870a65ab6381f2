"""Measurement timing: when a measurement describes the world and when it is available.

Every :class:`~fednav.sensors.base.MeasurementSeries` carries ``t`` (the instant the
measurement describes, e.g. the SAR image capture) and ``t_avail`` (when the filter can
have it, e.g. the end of image matching).  The processing latency is a sensor property:

* ``Latency.fixed(d)``;
* ``Latency.uniform(lo, hi)`` — drawn per measurement from the run's generator;
* ``Latency.from_list([...])`` — cycled through in order (replaying a recorded log).

With ``sequential`` timing a sensor starts its next measurement when the previous one
ends (a SAR matcher busy with one image at a time): capture times are chained by the
latencies themselves instead of following a fixed period.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import sample_times


@dataclass(frozen=True)
class Latency:
    """Processing latency [s]: ``kind`` fixed / uniform / list."""

    kind: str = "fixed"
    value: float = 0.0
    low: float = 0.0
    high: float = 0.0
    values: tuple[float, ...] = ()

    @classmethod
    def fixed(cls, d: float) -> Latency:
        return cls("fixed", value=float(d))

    @classmethod
    def uniform(cls, low: float, high: float) -> Latency:
        return cls("uniform", low=float(low), high=float(high))

    @classmethod
    def from_list(cls, values) -> Latency:
        return cls("list", values=tuple(float(v) for v in values))

    def __post_init__(self):
        if self.kind not in ("fixed", "uniform", "list"):
            raise ValueError(f"latency kind must be fixed, uniform or list, got '{self.kind}'")
        if self.kind == "fixed" and self.value < 0:
            raise ValueError(f"latency must be >= 0, got {self.value}")
        if self.kind == "uniform" and not 0 <= self.low <= self.high:
            raise ValueError(f"uniform latency needs 0 <= low <= high, got {self.low}, "
                             f"{self.high}")
        if self.kind == "list" and (not self.values or min(self.values) < 0):
            raise ValueError("latency list must be non-empty and >= 0")

    @property
    def is_zero(self) -> bool:
        return self.kind == "fixed" and self.value == 0.0

    def draw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` latencies; only the uniform kind consumes random numbers."""
        if self.kind == "fixed":
            return np.full(n, self.value)
        if self.kind == "uniform":
            return rng.uniform(self.low, self.high, n)
        v = np.asarray(self.values)
        return v[np.arange(n) % len(v)]


def sequential_times(t0: float, t_end: float, latency: Latency, rng: np.random.Generator,
                     grid: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Capture and availability times of a sensor that starts each measurement when the
    previous one ends, from ``t0`` while the capture is before ``t_end``.  Capture times
    are rounded to ``grid`` (the IMU period, where the truth is known)."""
    cap, avail = [], []
    t = t0
    while t <= t_end + 1e-9:
        if grid:
            t = round(t / grid) * grid
        d = float(latency.draw(1, rng)[0])
        if d <= 0:
            raise ValueError("sequential sensor timing needs a positive latency")
        cap.append(t)
        avail.append(t + d)
        t = t + d
    return np.array(cap), np.array(avail)


def measurement_times(t0: float, t_end: float, period: float, latency: Latency,
                      sequential: bool, rng: np.random.Generator,
                      grid: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(capture, available) times: periodic from ``t0 + period`` with the latency added,
    or sequential (chained by the latency)."""
    if sequential:
        return sequential_times(t0 + period, t_end, latency, rng, grid)
    t = sample_times(t_end, period, t0 + period)
    return t, t + (0.0 if latency.is_zero else latency.draw(len(t), rng))

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
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from ..core.config import _Model, simulation_only
from .base import sample_times

#: How the navigator treats the time between a measurement's time of validity and the
#: filter epoch that uses it (:class:`TimingConfig`).
DELAY_COMPENSATIONS = ("interpolate", "none", "curve_fit", "ins_increment", "recompute")


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


#: Why a declared latency is not used on recorded data.
_ARRIVAL = ("fednav process takes each measurement's arrival from its file's t_arrival_s "
            "column")


class TimingConfig(_Model):
    """When a sensor's measurements become available and how the filter treats the delay.

    A measurement describes its time of validity ``t`` and reaches the filter at the
    first epoch at or after its arrival.  Latency (simulation): ``latency_s`` (fixed),
    ``latency_range_s`` [lo, hi] (uniform per measurement) or ``latency_list_s``
    (cycled); none = available when taken.  ``sequential``: the next measurement starts
    when the previous one ends (instead of every ``period_s``).

    ``delay_compensation`` — how the residual bridges validity and epoch of use:
    ``interpolate`` (default: the INS at the IMU sample nearest the time of validity in
    the interval that ends at the epoch, moved by velocity x the remaining lag),
    ``none`` (the INS at the epoch: the delayed value used as if current),
    ``curve_fit`` (polynomial of ``curve_fit_degree`` through the last
    ``curve_fit_points`` values, extrapolated to the epoch of use), ``ins_increment``
    (paper 004 eq. 6: the INS carried back by its own increments since the time of
    validity) or ``recompute`` (re-run the filter from the epoch of validity; the exact,
    costly reference).
    """

    latency_s: float | None = Field(default=None, ge=0.0)
    latency_range_s: tuple[float, float] | None = None
    latency_list_s: list[float] | None = None
    sequential: bool = Field(False, json_schema_extra=simulation_only(_ARRIVAL))
    delay_compensation: Literal[DELAY_COMPENSATIONS] = "interpolate"
    curve_fit_degree: Literal[1, 2, 3] = 2
    curve_fit_points: int = Field(default=4, ge=2)

    @model_validator(mode="after")
    def _one_latency(self):
        given = [x is not None for x in (self.latency_s, self.latency_range_s,
                                         self.latency_list_s)]
        if sum(given) > 1:
            raise ValueError("give only one of latency_s, latency_range_s, latency_list_s")
        if self.latency_range_s is not None and not (
                0.0 <= self.latency_range_s[0] <= self.latency_range_s[1]):
            raise ValueError("latency_range_s must be [low, high] with 0 <= low <= high")
        if self.sequential and not any(given):
            raise ValueError("sequential timing needs a latency")
        if self.curve_fit_points < self.curve_fit_degree + 1:
            raise ValueError("curve_fit_points must be at least curve_fit_degree + 1")
        return self

    def latency(self) -> Latency:
        if self.latency_range_s is not None:
            return Latency.uniform(*self.latency_range_s)
        if self.latency_list_s is not None:
            return Latency.from_list(self.latency_list_s)
        return Latency.fixed(self.latency_s or 0.0)

    @property
    def delayed(self) -> bool:
        """Whether measurements arrive after their time of validity."""
        return not (self.latency().is_zero and not self.sequential)

"""Sensor fault injection: the faults a campaign draws per run.

A fault adds an offset to a sensor's measurements, in the units of the series' ``sigma``
(metres north/east for latitude/longitude components, converted to radians here; the
component's own units otherwise), ``size_sigma`` times that sigma, between ``start`` and
``end`` [s].  Its ``kind`` says how:

* ``step`` — a constant offset (a hard fault);
* ``ramp`` — growing linearly from zero at ``start`` to the size at ``end``, then gone
  (the slow fault the chi-square test catches last);
* ``drift`` — growing at the same rate from ``start`` and never stopping (a barometer's
  weather drift);
* ``burst`` — white noise of 1-sigma ``size_sigma`` sigmas on each measurement inside the
  window (interference; drawn from the fault's own ``seed``);
* ``false_match`` — a position fix jumps to a wrong match ``size_sigma`` horizontal sigmas
  away along ``bearing`` [rad from north toward east] and stays there (consistent wrong
  fixes: SAR image matching);
* ``misidentification`` — an attitude jump of ``size_sigma`` sigmas on each angle, with
  the ``signs`` drawn per run (a star sensor that matched the wrong stars);
* ``spoofing`` — the position pulled along ``bearing`` to ``size_sigma`` horizontal sigmas
  at ``end`` and held there, with the velocity offset that makes the pull consistent (its
  time derivative) while it grows: the ramp a spoofer uses so that the receiver's
  position and velocity agree with each other.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from .base import MeasurementSeries, position_noise_to_llh

#: Every fault kind (module docstring).
KINDS = ("step", "ramp", "drift", "burst", "false_match", "misidentification", "spoofing")
#: Kinds that move a horizontal position: for sensors whose ``z`` holds latitude and
#: longitude (:attr:`~fednav.sensors.spec.SensorSpec.latlon`).
HORIZONTAL = ("false_match", "spoofing")


@dataclass(frozen=True)
class Fault:
    """An additive fault on sensor ``sensor`` (``star``, ``sar``, ``gnss``, ``baro`` ...):
    between ``start`` and ``end`` [s], ``size_sigma`` (one value, or one per component)
    times the series' sigma on ``components`` (None: every component, or the position's
    for the horizontal kinds, the angles for ``misidentification``), shaped by ``kind``
    (module docstring).  ``bearing`` [rad] of the horizontal kinds, ``signs`` (+-1 per
    component) of ``misidentification`` and the ``seed`` of a ``burst`` are drawn per run
    (:meth:`fednav.sim.scenario.FaultConfig.fault`)."""

    sensor: str
    start: float
    end: float
    size_sigma: float | tuple
    kind: Literal["step", "ramp", "drift", "burst", "false_match", "misidentification",
                  "spoofing"] = "step"
    components: tuple[int, ...] | None = None  # None: every component
    bearing: float = 0.0
    signs: tuple[float, ...] | None = None
    seed: int = 0

    def __post_init__(self):
        if self.end <= self.start:
            raise ValueError(f"fault on {self.sensor}: end ({self.end}) must be after start "
                             f"({self.start})")
        if self.kind not in KINDS:
            raise ValueError(f"fault on {self.sensor}: kind must be one of "
                             f"{', '.join(KINDS)}, got '{self.kind}'")

    def active(self, t) -> np.ndarray:
        t = np.asarray(t)
        return (t >= self.start) & (t <= self.end)

    def _shape(self, t: np.ndarray) -> np.ndarray:
        """The fraction of the size at each time (N,)."""
        span = self.end - self.start
        if self.kind in ("ramp", "spoofing", "drift"):
            grown = (t - self.start) / span
            if self.kind == "drift":
                return np.where(t >= self.start, grown, 0.0)
            frac = np.clip(grown, 0.0, 1.0)
            if self.kind == "ramp":
                return np.where(self.active(t), frac, 0.0)
            return np.where(t >= self.start, frac, 0.0)  # (spoofing: held after the pull)
        if self.kind == "false_match":
            return (t >= self.start).astype(float)  # (the wrong match stays)
        return self.active(t).astype(float)

    def offsets(self, series: MeasurementSeries) -> np.ndarray:
        """Additive offset (N, m) in sigma units times sigma (metric for lat/lon)."""
        from .registry import SENSORS

        m = series.z.shape[1]
        spec = SENSORS.get(series.kind)
        comps = self.components
        if comps is None:
            comps = (spec.latlon if self.kind in HORIZONTAL and spec is not None
                     and spec.latlon is not None
                     else spec.angles if self.kind == "misidentification" and spec is not None
                     and spec.angles else range(m))
        size = np.broadcast_to(np.asarray(self.size_sigma, dtype=float), (m,))
        sigma = np.broadcast_to(np.asarray(series.sigma, dtype=float), (m,))
        scale = np.zeros(m)
        for c in comps:
            if not 0 <= c < m:
                raise ValueError(f"fault on {self.sensor}: component {c} outside 0..{m - 1}")
            scale[c] = size[c] * sigma[c]
        if self.kind in HORIZONTAL:
            if spec is None or spec.latlon is None:
                raise ValueError(f"fault on {self.sensor}: a {self.kind} moves a position "
                                 f"fix; the {series.kind} sensor has no latitude/longitude")
            n, e = spec.latlon
            s = np.hypot(scale[n], scale[e]) / np.sqrt(2.0)  # (the horizontal sigma's size)
            scale[n], scale[e] = s * np.cos(self.bearing), s * np.sin(self.bearing)
        elif self.kind == "misidentification" and self.signs is not None:
            scale = scale * np.resize(np.asarray(self.signs, dtype=float), m)
        frac = self._shape(np.asarray(series.t, dtype=float))
        d = frac[:, None] * scale[None, :]
        if self.kind == "burst":
            d = d * np.random.default_rng(self.seed).standard_normal(d.shape)
        if self.kind == "spoofing":  # the velocity that the pull's position implies
            names = [c.name for c in spec.columns]
            if "vE_mps" in names and "vN_mps" in names:
                rate = ((series.t >= self.start) & (series.t <= self.end)) / (
                    self.end - self.start)
                n, e = spec.latlon
                d[:, names.index("vN_mps")] += rate * scale[n]
                d[:, names.index("vE_mps")] += rate * scale[e]
        return d


def inject_faults(series: MeasurementSeries, faults: list[Fault]) -> MeasurementSeries:
    """A copy of ``series`` with every fault on its sensor added."""
    mine = [f for f in faults if f.sensor == series.kind]
    if not mine:
        return series
    d = sum(f.offsets(series) for f in mine)
    z = series.z.copy()
    from .registry import spec

    sp = spec(series.kind)
    ll = sp.latlon  # components holding latitude and longitude: faults are metres there
    if ll is not None:
        h = z[:, sp.height] if sp.height is not None else np.zeros(len(z))
        pos = position_noise_to_llh(np.column_stack([z[:, ll[0]], z[:, ll[1]], h]),
                                    np.column_stack([d[:, ll[0]], d[:, ll[1]],
                                                     np.zeros(len(z))]))
        z[:, ll[0]], z[:, ll[1]] = pos[:, 0], pos[:, 1]
        d[:, [ll[0], ll[1]]] = 0.0
    return replace(series, z=z + d, t_avail=series.t_avail.copy())

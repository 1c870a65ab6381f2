"""Sensor fault injection: hard (step) and soft (ramp) additive faults.

A fault adds ``size_sigma * sigma_i`` to component ``i`` of a sensor's measurements
between ``start`` and ``end`` [s] (``step``), or grows linearly from zero at ``start`` to
that value at ``end`` (``ramp``).  Offsets are in the units of the series' ``sigma``:
metres north/east for latitude/longitude components (converted to radians here),
otherwise the component's own units.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from .base import MeasurementSeries, position_noise_to_llh


@dataclass(frozen=True)
class Fault:
    """An additive fault on sensor ``sensor`` (``star``, ``sar``, ``gnss``, ``baro`` ...)."""

    sensor: str
    start: float
    end: float
    size_sigma: float | tuple
    kind: Literal["step", "ramp"] = "step"
    components: tuple[int, ...] | None = None  # None: every component

    def __post_init__(self):
        if self.end <= self.start:
            raise ValueError(f"fault on {self.sensor}: end ({self.end}) must be after start "
                             f"({self.start})")
        if self.kind not in ("step", "ramp"):
            raise ValueError(f"fault on {self.sensor}: kind must be 'step' or 'ramp', "
                             f"got '{self.kind}'")

    def active(self, t) -> np.ndarray:
        t = np.asarray(t)
        return (t >= self.start) & (t <= self.end)

    def offsets(self, series: MeasurementSeries) -> np.ndarray:
        """Additive offset (N, m) in sigma units times sigma (metric for lat/lon)."""
        m = series.z.shape[1]
        comps = range(m) if self.components is None else self.components
        size = np.broadcast_to(np.asarray(self.size_sigma, dtype=float), (m,))
        scale = np.zeros(m)
        for c in comps:
            if not 0 <= c < m:
                raise ValueError(f"fault on {self.sensor}: component {c} outside 0..{m - 1}")
            scale[c] = size[c] * series.sigma[c]
        frac = self.active(series.t).astype(float)
        if self.kind == "ramp":
            frac *= np.clip((series.t - self.start) / (self.end - self.start), 0.0, 1.0)
        return frac[:, None] * scale[None, :]


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

"""Protection levels in the stream: the navigator and its bank of sub-navigators, fed
sample by sample, measurement by measurement.

:class:`IntegrityNavigator` holds the all-sensor :class:`~fednav.navigator.Navigator`
and one more per tested aiding sensor, each without that sensor (the bank a processed
recording runs, :mod:`fednav.process.integrity`, here run as the data come).  Every IMU
sample goes to all of them, every measurement to all but the one that leaves its sensor
out; :meth:`IntegrityNavigator.solution` is the all-sensor :class:`Snapshot` with its
``levels``: the solution-separation tests and the protection levels of
:func:`fednav.navigator.integrity.separation` from the bank's snapshots at the same
time, and the alert state (a level above its alert limit, or a test that tripped).
Once a test has tripped the alert stays up — the stream detects and alerts; excluding
the faulty sensor needs its candidates' own banks, which a processed recording runs
(``fednav process`` with ``integrity:``).  Cost: (tested sensors + 1) navigators.
"""

from __future__ import annotations

import numpy as np

from .integrity import IntegrityConfig, separation, separations, tested_sensors
from .navigator import Navigator, Snapshot


class IntegrityNavigator:
    """A :class:`~fednav.navigator.Navigator` with its bank (module docstring): the same
    constructor arguments; ``add_imu``, ``add_measurement``, ``add_measurements`` and
    ``add_series`` as the navigator's; :meth:`solution` with ``levels``.  ``full`` is the
    all-sensor navigator (its ``result()`` the run's), ``bank`` the sub-navigators by the
    sensor each leaves out."""

    def __init__(self, system, initial, imu_period: float, **kwargs):
        self.config = system.integrity or IntegrityConfig()
        self.sensors = tested_sensors(system.aiding)
        if len(self.sensors) < 2:
            raise ValueError(f"integrity: solution separation needs two or more aiding "
                             f"sensors (this system has {', '.join(self.sensors) or 'none'})")
        self.full = Navigator(system, initial, imu_period, **kwargs)
        self.bank = {k: Navigator(system.model_copy(update={"aiding": [
            a for a in system.aiding if a != k]}), initial, imu_period, **kwargs)
            for k in self.sensors}
        self._tripped: float | None = None

    def _all(self):
        return [self.full, *self.bank.values()]

    def add_imu(self, *args, **kwargs) -> None:
        """IMU samples for every navigator (:meth:`Navigator.add_imu`)."""
        for nav in self._all():
            nav.add_imu(*args, **kwargs)

    def add_measurement(self, sensor: str, *args, **kwargs) -> None:
        """One measurement for every navigator but the one without ``sensor``."""
        for k, nav in (("", self.full), *self.bank.items()):
            if k != sensor:
                nav.add_measurement(sensor, *args, **kwargs)

    def add_measurements(self, sensor: str, *args, **kwargs) -> None:
        """Measurements for every navigator but the one without ``sensor``."""
        for k, nav in (("", self.full), *self.bank.items()):
            if k != sensor:
                nav.add_measurements(sensor, *args, **kwargs)

    def add_series(self, series) -> None:
        """A sensor's series for every navigator but the one without it."""
        for k, nav in (("", self.full), *self.bank.items()):
            if k != series.name:
                nav.add_series(series)

    def solution(self) -> Snapshot:
        """The all-sensor :meth:`Navigator.solution` with ``levels``: ``hpl_m``,
        ``vpl_m``, ``heading_pl_deg``, ``test_ratio`` (the largest separation over its
        threshold: above 1 a test trips), ``candidate`` (the sensor whose leaving out
        separates most: the first to try excluding, not an identification — a GNSS
        height ramp separates most the solution without the barometer, which follows
        it), ``alert`` (a level above its alert limit, or a test tripped now
        or earlier) and ``tripped_s`` (when a test first tripped, else None)."""
        s0 = self.full.solution()
        subs = {k: nav.solution() for k, nav in self.bank.items()}
        names = list(subs)
        d = np.stack([separations(np.asarray(subs[k].lla)[None], subs[k].euler[2:3],
                                  np.asarray(s0.lla)[None], s0.euler[2:3]) for k in names])
        sig0 = np.concatenate([s0.sigma[6:9], s0.sigma[2:3]])[None]
        sk = np.stack([np.concatenate([subs[k].sigma[6:9], subs[k].sigma[2:3]])[None]
                       for k in names])
        r = separation(np.array([s0.t]), d, sig0, sk, names, self.config)
        ratio = float(r.test_ratio[0])
        if ratio > 1.0 and self._tripped is None:
            self._tripped = float(s0.t)
        s0.levels = {"hpl_m": float(r.hpl[0]), "vpl_m": float(r.vpl[0]),
                     "heading_pl_deg": float(np.degrees(r.heading_pl[0])),
                     "test_ratio": ratio, "candidate": r.candidates(0)[0],
                     "alert": bool(r.alert[0] or self._tripped is not None),
                     "tripped_s": self._tripped}
        return s0

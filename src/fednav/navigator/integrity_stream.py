"""Protection levels in the stream: the navigator and its bank of sub-navigators, fed
sample by sample, measurement by measurement.

:class:`IntegrityNavigator` holds the all-sensor :class:`~fednav.navigator.Navigator`
and one more per tested aiding sensor, each without that sensor (the bank a processed
recording runs, :mod:`fednav.process.integrity`, here run as the data come), and — with
three tested sensors or more — one per pair of them, each without both: the banks of the
candidates for exclusion.  Every IMU sample goes to all of them, every measurement to
those that keep its sensor.  :meth:`IntegrityNavigator.solution` is the output
:class:`Snapshot` with its ``levels``: the solution-separation tests and the protection
levels of :func:`fednav.navigator.integrity.separation` from the bank's snapshots at
the same time, and the alert state.

After a test trips, the stream excludes a sensor (fault detection and exclusion) at
the first snapshot where exactly one sub-solution passes its own tests — against the
pair navigators that leave out one more sensor: the one without the faulty sensor is
then the only one whose bank agrees with it, while each other still holds the fault
against a member without it.  From then on the output is that sub-solution, with its
own bank's levels, and its own tests keep watch (one tripping alerts again; nothing is
excluded twice).  While two or more pass (the fault still too small to tell them
apart) the alert stays up and nothing is excluded.  The batch (``fednav process`` with
``integrity:``) takes the first candidate whose tests pass from the detection to the
end of the recording; the stream cannot see ahead.
With two tested sensors nothing is left to tell which one is faulty: the stream detects
and alerts.  Cost: 1 + n navigators, and n (n - 1) / 2 more with n >= 3 tested sensors.
"""

from __future__ import annotations

import warnings
from itertools import combinations

import numpy as np

from .integrity import IntegrityConfig, separation, separations, tested_sensors
from .navigator import HealthWarning, Navigator, Snapshot


class IntegrityNavigator:
    """A :class:`~fednav.navigator.Navigator` with its banks (module docstring): the
    same constructor arguments; ``add_imu``, ``add_measurement``, ``add_measurements`` and
    ``add_series`` as the navigator's; :meth:`solution` with ``levels``.  ``full`` is the
    all-sensor navigator (its ``result()`` the run's), ``bank`` the sub-navigators by the
    sensor each leaves out, ``pairs`` those by the two sensors each leaves out;
    ``excluded`` the sensor excluded (None: none yet)."""

    def __init__(self, system, initial, imu_period: float, **kwargs):
        self.config = system.integrity or IntegrityConfig()
        self.sensors = tested_sensors(system.aiding)
        if len(self.sensors) < 2:
            raise ValueError(f"integrity: solution separation needs two or more aiding "
                             f"sensors (this system has {', '.join(self.sensors) or 'none'})")

        def without(*out):
            return Navigator(system.model_copy(update={"aiding": [
                a for a in system.aiding if a not in out]}), initial, imu_period, **kwargs)

        self.full = Navigator(system, initial, imu_period, **kwargs)
        self.bank = {k: without(k) for k in self.sensors}
        self.pairs = ({} if len(self.sensors) < 3 else
                      {frozenset(p): without(*p) for p in combinations(self.sensors, 2)})
        self.excluded: str | None = None
        self._tripped: float | None = None
        self._excluded_s: float | None = None
        self._own_tripped: float | None = None

    def _fed(self):
        """(the sensors each navigator leaves out, the navigator)."""
        return [(frozenset(), self.full), *((frozenset((k,)), n) for k, n in
                                            self.bank.items()), *self.pairs.items()]

    def add_imu(self, *args, **kwargs) -> None:
        """IMU samples for every navigator (:meth:`Navigator.add_imu`)."""
        for _, nav in self._fed():
            nav.add_imu(*args, **kwargs)

    def add_measurement(self, sensor: str, *args, **kwargs) -> None:
        """One measurement for every navigator that keeps ``sensor``."""
        for out, nav in self._fed():
            if sensor not in out:
                nav.add_measurement(sensor, *args, **kwargs)

    def add_measurements(self, sensor: str, *args, **kwargs) -> None:
        """Measurements for every navigator that keeps ``sensor``."""
        for out, nav in self._fed():
            if sensor not in out:
                nav.add_measurements(sensor, *args, **kwargs)

    def add_series(self, series) -> None:
        """A sensor's series for every navigator that keeps it."""
        for out, nav in self._fed():
            if series.name not in out:
                nav.add_series(series)

    def _test(self, s0: Snapshot, subs: dict[str, Snapshot]):
        """The separation tests and levels of ``s0`` against the sub-solutions ``subs``
        (:func:`~fednav.navigator.integrity.separation`, one row)."""
        names = list(subs)
        d = np.stack([separations(np.asarray(subs[k].lla)[None], subs[k].euler[2:3],
                                  np.asarray(s0.lla)[None], s0.euler[2:3]) for k in names])
        sig0 = np.concatenate([s0.sigma[6:9], s0.sigma[2:3]])[None]
        sk = np.stack([np.concatenate([subs[k].sigma[6:9], subs[k].sigma[2:3]])[None]
                       for k in names])
        return separation(np.array([s0.t]), d, sig0, sk, names, self.config)

    def _own(self, k: str, pairs: dict) -> dict[str, Snapshot]:
        """The snapshots of ``k``'s own bank among the pair navigators' snapshots
        ``pairs``: those without ``k`` and one more tested sensor."""
        return {j: pairs[frozenset((k, j))] for j in self.sensors if j != k}

    def solution(self) -> Snapshot:
        """The output :meth:`Navigator.solution` — the all-sensor one, or after an
        exclusion the one without the excluded sensor — with ``levels``: ``hpl_m``,
        ``vpl_m``, ``heading_pl_deg``, ``test_ratio`` (the largest separation over its
        threshold: above 1 a test trips), ``candidate`` (the sensor whose leaving out
        separates most: the first to try excluding), ``alert`` (a level above its alert
        limit, or a test tripped and no exclusion passed; after an exclusion, the
        excluded solution's own), ``tripped_s`` (when a test first tripped, else None),
        ``excluded`` (the sensor excluded, else None) and ``excluded_s`` (when; said
        once through Python's ``warnings`` module, a
        :class:`~fednav.navigator.navigator.HealthWarning`)."""
        s0 = self.full.solution()
        subs = {k: nav.solution() for k, nav in self.bank.items()}
        r = self._test(s0, subs)
        ratio = float(r.test_ratio[0])
        if ratio > 1.0 and self._tripped is None:
            self._tripped = float(s0.t)
        pairs = ({} if self._tripped is None else  # (each pair's snapshot once)
                 {p: nav.solution() for p, nav in self.pairs.items()})
        if self._tripped is not None and self.excluded is None and self.pairs:
            passing = [k for k in self.sensors if float(
                self._test(subs[k], self._own(k, pairs)).test_ratio[0]) <= 1.0]
            if len(passing) == 1:  # (one sub-solution consistent with its own bank)
                self.excluded, self._excluded_s = passing[0], float(s0.t)
                warnings.warn(f"integrity: '{self.excluded}' excluded at {s0.t:.3f} s (a "
                              f"solution separation test tripped at {self._tripped:.3f} s; "
                              f"the solution without it is the only one its own tests "
                              f"pass): from now on the output is the one without it",
                              HealthWarning, stacklevel=2)
        out, alert = s0, bool(r.alert[0] or self._tripped is not None)
        if self.excluded is not None:
            out = subs[self.excluded]
            r = self._test(out, self._own(self.excluded, pairs))
            ratio = float(r.test_ratio[0])
            if ratio > 1.0 and self._own_tripped is None:
                self._own_tripped = float(out.t)
            alert = bool(r.alert[0] or self._own_tripped is not None)
        out.levels = {"hpl_m": float(r.hpl[0]), "vpl_m": float(r.vpl[0]),
                      "heading_pl_deg": float(np.degrees(r.heading_pl[0])),
                      "test_ratio": ratio, "candidate": r.candidates(0)[0],
                      "alert": alert, "tripped_s": self._tripped,
                      "excluded": self.excluded, "excluded_s": self._excluded_s}
        return out

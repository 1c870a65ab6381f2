"""Sensor simulation: each sensor turns the truth into time-stamped measurements.

A sensor is a small frozen dataclass with a ``simulate(truth, rng)`` method returning a
:class:`~fednav.sensors.base.MeasurementSeries`; its filter-side counterpart lives in
:mod:`fednav.sensors.models`.  All randomness comes from the ``numpy.random.Generator``
passed in.
"""

from .airdata import AirData
from .baro import Barometer
from .base import MeasurementSeries, sample_times
from .faults import Fault, inject_faults
from .gnss import Gnss
from .imu import ImuErrors, ImuErrorState, corrupt_imu
from .sar import SarMatcher, SarVelocity
from .star import StarSensor
from .timing import Latency, measurement_times, sequential_times

__all__ = ["AirData", "Barometer", "Fault", "Gnss", "ImuErrorState", "ImuErrors", "Latency",
           "MeasurementSeries", "SarMatcher", "SarVelocity", "StarSensor", "corrupt_imu",
           "inject_faults", "measurement_times", "sample_times", "sequential_times"]

"""Sensors: each aiding sensor in one module — its section of the system description,
its simulator (truth -> time-stamped measurements, every random number from the
``numpy.random.Generator`` passed in), its filter-side measurement model and its file
columns — and the registry that lists them (:mod:`fednav.sensors.registry`); plus the
IMU error model, measurement timing and delays, and fault injection."""

from .airdata import AirData, AirDataConfig, WindConstraint
from .baro import BaroConfig, BaroHeight, Barometer
from .base import MeasurementSeries, sample_times
from .faults import Fault, inject_faults
from .gnss import Gnss, GnssConfig, GnssPosVel
from .imu import ImuConfig, ImuErrors, ImuErrorState, corrupt_imu
from .measurement import NavSnapshot, StackedModel, euler_error_nb
from .sar import SarConfig, SarFix, SarMatcher
from .sarvel import SarVelocity, SarVelocityConfig, SarVelocityEN
from .spec import Column, SensorConfig, SensorSpec
from .star import StarAttitude, StarConfig, StarSensor
from .timing import Latency, TimingConfig, measurement_times, sequential_times
from .velocity import VelocityConfig, VelocityENU, VelocitySensor

__all__ = ["AirData", "AirDataConfig", "BaroConfig", "BaroHeight", "Barometer", "Column",
           "Fault", "Gnss", "GnssConfig", "GnssPosVel", "ImuConfig", "ImuErrorState",
           "ImuErrors", "Latency", "MeasurementSeries", "NavSnapshot", "SarConfig", "SarFix",
           "SarMatcher", "SarVelocity", "SarVelocityConfig", "SarVelocityEN", "SensorConfig",
           "SensorSpec", "StackedModel", "StarAttitude", "StarConfig", "StarSensor",
           "TimingConfig", "VelocityConfig", "VelocityENU", "VelocitySensor", "WindConstraint",
           "corrupt_imu", "inject_faults", "measurement_times", "sample_times",
           "euler_error_nb", "sequential_times"]

#: One model of each aiding sensor with default settings (no lever arm), by name —
#: fednav 0.1's ``fednav.measurements.MODELS``; build a configured one with
#: ``system.sensors[name].measurement_model()``.
MODELS = {m.kind: m for m in (StarAttitude(), SarFix(), BaroHeight(), GnssPosVel(),
                              SarVelocityEN())}

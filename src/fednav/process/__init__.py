"""Recorded data: ``fednav process`` (loosely coupled INS/GNSS and velocity aiding,
smoother) and ``fednav tune`` (noise figures from the data)."""

from ..sensors.imu import ImuConfig as ImuNoiseConfig  # noqa: F401  (0.1's name)
from .run import (
    InnovationRecord,
    ProcessConfig,
    ProcessResult,
    Solution,
    adjust_sensors,
    check_units,
    errors_against,
    gnss_course,
    gnss_z,
    imu_figures,
    prepare,
    process,
    rmse,
)

__all__ = ["InnovationRecord", "ProcessConfig", "ProcessResult", "Solution",
           "adjust_sensors", "check_units", "errors_against", "gnss_course", "gnss_z",
           "imu_figures", "prepare", "process", "rmse"]

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
    fix_course,
    fix_z,
    imu_figures,
    prepare,
    process,
    rmse,
)

gnss_course, gnss_z = fix_course, fix_z  # (0.1's names)

__all__ = ["InnovationRecord", "ProcessConfig", "ProcessResult", "Solution",
           "adjust_sensors", "check_units", "errors_against", "fix_course", "fix_z",
           "gnss_course", "gnss_z", "imu_figures", "prepare", "process", "rmse"]

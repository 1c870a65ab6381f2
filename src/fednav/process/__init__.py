"""Recorded data: ``fednav process`` (loosely coupled INS/GNSS and velocity aiding,
smoother) and ``fednav tune`` (noise figures from the data)."""

from .run import (
    InnovationRecord,
    ProcessConfig,
    ProcessResult,
    Solution,
    errors_against,
    process,
    rmse,
)

__all__ = ["InnovationRecord", "ProcessConfig", "ProcessResult", "Solution",
           "errors_against", "process", "rmse"]

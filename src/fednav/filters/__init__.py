"""Estimators behind one interface (:class:`~fednav.filters.base.Filter`) and the
federated filter that combines them."""

from .adaptive import RobustAdaptiveUKF, SageHusaEKF, igg3_weights
from .base import Filter, FilterError, FunctionModel, FunctionProcess, Innovation, LinearModel
from .constrained import ConstrainedEKF, ConstrainedUKF, project
from .federated import FederatedFilter, sharing_factors
from .kf import KalmanFilter
from .particle import ParticleFilter, systematic_resample
from .quadrature import AdaptiveSparseGridFilter, SparseGridFilter
from .registry import FILTERS, make_filter
from .ukf import SimplifiedUKF, UnscentedKalmanFilter

#: The filter registry (:data:`fednav.filters.registry.FILTERS`; this name for 0.1's users).
REGISTRY = FILTERS


__all__ = ["AdaptiveSparseGridFilter", "ConstrainedEKF", "ConstrainedUKF", "FILTERS",
           "FederatedFilter",
           "Filter", "FilterError", "FunctionModel", "FunctionProcess", "Innovation",
           "KalmanFilter", "LinearModel", "ParticleFilter", "REGISTRY", "RobustAdaptiveUKF",
           "SageHusaEKF", "SimplifiedUKF", "SparseGridFilter", "UnscentedKalmanFilter",
           "igg3_weights", "make_filter", "project", "sharing_factors", "systematic_resample"]

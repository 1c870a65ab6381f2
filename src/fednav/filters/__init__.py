"""Estimators behind one interface (:class:`~fednav.filters.base.Filter`) and the
federated filter that combines them."""

from .adaptive import RobustAdaptiveUKF, SageHusaEKF, igg3_weights
from .base import Filter, FilterError, FunctionModel, FunctionProcess, Innovation, LinearModel
from .constrained import ConstrainedEKF, ConstrainedUKF, project
from .federated import FederatedFilter, sharing_factors
from .kf import KalmanFilter
from .particle import ParticleFilter, systematic_resample
from .quadrature import AdaptiveSparseGridFilter, SparseGridFilter
from .ukf import SimplifiedUKF, UnscentedKalmanFilter

#: Names accepted in scenario files.
REGISTRY = {"kf": KalmanFilter, "ekf": KalmanFilter, "ukf": UnscentedKalmanFilter,
            "sukf": SimplifiedUKF, "cukf": ConstrainedUKF, "cekf": ConstrainedEKF,
            "aekf": SageHusaEKF, "raukf": RobustAdaptiveUKF, "pf": ParticleFilter,
            "sghqf": SparseGridFilter, "aasghqf": AdaptiveSparseGridFilter}


def make_filter(name: str, x0, P0, **options) -> Filter:
    """Build a filter by its registry name (``kf``, ``ekf``, ``ukf``, ``sukf``, ``pf`` ...)."""
    try:
        cls = REGISTRY[name.lower()]
    except KeyError:
        raise ValueError(
            f"unknown filter '{name}'; choose one of {', '.join(sorted(REGISTRY))}"
        ) from None
    return cls(x0, P0, name=name.lower(), **options)


__all__ = ["AdaptiveSparseGridFilter", "ConstrainedEKF", "ConstrainedUKF", "FederatedFilter",
           "Filter", "FilterError", "FunctionModel", "FunctionProcess", "Innovation",
           "KalmanFilter", "LinearModel", "ParticleFilter", "REGISTRY", "RobustAdaptiveUKF",
           "SageHusaEKF", "SimplifiedUKF", "SparseGridFilter", "UnscentedKalmanFilter",
           "igg3_weights", "make_filter", "project", "sharing_factors", "systematic_resample"]

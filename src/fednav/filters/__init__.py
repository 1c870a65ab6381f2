"""Estimators behind one interface (:class:`~fednav.filters.base.Filter`) and the
federated filter that combines them."""

from .base import Filter, FilterError, FunctionModel, FunctionProcess, Innovation, LinearModel
from .federated import FederatedFilter, sharing_factors
from .kf import KalmanFilter
from .ukf import SimplifiedUKF, UnscentedKalmanFilter

#: Names accepted in scenario files.
REGISTRY = {"kf": KalmanFilter, "ekf": KalmanFilter, "ukf": UnscentedKalmanFilter,
            "sukf": SimplifiedUKF}


def make_filter(name: str, x0, P0, **options) -> Filter:
    """Build a filter by its registry name (``kf``, ``ekf``, ``ukf``, ``sukf``)."""
    try:
        cls = REGISTRY[name.lower()]
    except KeyError:
        raise ValueError(
            f"unknown filter '{name}'; choose one of {', '.join(sorted(REGISTRY))}"
        ) from None
    return cls(x0, P0, name=name.lower(), **options)


__all__ = ["FederatedFilter", "Filter", "FilterError", "FunctionModel", "FunctionProcess",
           "Innovation", "KalmanFilter", "LinearModel", "REGISTRY", "SimplifiedUKF",
           "UnscentedKalmanFilter", "make_filter", "sharing_factors"]

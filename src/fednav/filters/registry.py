"""The filter registry: every estimator a system description can name, by name.

Adding a filter is one module (a :class:`~fednav.filters.base.Filter` subclass whose
``__init__(x0, P0, name, ...)`` takes its settings as keywords) and one line in
:data:`FILTERS`; :func:`register` adds one at run time.  The system description's
``filter.type`` and ``filter.locals`` are validated against this table.
"""

from __future__ import annotations

import inspect

from .adaptive import RobustAdaptiveUKF, SageHusaEKF
from .base import Filter
from .constrained import ConstrainedEKF, ConstrainedUKF
from .kf import KalmanFilter
from .particle import ParticleFilter
from .quadrature import AdaptiveSparseGridFilter, SparseGridFilter
from .square_root import FACTORED
from .ukf import SimplifiedUKF, UnscentedKalmanFilter

#: name -> filter class.
FILTERS: dict[str, type[Filter]] = {
    "kf": KalmanFilter, "ekf": KalmanFilter, "ukf": UnscentedKalmanFilter,
    "sukf": SimplifiedUKF, "cukf": ConstrainedUKF, "cekf": ConstrainedEKF,
    "aekf": SageHusaEKF, "raukf": RobustAdaptiveUKF, "pf": ParticleFilter,
    "sghqf": SparseGridFilter, "aasghqf": AdaptiveSparseGridFilter,
}

#: The covariance forms a filter can take: the covariance itself or its Cholesky factor.
FORMS = ("standard", "square_root")


def register(name: str, cls: type[Filter]) -> None:
    """Add a filter class under a new ``name``."""
    if name in FILTERS:
        raise ValueError(f"a filter called '{name}' is registered already")
    FILTERS[name] = cls


def unregister(name: str) -> None:
    """Remove a filter added by :func:`register`."""
    FILTERS.pop(name, None)


def names() -> list[str]:
    """Registered names, sorted."""
    return sorted(FILTERS)


def filter_class(name: str, form: str = "standard") -> type[Filter]:
    """The class registered as ``name`` (case-insensitive) in ``form`` (``standard`` or
    ``square_root``, :data:`FORMS`); a one-line error naming the registered ones."""
    try:
        cls = FILTERS[name.lower()]
    except KeyError:
        raise ValueError(f"unknown filter '{name}'; registered: {', '.join(names())}"
                         ) from None
    if form == "standard":
        return cls
    if form != "square_root":
        raise ValueError(f"unknown filter form '{form}'; choose {' or '.join(FORMS)}")
    sr = FACTORED.get(cls)
    if sr is None:
        raise ValueError(f"filter '{name}' has no square-root form (the Gaussian filters "
                         f"have one: {', '.join(square_root_names())})")
    return sr


def square_root_names() -> list[str]:
    """Registered names with a square-root form, sorted."""
    return sorted(k for k, c in FILTERS.items() if c in FACTORED)


def make_filter(name: str, x0, P0, common: dict | None = None, form: str = "standard",
                **options) -> Filter:
    """A filter by its registered name, from the state ``x0`` and covariance ``P0``.

    ``options`` go to the filter's constructor as they are (an option it does not take is
    an error); ``common`` are settings a system gives every filter (the sigma-point
    ``alpha``, ``beta``, ``kappa``, the sparse grid's ``level``, the particle filter's
    ``n_particles``, ``resample_threshold``, ``roughening``, ``progressive`` and ``rng``):
    each goes to the filters whose constructor takes it (a filter registered later whose
    constructor takes one of these names receives it).  ``form``: ``standard`` (the covariance) or
    ``square_root`` (its Cholesky factor, :mod:`fednav.filters.square_root`)."""
    cls = filter_class(name, form)
    if common:
        takes = inspect.signature(cls.__init__).parameters
        options = {**{k: v for k, v in common.items() if k in takes}, **options}
    flt = cls(x0, P0, name=name.lower(), **options)
    flt.kind = name.lower()
    return flt

"""fednav — multi-sensor integrated navigation: SINS aided by CNS, SAR, GNSS and baro.

Frames and units are fixed in ``docs/conventions.md``: ENU navigation frame, body
right-forward-up, Euler angles ``[pitch, roll, heading]`` with heading from north
positive toward east, SI units and radians inside the library.
"""

__version__ = "0.1.0"

from . import _kernel_cache

_kernel_cache.install(__version__)  # (before any numba kernel is compiled or loaded)

from . import _compat  # noqa: E402

_compat.install()

from .navigator.system import System, load_system  # noqa: E402

__all__ = ["InitialState", "NavResult", "Navigator", "Snapshot", "Solution", "System",
           "load_system"]


def __getattr__(name: str):
    """The navigator's names, imported on first use (``fednav --help`` stays quick)."""
    from . import navigator

    if name in navigator.__all__:
        return getattr(navigator, name)
    raise AttributeError(f"module 'fednav' has no attribute '{name}'")

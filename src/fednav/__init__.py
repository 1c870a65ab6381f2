"""fednav — multi-sensor integrated navigation: SINS aided by CNS, SAR, GNSS and baro.

Frames and units are fixed in ``docs/conventions.md``: ENU navigation frame, body
right-forward-up, Euler angles ``[pitch, roll, heading]`` with heading from north
positive toward east, SI units and radians inside the library.
"""

__version__ = "0.1.0"

from . import _compat

_compat.install()

from .navigator.system import System, load_system  # noqa: E402

__all__ = ["System", "load_system"]

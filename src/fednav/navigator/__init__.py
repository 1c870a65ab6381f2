"""The navigator: one closed loop — mechanize, predict, update, fuse, feed back — behind
every system fednav runs, from its description (:mod:`fednav.navigator.system`)."""

from .system import FilterConfig, System, load_system

__all__ = ["FilterConfig", "InitialState", "NavResult", "Navigator", "Snapshot", "Solution",
           "System", "load_system"]


def __getattr__(name: str):
    """The navigator and its results, imported on first use."""
    if name in ("InitialState", "NavResult", "Navigator", "Snapshot"):
        from . import navigator

        return getattr(navigator, name)
    if name == "Solution":
        from .solution import Solution

        return Solution
    raise AttributeError(f"module 'fednav.navigator' has no attribute '{name}'")

"""The navigator: one closed loop — mechanize, predict, update, fuse, feed back — behind
every system fednav runs, from its description (:mod:`fednav.navigator.system`)."""

from .system import FilterConfig, System, load_system

__all__ = ["FilterConfig", "System", "load_system"]

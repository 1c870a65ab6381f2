"""The module names of fednav 0.1 (before the layered packages), kept for one release.

``import fednav.earth`` (or ``from fednav.simulate import run_mode``) still works: a
finder on ``sys.meta_path`` answers each old name with the module at its new place,
registered under both names, and warns once with the new name (``FutureWarning``, so
users see it).  The list below is also the changelog's table of moved modules.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: Old module -> the module that holds its names now.
MOVED = {
    "fednav.units": "fednav.core.units", "fednav.earth": "fednav.core.earth",
    "fednav.attitude": "fednav.core.attitude", "fednav.kernels": "fednav.core.kernels",
    "fednav.errors": "fednav.core.errors", "fednav.atomic": "fednav.core.atomic",
    "fednav.strapdown": "fednav.ins.strapdown", "fednav.error_model": "fednav.ins.error_model",
    "fednav.alignment": "fednav.ins.alignment",
    "fednav.observability": "fednav.ins.observability",
    "fednav.total_state": "fednav.ins.total_state",
    "fednav.smoother": "fednav.filters.smoother",
    "fednav.measurements": "fednav.sensors", "fednav.delays": "fednav.sensors.delays",
    "fednav.trajectory": "fednav.sim.trajectory", "fednav.wind": "fednav.sim.wind",
    "fednav.simulate": "fednav.sim.runs", "fednav.dataset": "fednav.sim.dataset",
    "fednav.config": "fednav.sim.scenario",
    "fednav.montecarlo": "fednav.campaign.montecarlo",
    "fednav.evaluation": "fednav.campaign.evaluation",
    "fednav.report": "fednav.campaign.report",
    "fednav.html_report": "fednav.campaign.html_report",
    "fednav.process_output": "fednav.process.output", "fednav.tuning": "fednav.process.tuning",
}


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, name, path=None, target=None):
        if name in MOVED:
            return importlib.util.spec_from_loader(name, self)
        return None

    def create_module(self, spec):
        new = MOVED[spec.name]
        warnings.warn(f"{spec.name} is now {new}; the old name goes in fednav 0.3",
                      FutureWarning, stacklevel=2)
        module = importlib.import_module(new)
        sys.modules[spec.name] = module
        return module

    def exec_module(self, module):
        pass


def install() -> None:
    if not any(isinstance(f, _Alias) for f in sys.meta_path):
        sys.meta_path.append(_Alias())

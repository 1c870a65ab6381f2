"""Paper scenarios: YAML files plus the code that reproduces each paper's tables."""

import importlib
from pathlib import Path

SCENARIO_DIR = Path(__file__).parent
#: Paper number -> the names the command line accepts for it (each paper module's
#: ``ALIASES``), here so that finding one paper imports only that paper's module.
ALIASES = {"000": ("000", "airship"), "001": ("001", "launch-frame"),
           "002": ("002", "cruise-missile"), "003": ("003", "federated-ukf"),
           "004": ("004", "sar-delay")}


def paper_module(name: str):
    """The module of the paper called ``name`` (number or alias), or None."""
    for number, aliases in ALIASES.items():
        if name.lower() in aliases:
            return importlib.import_module(f"{__name__}.paper{number}")
    return None


def papers() -> tuple:
    """The paper modules, in order (imported on first use: they load numba kernels)."""
    return tuple(paper_module(number) for number in ALIASES)


def scenario_path(name: str) -> Path:
    """Path of a packaged scenario file (``paper002`` -> ``paper002.yaml``)."""
    return SCENARIO_DIR / f"{name}.yaml"

"""Paper scenarios: YAML files plus the code that reproduces each paper's tables."""

from pathlib import Path

SCENARIO_DIR = Path(__file__).parent


def papers() -> tuple:
    """The paper modules, in order (imported on first use: they load numba kernels)."""
    from . import paper000, paper001, paper002, paper003, paper004

    return (paper000, paper001, paper002, paper003, paper004)


def scenario_path(name: str) -> Path:
    """Path of a packaged scenario file (``paper002`` -> ``paper002.yaml``)."""
    return SCENARIO_DIR / f"{name}.yaml"

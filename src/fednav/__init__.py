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

#: The Python API's main names (``docs/api.md``), by the module that defines each, each
#: imported on first use (``import fednav`` and ``fednav --version`` stay quick).
_LAZY = {
    # the system description
    "System": "fednav.navigator.system",
    "load_system": "fednav.navigator.system",
    # the navigator and its results
    "Navigator": "fednav.navigator.navigator",
    "NavResult": "fednav.navigator.navigator",
    "InitialState": "fednav.navigator.navigator",
    "Snapshot": "fednav.navigator.navigator",
    "Solution": "fednav.navigator.solution",
    # reading recorded data
    "read_imu_csv": "fednav.io.csvdata",
    "read_gnss_csv": "fednav.io.csvdata",
    "read_reference_csv": "fednav.io.csvdata",
    "read_sensor_csv": "fednav.io.sensorfile",
    # processing it (``process_data`` is :func:`fednav.process.process`, what ``fednav
    # process`` runs: ``fednav.process`` is the subpackage)
    "process_data": "fednav.process.run",
    "prepare": "fednav.process.run",
    "Prepared": "fednav.process.run",
    "ProcessResult": "fednav.process.run",
    # evaluating a solution against a reference
    "errors_against": "fednav.process.run",
    "rmse": "fednav.process.run",
    # plots
    "plot_errors": "fednav.process.output",
    "plot_track": "fednav.process.output",
}

#: exported names that differ from their name in the defining module
_NAMES = {"process_data": "process"}

__all__ = [*_LAZY]


#: the subpackages, imported on first use as attributes (``fednav.core.config`` after
#: ``import fednav``)
_SUBPACKAGES = ("core", "ins", "filters", "sensors", "io", "navigator", "sim", "process",
                "campaign", "launch", "scenarios")


def __getattr__(name: str):
    """The API's names and the subpackages, imported on first use."""
    import importlib

    if name in _SUBPACKAGES:
        return importlib.import_module(f"fednav.{name}")
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'fednav' has no attribute '{name}'")

    value = getattr(importlib.import_module(module), _NAMES.get(name, name))
    globals()[name] = value  # (found directly next time)
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

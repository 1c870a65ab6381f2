"""A scenario's simulated run as recorded data (``fednav simulate PAPER --mode M``).

:func:`write_run` writes the data that run ``seed`` of the scenario flies (the same
random draws as :func:`fednav.sim.runs.make_run_data`, so ``fednav reproduce`` and
``fednav process`` on these files see the same numbers) in fednav's file layouts
(``docs/data-formats.md``):

* ``imu.csv`` — the corrupted IMU increments ``dtheta_*_rad``, ``dv_*_mps`` (body
  right-forward-up), each row stamped at the end of its interval;
* one file per sensor the mode's navigator is fed (its aiding sensors, a damping
  barometer, air data for the wind constraint), ``<sensor>.csv``, with each row's
  1-sigma and, for delayed sensors, ``t_arrival_s`` — or the files a real one gives,
  where the sensor has a format of its own (:data:`fednav.io.sensorfile.OWN_WRITERS`:
  the raw GNSS receiver's RINEX observation and navigation files);
* ``reference.csv`` — the truth at every IMU sample, with attitude;
* ``system.yaml`` — the system description of that mode (:meth:`Scenario.system_for`)
  with the run's initial state (``initial:``, the truth moved by the run's drawn initial
  errors, and their 1-sigma) and the files (``files:``), so that
  ``fednav process csv --config DIR/system.yaml`` runs the same navigator.

Every number is written with 17 significant digits: the files read back to the same
doubles but for the degree conversions' rounding.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core import units
from ..io.csvdata import INCREMENT_COLUMNS, write_csv
from ..io.sensorfile import OWN_WRITERS, write_sensor_csv
from ..navigator.system import missing_figures
from .runs import feed_order, make_run_data
from .scenario import ModeConfig, Scenario


def fed_sensors(scn: Scenario, mode: ModeConfig) -> list[str]:
    """The sensors the navigator of ``mode`` is fed: its aiding sensors and those with
    another role in its system (a barometer's damping loop, air data for the wind
    constraint: :meth:`fednav.navigator.system.System.roles`), as
    :func:`fednav.sim.runs.run_mode` feeds them."""
    return feed_order(mode.aiding, scn.system_for(mode))


def find_mode(scn: Scenario, name: str | None) -> ModeConfig:
    """The mode called ``name`` (default: the scenario's last, its full system); a
    one-line error naming the modes."""
    from ..core.config import ConfigError

    if name is None:
        return scn.modes[-1]
    for m in scn.modes:
        if m.name.lower() == name.lower():
            return m
    raise ConfigError(f"scenario {scn.name} has no mode '{name}'; its modes: "
                      f"{', '.join(m.name for m in scn.modes)}")


def system_yaml(scn: Scenario, mode: ModeConfig, truth, data, files: dict[str, str],
                sections: dict[str, dict] | None = None) -> dict:
    """The system description of ``mode`` with the initial state of the run whose data
    (:class:`~fednav.sim.runs.RunData`) are ``data``, the files, and the keys
    ``sections`` {sensor: {key: value}} that go with a file (a receiver's time offset),
    as a mapping for YAML (SI and degrees as the keys say)."""
    from .runs import _initial_state

    init = _initial_state(scn, truth, data)
    system = scn.system_for(mode)
    out = system.model_dump(mode="json", exclude_none=True,
                            exclude={"alignment", "smoother", "files", "initial"})
    # the figures the scenario leaves out are zero in a simulation; recorded data must say
    # so (fednav process refuses a figure it is not given)
    for key in missing_figures(system.imu):
        if not key.endswith("tau_s"):
            out["imu"][key] = 0.0
    ie = scn.initial_errors
    lat, lon = (float(v) for v in units.to_deg(init.lla[:2]))
    pos = np.broadcast_to(np.asarray(ie.position_m, dtype=float), (3,))
    out["initial"] = {
        "t_s": float(init.t), "lat_deg": lat, "lon_deg": lon, "h_m": float(init.lla[2]),
        "vel_mps": [float(v) for v in init.vel],
        "euler_deg": [float(v) for v in units.to_deg(init.euler)],
        "sigma": {"attitude_arcsec": [float(v) for v in ie.attitude_arcsec],
                  "velocity_mps": float(ie.velocity_mps),
                  "position_m": [float(v) for v in pos]}}
    for name, keys in (sections or {}).items():
        out["sensors"][name].update(keys)
    out["files"] = dict(files)
    return out


def write_run(scn: Scenario, seed: int, mode: ModeConfig, out,
              max_time: float | None = None) -> list[Path]:
    """The files of run ``seed``, mode ``mode`` into folder ``out`` (see the module
    docstring); returns their paths."""
    import yaml

    from ..core.atomic import write_text

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    truth = scn.trajectory(max_time)
    data = make_run_data(scn, seed, max_time)
    m = len(truth.t) - 1
    cols = {"t_s": truth.t[1:]}
    for j, c in enumerate(INCREMENT_COLUMNS[:3]):
        cols[c] = data.dtheta[:m, j]
    for j, c in enumerate(INCREMENT_COLUMNS[3:]):
        cols[c] = data.dv[:m, j]
    files = [write_csv(out / "imu.csv", cols, significant=17)]
    names, sections = {"imu": "imu.csv"}, {}
    system = scn.system_for(mode)
    for name in fed_sensors(scn, mode):
        if name not in data.series:
            continue
        own = OWN_WRITERS.get(name)
        if own is not None:
            written, names[name], sections[name] = own(out, data.series[name], truth,
                                                       system.sensors[name])
            files += written
            continue
        files.append(write_sensor_csv(out / f"{name}.csv", data.series[name], sigma=True))
        names[name] = f"{name}.csv"
    deg = units.to_deg
    files.append(write_csv(out / "reference.csv", {
        "t_s": truth.t, "lat_deg": deg(truth.lla[:, 0]), "lon_deg": deg(truth.lla[:, 1]),
        "h_m": truth.lla[:, 2], "vE_mps": truth.vel[:, 0], "vN_mps": truth.vel[:, 1],
        "vU_mps": truth.vel[:, 2], "pitch_deg": deg(truth.euler[:, 0]),
        "roll_deg": deg(truth.euler[:, 1]), "heading_deg": deg(truth.euler[:, 2])},
        significant=17))
    names["reference"] = "reference.csv"
    desc = system_yaml(scn, mode, truth, data, names, sections)
    head = (f"# fednav process csv --config {out / 'system.yaml'}: scenario {scn.name}, "
            f"mode {mode.name}, run seed {seed}"
            + (f", first {max_time:g} s" if max_time is not None else "") + "\n")
    files.append(write_text(out / "system.yaml", head + yaml.safe_dump(desc, sort_keys=False)))
    return files


def truth_errors(scn: Scenario, mode: ModeConfig, seed: int,
                 max_time: float | None = None):
    """Run ``seed``, mode ``mode`` as ``fednav reproduce`` flies it
    (:func:`fednav.sim.runs.run_configured_mode`): its :class:`RunResult` (the errors at
    the statistics epochs) — what the round trip compares ``fednav process`` with."""
    from .runs import run_configured_mode

    return run_configured_mode(scn, mode, make_run_data(scn, seed, max_time), max_time)



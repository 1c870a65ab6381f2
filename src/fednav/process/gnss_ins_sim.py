"""A gnss-ins-sim folder's system description: what the folder says, laid into the
user's (``fednav process gnss-ins-sim``)."""

from __future__ import annotations

from ..io.gnss_ins_sim import GnssInsSimRecording
from ..navigator.system import System


def gnss_ins_sim_system(rec: GnssInsSimRecording, cfg):
    """The system description ``cfg`` completed from the folder (what ``fednav process
    gnss-ins-sim`` runs), with the warnings saying what was assumed:

    * ``sensors.gnss``: the reader's 1-sigma (the RMS against ``ref_gps.csv``, else
      gnss-ins-sim's built-in profile) where the description gives none;
    * ``sensors.mag``: the declination and inclination the reader found, where the
      description has a ``mag`` section without them;
    * the magnetometer and the odometer aid only when the description has their section
      (their noise and the odometer's scale are the simulation script's); otherwise
      their series are left out with a warning.

    Returns ``(System, series to process, warnings)``: the warnings open with the
    reader's notes (the one on IMU figures only when the description gives none)."""
    figures = set(cfg.imu.model_fields_set) - {"max_bridge_s", "random_bias", "mounting"}
    warnings = [f"{rec.source}: {n}" for n in rec.notes
                if not (figures and n.startswith("imu:"))]
    data = cfg.model_dump(exclude_unset=True, mode="json")
    # (each section as it was given: the sensors' dump holds every default)
    sensors = data["sensors"] = {n: c.model_dump(exclude_unset=True, mode="json")
                                 for n, c in cfg.sensors.items()}
    g = rec.gnss
    if g is not None:
        sec = sensors.setdefault("gnss", {})
        sec.setdefault("sigma_pos_enu_m", [float(v) for v in g.sigma_pos_enu])
        sec.setdefault("sigma_vel_mps", [float(v) for v in g.sigma_vel])
    if "mag" in sensors:
        for key in ("declination_deg", "inclination_deg"):
            if key not in sensors["mag"] and f"mag_{key}" in rec.quality:
                sensors["mag"][key] = rec.quality[f"mag_{key}"]
    series = {n: s for n, s in rec.series.items() if n == "gnss" or n in sensors}
    left = [n for n in rec.series if n not in series]
    if left:
        warnings.append(f"{rec.source}: {' and '.join(left)} read but not used: give "
                        f"{' and '.join(f'sensors.{n}' for n in left)} in --config "
                        f"(their noise{' and scale' if 'odometer' in left else ''}) to aid "
                        f"with {'them' if len(left) > 1 else 'it'}")
    return System.model_validate(data), series, warnings

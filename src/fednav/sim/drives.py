"""Short simulated car drives for alignment and land-vehicle tests and benchmarks.

:func:`car_drive` draws a drive that starts facing any heading at any speed (a moving
start has no static period to level in) and returns it as recorded data for
:func:`fednav.process.process`: the IMU, the GNSS at a roof antenna, the truth as a
reference, and a system description with the IMU's data-sheet figures and the antenna's
lever arm — what a user would give, nothing tuned to the drive.

Frames and units as everywhere in fednav: body right-forward-up, ENU, SI inside.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io.data import GnssData, ImuData, ImuErrors, Reference
from ..navigator.system import System, load_system
from ..sensors.imu import ImuConfig
from .dataset import DatasetConfig, GnssSimConfig, process_config, simulate_dataset
from .scenario import SegmentConfig, StartConfig

#: The ADIS16405-class IMU of ``examples/car-drive.yaml`` (turn-on biases drawn per run).
ADIS16405 = {"random_bias": True, "gyro_bias_deg_h": 200.0, "gyro_markov_deg_h": 25.0,
             "gyro_markov_tau_s": 100.0, "gyro_arw_deg_sqrt_h": 2.0, "accel_bias_ug": 2000.0,
             "accel_markov_ug": 200.0, "accel_markov_tau_s": 100.0,
             "accel_vrw_ug_sqrt_hz": 200.0}
#: An ADIS16488-class IMU (industrial MEMS).
ADIS16488 = {"random_bias": True, "gyro_bias_deg_h": 20.0, "gyro_markov_deg_h": 6.0,
             "gyro_markov_tau_s": 100.0, "gyro_arw_deg_sqrt_h": 0.3, "accel_bias_ug": 500.0,
             "accel_markov_ug": 100.0, "accel_markov_tau_s": 100.0,
             "accel_vrw_ug_sqrt_hz": 60.0}

#: The motion after the start: pull away, turns both ways, a stop, a straight.
SEGMENTS = (
    {"name": "pull away", "duration_s": 8.0, "accel_mps2": 1.0},
    {"name": "street", "duration_s": 10.0},
    {"name": "right turn", "duration_s": 10.0, "heading_rate_deg_s": 9.0},
    {"name": "street", "duration_s": 15.0},
    {"name": "brake", "duration_s": 5.0, "accel_mps2": -1.0},
    {"name": "stop", "duration_s": 8.0},
    {"name": "pull away", "duration_s": 6.0, "accel_mps2": 1.2},
    {"name": "left turn", "duration_s": 10.0, "heading_rate_deg_s": -9.0},
    {"name": "avenue", "duration_s": 20.0},
)


@dataclass
class Drive:
    """A simulated drive as recorded data: ``imu``, ``gnss``, the truth ``reference`` (at
    every IMU sample, attitude included) and the ``system`` a user would give."""

    imu: ImuData
    gnss: GnssData
    reference: Reference
    system: System
    #: the IMU errors drawn (bias series, scale factors; :class:`~fednav.sensors.imu.
    #: ImuErrorState`)
    imu_state: object = None


def car_drive(heading_deg: float = 30.0, speed_mps: float = 0.0, seed: int = 1,
              imu: dict | None = None, static_s: float = 0.0, accel_mps2: float = 1.0,
              imu_period_s: float = 0.01, gnss: dict | None = None,
              hill_deg: float = 0.0) -> Drive:
    """A ~100 s car drive starting at ``heading_deg`` and ``speed_mps`` (a moving start:
    the vehicle keeps rolling and pulls away at ``accel_mps2`` for 8 s, later brakes to a
    stop; ``static_s`` of steady motion at the start speed first when > 0 — standing
    still when that speed is 0), IMU figures ``imu`` (default :data:`ADIS16405`), GNSS receiver
    ``gnss`` (:class:`~fednav.sim.dataset.GnssSimConfig` keys; default 5 Hz, 1.5 m /
    0.05 m/s, antenna 1.2 m above and 1 m behind the IMU); with ``hill_deg`` the streets
    and the avenue climb at that slope (pitching up over 2 s, down over 2 s at the end)."""
    segments = []
    for s in SEGMENTS:
        if hill_deg and s["name"] in ("street", "avenue"):
            rate = hill_deg / 2.0
            segments += [{**s, "duration_s": 2.0, "pitch_rate_deg_s": rate},
                         {**s, "duration_s": s["duration_s"] - 4.0},
                         {**s, "duration_s": 2.0, "pitch_rate_deg_s": -rate}]
        else:
            segments.append(dict(s))
    segments[0]["accel_mps2"] = accel_mps2
    # to a stop, not below zero by a rounding (the generator's arithmetic: a * n * dt)
    n8, n5 = round(8.0 / imu_period_s), round(5.0 / imu_period_s)
    v = speed_mps + accel_mps2 * n8 * imu_period_s
    brake = -v / 5.0
    while v + brake * n5 * imu_period_s < 0.0 or v + brake * 5.0 < 0.0:
        brake = float(np.nextafter(brake, 0.0))
    next(s for s in segments if s["name"] == "brake")["accel_mps2"] = brake
    if static_s > 0.0:
        segments.insert(0, {"name": "static", "duration_s": static_s})
    return drive_of(segments, heading_deg, speed_mps, seed, imu, imu_period_s, gnss)


def town_drive(seed: int = 1, duration_s: float = 300.0, imu: dict | None = None,
                gnss: dict | None = None) -> Drive:
    """A town drive of about ``duration_s`` (its last segment may run up to 16 s over):
    from 8 m/s, speeding up and slowing down every few seconds (1–4 s at up to 1.5 m/s^2,
    between 3 and 15 m/s, never to a stop) with turns between (6–12 s at up to 9 deg/s;
    every duration a whole tenth of a second) — the speed changes a car's receiver
    latency shows in (a cruise at one speed hides it; :mod:`fednav.process.latency`).
    Drawn by a ``numpy.random.Generator`` of ``seed``; IMU and GNSS as
    :func:`car_drive`."""
    rng = np.random.default_rng(seed)
    segments = town_segments(rng, duration_s)
    return drive_of(segments, float(rng.uniform(0.0, 360.0)), 8.0, seed, imu, 0.01, gnss)


def town_segments(rng: np.random.Generator, duration_s: float) -> list[dict]:
    """:func:`town_drive`'s segments (:class:`~fednav.sim.scenario.SegmentConfig` keys)
    for a drive from 8 m/s, drawn from ``rng``: ``speed`` segments (``accel_mps2``) and
    ``turn`` segments (``heading_rate_deg_s``), each ``duration_s`` a whole tenth of a
    second (another generator's motion can be written from them)."""
    segments, v, t = [], 8.0, 0.0
    while t < duration_s:
        d = round(float(rng.uniform(1.0, 4.0)), 1)
        a = float(np.clip(rng.uniform(-1.5, 1.5), (3.0 - v) / d, (15.0 - v) / d))
        segments.append({"name": "speed", "duration_s": d, "accel_mps2": a})
        v, t = v + a * d, t + d
        if rng.uniform() < 0.3:
            d = round(float(rng.uniform(6.0, 12.0)), 1)
            segments.append({"name": "turn", "duration_s": d,
                             "heading_rate_deg_s": float(rng.uniform(-9.0, 9.0))})
            t += d
    return segments


def drive_of(segments: list[dict], heading_deg: float, speed_mps: float, seed: int,
             imu: dict | None, imu_period_s: float, gnss: dict | None) -> Drive:
    """The :class:`Drive` of ``segments`` (:class:`~fednav.sim.scenario.SegmentConfig`
    keys) from ``heading_deg`` and ``speed_mps``, IMU and GNSS as :func:`car_drive`."""
    cfg = DatasetConfig(
        name="car-drive", seed=seed, imu_period_s=imu_period_s,
        start=StartConfig(lat_deg=51.05, lon_deg=-114.07, h_m=1050.0, speed_mps=speed_mps,
                          heading_deg=heading_deg),
        segments=[SegmentConfig(**s) for s in segments],
        imu=ImuConfig(**(ADIS16405 if imu is None else imu)),
        gnss=GnssSimConfig(**({"lever_m": (0.3, -1.0, 1.2)} if gnss is None else gnss)))
    ds = simulate_dataset(cfg)
    figures = process_config(ds)
    f = figures["imu"]
    three = lambda v: np.full(3, float(v))  # noqa: E731
    errors = ImuErrors(three(f["gyro_arw_rad_sqrt_s"]), three(f["accel_vrw_mps_sqrt_s"]),
                       three(f["gyro_bias_radps"]), three(f["accel_bias_mps2"]),
                       three(f["gyro_markov_radps"]), three(f["accel_markov_mps2"]),
                       three(f.get("gyro_tau_s", np.inf)), three(f.get("accel_tau_s", np.inf)))
    g = cfg.gnss
    return Drive(
        ImuData("car-drive imu", ds.t, ds.gyro, ds.accel, errors),
        GnssData("car-drive gnss", ds.gnss_t, ds.gnss_lla, ds.gnss_vel,
                 np.asarray(g.sigma_pos_enu_m, dtype=float),
                 np.asarray(g.sigma_vel_mps, dtype=float),
                 np.asarray(g.lever_m, dtype=float)),
        Reference("car-drive truth", ds.t, ds.ref_lla, ds.ref_vel, ds.ref_euler),
        load_system(figures), ds.imu_state)


def heading_containment(sol, reference: Reference, rows=None) -> tuple[float, float]:
    """Fraction of the solution's rows (default: its filter epochs) whose heading error
    lies within 3 sigma, and the largest |error| / sigma there."""
    idx = sol.epoch_rows if rows is None else rows
    if idx is None:
        idx = np.arange(len(sol.t))
    t = sol.t[idx]
    href = np.interp(t, reference.t, np.unwrap(reference.euler[:, 2]))
    err = np.angle(np.exp(1j * (sol.euler[idx, 2] - href)))
    ratio = np.abs(err) / sol.sigma_euler[idx, 2]
    return float(np.mean(ratio <= 3.0)), float(ratio.max())


__all__ = ["ADIS16405", "ADIS16488", "Drive", "car_drive", "drive_of", "heading_containment",
           "town_drive", "town_segments"]

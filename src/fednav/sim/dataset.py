"""Simulated datasets in fednav's own file layouts (``fednav simulate``).

A dataset scenario (YAML, :class:`DatasetConfig`) gives the start, the motion as segments
(:class:`~fednav.sim.scenario.SegmentConfig`), the IMU error figures
(:class:`~fednav.sensors.imu.ImuConfig`), the GNSS receiver (rate, noise, antenna lever arm)
and optionally a velocity sensor. :func:`simulate_dataset` draws one realisation from
its seed; :func:`write_csv_dataset` and :func:`write_navego_dataset` write it in the
layouts of ``docs/data-formats.md`` — ``imu.csv gnss.csv velocity.csv reference.csv``
plus ``process.yaml`` (the noise figures, which CSV files have no room for), or NaveGo's
``imu.mat gnss.mat visual.mat ref.mat`` with the figures in the IMU struct — so that
``fednav process csv|navego`` reads them back unchanged.

Frames and units as everywhere in fednav: body right-forward-up, ENU, SI inside; the
files use the edge units of their layout (degrees in CSV, NaveGo's FRD/NED radians).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydantic import Field, field_validator, model_validator

from ..core import earth, units
from ..core.config import _Model, load_model
from ..sensors.base import SensorView
from ..sensors.gnss import renamed_neu_keys
from ..sensors.imu import ImuConfig
from .scenario import SegmentConfig, StartConfig

_V3 = tuple[float, float, float]


class GnssSimConfig(_Model):
    """GNSS receiver: fix period [s], 1-sigma position noise ``sigma_pos_enu_m`` [east,
    north, up] m and velocity noise ``sigma_vel_mps`` [east, north, up] m/s (white),
    antenna lever arm from the IMU (body right-forward-up, m).

    Optionally a time-correlated position error on top of the white one (multipath,
    atmosphere, orbit errors: what makes a real receiver's positions wander): a
    first-order Gauss–Markov process per axis of stationary 1-sigma
    ``markov_sigma_enu_m`` [east, north, up] m and correlation time ``markov_tau_s`` [s],
    drawn from its own random stream (``seed``, 2) so that the other draws are the same
    with it or without.
    Off by default (zeros).  The sigma written for the filter (``process.yaml``, NaveGo's
    ``stdm``) is then the whole error's, ``hypot(sigma_pos_enu_m, markov_sigma_enu_m)``:
    what a receiver's accuracy estimate reports.  The old keys ``sigma_pos_m`` and
    ``markov_sigma_m`` ([north, east, up]) are read, reordered, with a ``FutureWarning``
    for one more release."""

    period_s: float = Field(0.2, gt=0.0)
    sigma_pos_enu_m: _V3 = (1.5, 1.5, 3.0)
    sigma_vel_mps: _V3 = (0.05, 0.05, 0.1)
    lever_m: _V3 = (0.0, 0.0, 0.0)
    markov_sigma_enu_m: _V3 = (0.0, 0.0, 0.0)
    markov_tau_s: float = Field(100.0, gt=0.0)

    @model_validator(mode="before")
    @classmethod
    def _renamed(cls, data):
        return renamed_neu_keys(data, "gnss", {"sigma_pos_m": "sigma_pos_enu_m",
                                               "markov_sigma_m": "markov_sigma_enu_m"})

    @field_validator("markov_sigma_enu_m")
    @classmethod
    def _nonnegative(cls, v):
        if min(v) < 0:
            raise ValueError("a Gauss-Markov sigma is not negative")
        return v

    def reported_sigma_pos_enu_m(self) -> _V3:
        """The position 1-sigma [east, north, up] m of the whole error (white and
        Gauss–Markov)."""
        return tuple(float(x) for x in np.hypot(self.sigma_pos_enu_m,
                                                self.markov_sigma_enu_m))


def gauss_markov(n: int, dt: float, sigma, tau: float, rng) -> np.ndarray:
    """``n`` samples every ``dt`` [s] of first-order Gauss–Markov processes (one column
    per entry of ``sigma``), stationary from the first sample: ``x[k+1] = phi x[k] +
    sqrt(1 - phi^2) sigma w[k]``, ``phi = exp(-dt / tau)``."""
    sigma = np.asarray(sigma, dtype=float)
    phi = float(np.exp(-dt / tau))
    w = rng.standard_normal((n, len(sigma))) * sigma
    w[1:] *= np.sqrt(1.0 - phi * phi)
    from scipy.signal import lfilter

    return lfilter([1.0], [1.0, -phi], w, axis=0)


class VelocitySimConfig(_Model):
    """Velocity sensor (odometry, visual odometry): period [s], 1-sigma ENU noise [m/s],
    lever arm (body right-forward-up, m); optionally a time-correlated error on top
    (first-order Gauss–Markov per ENU axis: ``markov_sigma_mps``, ``markov_tau_s``; its
    own random stream (``seed``, 3)), the sigma written for the filter then the whole
    error's, ``hypot(sigma_mps, markov_sigma_mps)``."""

    period_s: float = Field(0.1, gt=0.0)
    sigma_mps: _V3 = (0.05, 0.05, 0.05)
    lever_m: _V3 = (0.0, 0.0, 0.0)
    markov_sigma_mps: _V3 = (0.0, 0.0, 0.0)
    markov_tau_s: float = Field(30.0, gt=0.0)

    def reported_sigma_mps(self) -> np.ndarray:
        """The 1-sigma [east, north, up] m/s of the whole error (white and Gauss–Markov)."""
        return np.hypot(self.sigma_mps, self.markov_sigma_mps)


class DatasetConfig(_Model):
    """A dataset scenario (the YAML of ``fednav simulate``)."""

    name: str = "dataset"
    description: str = ""
    seed: int = 1
    start: StartConfig
    imu_period_s: float = Field(0.005, gt=0.0)
    segments: list[SegmentConfig] = Field(min_length=1)
    imu: ImuConfig
    gnss: GnssSimConfig = GnssSimConfig()
    velocity: VelocitySimConfig | None = None
    #: 1-sigma [pitch, roll, heading] deg of NaveGo's ini_align (written roll first)
    initial_attitude_error_deg: _V3 = (1.0, 1.0, 2.0)

    def truncated(self, seconds: float) -> DatasetConfig:
        """This scenario's first ``seconds`` [s] (the last segment cut short)."""
        segs, left = [], float(seconds)
        for seg in self.segments:
            if left <= 0:
                break
            segs.append(seg.model_copy(update={"duration_s": min(seg.duration_s, left)}))
            left -= seg.duration_s
        return self.model_copy(update={"segments": segs})


@dataclass
class Dataset:
    """One realisation: IMU ``t`` (N,), ``gyro`` [rad/s] and ``accel`` [m/s^2] (body
    RFU; sample ``k``'s rates hold over ``[t_k, t_k + dt]``, from its stamp); GNSS
    ``gnss_t``, antenna ``gnss_lla`` [rad, rad, m] and ENU ``gnss_vel`` (the last fix may
    lie at the last sample's end, past the reference); optional velocity sensor
    ``vel_t``, ``vel`` (ENU at its lever point); reference of the IMU at every IMU
    sample's stamp ``ref_lla``, ``ref_vel``, ``ref_euler``; and the config."""

    cfg: DatasetConfig
    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    gnss_t: np.ndarray
    gnss_lla: np.ndarray
    gnss_vel: np.ndarray
    vel_t: np.ndarray | None
    vel: np.ndarray | None
    ref_lla: np.ndarray
    ref_vel: np.ndarray
    ref_euler: np.ndarray
    #: the IMU errors drawn (:class:`~fednav.sensors.imu.ImuErrorState`: bias series and
    #: scale factors)
    imu_state: object = None


def load_dataset_config(path) -> DatasetConfig:
    return load_model(path, DatasetConfig, "dataset scenario")


def _lever_point(tr, idx, lever):
    """Position and ENU velocity of a point at ``lever`` (body) from the IMU, at samples
    ``idx`` of the trajectory: the sensors' own view of the truth
    (:class:`~fednav.sensors.base.SensorView`, the one place lever arms are simulated)."""
    at = SensorView.of(tr, lever).at(tr.t[idx])
    return at["lla"], at["vel"]


def simulate_dataset(cfg: DatasetConfig) -> Dataset:
    """Draw the dataset of ``cfg`` (seeded by ``cfg.seed``)."""
    from ..sensors import corrupt_imu
    from .trajectory import generate

    st = cfg.start
    tr = generate(np.array([units.deg(st.lat_deg), units.deg(st.lon_deg), st.h_m]),
                  st.speed_mps, units.deg(np.array([st.pitch_deg, st.roll_deg,
                                                    st.heading_deg])),
                  [s.to_segment() for s in cfg.segments], cfg.imu_period_s)
    rng = np.random.default_rng(cfg.seed)
    dt = tr.dt
    dth, dv, imu_state = corrupt_imu(tr.dtheta, tr.dv, dt, cfg.imu.errors(dt), rng)
    g = cfg.gnss
    step = max(1, int(round(g.period_s / dt)))
    gi = np.arange(step, len(tr.t), step)
    lla, vel = _lever_point(tr, gi, g.lever_m)
    # drawn north, east, up (the draws of earlier releases: seeded datasets stay the same)
    sp, sv = np.asarray(g.sigma_pos_enu_m)[[1, 0, 2]], np.asarray(g.sigma_vel_mps)
    n_pos = rng.standard_normal((len(gi), 3)) * sp               # north, east, up
    if any(g.markov_sigma_enu_m):  # (its own stream: the draws below are the same without it)
        n_pos = n_pos + gauss_markov(len(gi), step * dt,
                                     np.asarray(g.markov_sigma_enu_m)[[1, 0, 2]],
                                     g.markov_tau_s, np.random.default_rng((cfg.seed, 2)))
    lla = earth.move_enu(lla, n_pos[:, [1, 0, 2]])
    vel = vel + rng.standard_normal((len(gi), 3)) * sv
    vt = vv = None
    if cfg.velocity is not None:
        vc = cfg.velocity
        step = max(1, int(round(vc.period_s / dt)))
        vi = np.arange(step, len(tr.t), step)
        _, vv = _lever_point(tr, vi, vc.lever_m)
        vv = vv + rng.standard_normal((len(vi), 3)) * np.asarray(vc.sigma_mps)
        if any(vc.markov_sigma_mps):  # (its own stream, as the GNSS's)
            vv = vv + gauss_markov(len(vi), step * dt, vc.markov_sigma_mps, vc.markov_tau_s,
                                   np.random.default_rng((cfg.seed, 3)))
        vt = tr.t[vi]
    # sample k's increments cover [t_k, t_k+1]: as rates they are stamped t_k, where
    # they start (ImuData's and the rates file's convention, docs/data-formats.md), and
    # the reference is the truth at the same stamps
    return Dataset(cfg, tr.t[:-1], dth / dt, dv / dt, tr.t[gi], lla, vel, vt, vv,
                   tr.lla[:-1], tr.vel[:-1], tr.euler[:-1], imu_state)


def process_config(ds: Dataset) -> dict:
    """The system description (``fednav process --config``) with the dataset's true noise
    figures (the scale factors' and the GNSS error's Gauss–Markov part too, when drawn:
    what the optional error states of ``filter.states`` start from; none is selected)."""
    cfg, dt = ds.cfg, ds.cfg.imu_period_s
    e = cfg.imu.errors(dt)
    imu = {"gyro_arw_rad_sqrt_s": e.gyro_arw, "accel_vrw_mps_sqrt_s": e.accel_vrw,
           "gyro_bias_radps": float(e.gyro_bias), "accel_bias_mps2": float(e.accel_bias),
           "gyro_markov_radps": e.gyro_markov_sigma,
           "accel_markov_mps2": e.accel_markov_sigma}
    for key, tau in (("gyro_tau_s", e.gyro_markov_tau), ("accel_tau_s", e.accel_markov_tau)):
        if np.isfinite(tau):
            imu[key] = float(tau)
    for key in ("gyro_scale_ppm", "accel_scale_ppm"):
        if getattr(cfg.imu, key):
            imu[key] = float(getattr(cfg.imu, key))
    sensors = {"gnss": {"sigma_pos_enu_m": list(cfg.gnss.reported_sigma_pos_enu_m()),
                        "sigma_vel_mps": list(map(float, cfg.gnss.sigma_vel_mps)),
                        "lever_m": list(map(float, cfg.gnss.lever_m))}}
    if any(cfg.gnss.markov_sigma_enu_m):
        sensors["gnss"]["markov_sigma_enu_m"] = list(map(float, cfg.gnss.markov_sigma_enu_m))
        sensors["gnss"]["markov_tau_s"] = float(cfg.gnss.markov_tau_s)
    v = cfg.velocity
    if v is not None and any(v.markov_sigma_mps):
        sensors["velocity"] = {"markov_sigma_mps": list(map(float, v.markov_sigma_mps)),
                               "markov_tau_s": float(v.markov_tau_s)}
    return {"imu": {k: float(v) for k, v in imu.items()}, "sensors": sensors}


def write_csv_dataset(ds: Dataset, out) -> list[Path]:
    """``imu.csv gnss.csv [velocity.csv] reference.csv process.yaml`` into ``out``."""
    import yaml

    from ..core.atomic import write_text
    from ..io.csvdata import write_csv

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    deg = units.to_deg
    files = [
        write_csv(out / "imu.csv", {
            "t_s": ds.t, "gyro_x_radps": ds.gyro[:, 0], "gyro_y_radps": ds.gyro[:, 1],
            "gyro_z_radps": ds.gyro[:, 2], "accel_x_mps2": ds.accel[:, 0],
            "accel_y_mps2": ds.accel[:, 1], "accel_z_mps2": ds.accel[:, 2]}),
        write_csv(out / "gnss.csv", {
            "t_s": ds.gnss_t, "lat_deg": deg(ds.gnss_lla[:, 0]),
            "lon_deg": deg(ds.gnss_lla[:, 1]), "h_m": ds.gnss_lla[:, 2],
            "vE_mps": ds.gnss_vel[:, 0], "vN_mps": ds.gnss_vel[:, 1],
            "vU_mps": ds.gnss_vel[:, 2]})]
    cfg = process_config(ds)
    if ds.vel is not None:
        s = ds.cfg.velocity.reported_sigma_mps()
        n = len(ds.vel_t)
        files.append(write_csv(out / "velocity.csv", {
            "t_s": ds.vel_t, "vE_mps": ds.vel[:, 0], "vN_mps": ds.vel[:, 1],
            "vU_mps": ds.vel[:, 2], "sigma_vE_mps": np.full(n, s[0]),
            "sigma_vN_mps": np.full(n, s[1]), "sigma_vU_mps": np.full(n, s[2])}))
    files.append(write_csv(out / "reference.csv", {
        "t_s": ds.t, "lat_deg": deg(ds.ref_lla[:, 0]), "lon_deg": deg(ds.ref_lla[:, 1]),
        "h_m": ds.ref_lla[:, 2], "vE_mps": ds.ref_vel[:, 0], "vN_mps": ds.ref_vel[:, 1],
        "vU_mps": ds.ref_vel[:, 2], "pitch_deg": deg(ds.ref_euler[:, 0]),
        "roll_deg": deg(ds.ref_euler[:, 1]), "heading_deg": deg(ds.ref_euler[:, 2])}))
    files.append(write_text(out / "process.yaml", "# fednav process --config: the true noise "
                            "figures of this simulated dataset\n"
                            + yaml.safe_dump(cfg, sort_keys=False)))
    return files


def write_navego_dataset(ds: Dataset, out) -> list[Path]:
    """NaveGo ``imu.mat gnss.mat [visual.mat] ref.mat`` into ``out`` (figures in the IMU
    struct; written atomically)."""
    import scipy.io

    from ..core.atomic import replacing
    from ..io.navego import FRD_TO_RFU, fednav_euler_to_navego

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cfg = ds.cfg
    f = process_config(ds)["imu"]  # the figures, SI; no correlation time: 1e9 s in NaveGo
    M = FRD_TO_RFU  # RFU -> FRD and ENU -> NED (its own inverse)
    one = np.ones(3)
    # (NaveGo's state starts at its first IMU stamp, the first sample's end: the truth
    # one sample in)
    r0, p0, y0 = fednav_euler_to_navego(ds.ref_euler[min(1, len(ds.ref_euler) - 1)])
    err = units.deg(np.asarray(cfg.initial_attitude_error_deg))[[1, 0, 2]]  # roll, pitch, yaw
    rng = np.random.default_rng(cfg.seed + 7919)
    ini = np.array([r0, p0, y0]) + err * rng.standard_normal(3)
    structs = {
        # (NaveGo integrates wb(i), fb(i) over [t(i-1), t(i)]: stamped at the end)
        "imu": {"t": ds.t + cfg.imu_period_s, "wb": ds.gyro @ M.T, "fb": ds.accel @ M.T,
                "arw": f["gyro_arw_rad_sqrt_s"] * one, "vrw": f["accel_vrw_mps_sqrt_s"] * one,
                "gb_sta": f["gyro_bias_radps"] * one, "ab_sta": f["accel_bias_mps2"] * one,
                "gb_dyn": f["gyro_markov_radps"] * one, "ab_dyn": f["accel_markov_mps2"] * one,
                "gb_corr": f.get("gyro_tau_s", 1e9) * one,
                "ab_corr": f.get("accel_tau_s", 1e9) * one,
                "ini_align": ini, "ini_align_err": err},
        "gnss": {"t": ds.gnss_t, "lat": ds.gnss_lla[:, 0], "lon": ds.gnss_lla[:, 1],
                 "h": ds.gnss_lla[:, 2], "vel": ds.gnss_vel @ M.T,
                 "stdm": np.asarray(cfg.gnss.reported_sigma_pos_enu_m())[[1, 0, 2]],  # NED
                 "stdv": np.asarray(cfg.gnss.sigma_vel_mps)[[1, 0, 2]],
                 "larm": M @ np.asarray(cfg.gnss.lever_m)},
    }
    roll, pitch, yaw = fednav_euler_to_navego(ds.ref_euler)
    structs["ref"] = {"t": ds.t, "lat": ds.ref_lla[:, 0], "lon": ds.ref_lla[:, 1],
                      "h": ds.ref_lla[:, 2], "vel": ds.ref_vel @ M.T, "roll": roll,
                      "pitch": pitch, "yaw": yaw}
    if ds.vel is not None:
        s2 = cfg.velocity.reported_sigma_mps()[[1, 0, 2]] ** 2   # NED variances
        structs["visual"] = {"t": ds.vel_t, "vel": ds.vel @ M.T,
                             "covv": np.tile(np.diag(s2).ravel(), (len(ds.vel_t), 1)),
                             "larm": M @ np.asarray(cfg.velocity.lever_m)}
    files = []
    for name, s in structs.items():
        path = out / f"{name}.mat"
        with replacing(path) as tmp, open(tmp, "wb") as f:
            scipy.io.savemat(f, {name: s})
        files.append(path)
    return files


def write_kfgins_dataset(ds: Dataset, out) -> list[Path]:
    """A KF-GINS user's folder into ``out``: ``imu.txt`` (increments, forward-right-down,
    stamped at each interval's end), ``gnss.txt`` (positions and their N/E/D 1-sigma),
    ``kf-gins.yaml`` (the true figures in KF-GINS's units; the initial state from the
    truth with the configured initial attitude error drawn, as the NaveGo files' is) and
    the truth ``truth.nav``; times are the dataset's, taken as GPS seconds of the week."""
    import yaml

    from ..core.atomic import replacing, write_text
    from ..io.kfgins import write_kfgins_nav
    from ..io.navego import FRD_TO_RFU, fednav_euler_to_navego

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cfg, dt = ds.cfg, ds.cfg.imu_period_s
    M = FRD_TO_RFU  # RFU -> FRD and ENU -> NED (its own inverse)
    deg = units.to_deg
    files = []
    rows = np.column_stack([ds.t + dt, ds.gyro @ M.T * dt, ds.accel @ M.T * dt])
    with replacing(out / "imu.txt") as tmp:
        np.savetxt(tmp, rows, fmt="%.6f" + " %.12e" * 6)
    files.append(out / "imu.txt")
    sd = np.asarray(cfg.gnss.reported_sigma_pos_enu_m(), dtype=float)[[1, 0, 2]]  # N, E, D
    rows = np.column_stack([ds.gnss_t, deg(ds.gnss_lla[:, 0]), deg(ds.gnss_lla[:, 1]),
                            ds.gnss_lla[:, 2], np.tile(sd, (len(ds.gnss_t), 1))])
    with replacing(out / "gnss.txt") as tmp:
        np.savetxt(tmp, rows, fmt="%.6f %.10f %.10f %.4f %.4f %.4f %.4f")
    files.append(out / "gnss.txt")
    f = process_config(ds)["imu"]
    err = units.deg(np.asarray(cfg.initial_attitude_error_deg))[[1, 0, 2]]  # roll, pitch, yaw
    rng = np.random.default_rng(cfg.seed + 7919)
    r0, p0, y0 = (np.array(fednav_euler_to_navego(ds.ref_euler[1]))
                  + err * rng.standard_normal(3))
    v0 = ds.ref_vel[1]
    tau = f.get("gyro_tau_s", f.get("accel_tau_s", 1e9))
    three = lambda v: [float(v)] * 3  # noqa: E731
    yml = {
        "imupath": "imu.txt", "gnsspath": "gnss.txt", "outputpath": ".",
        "imudatalen": 7, "imudatarate": int(round(1.0 / dt)),  # (KF-GINS: an int)
        "starttime": float(ds.t[0] + dt), "endtime": -1,
        "initpos": [float(deg(ds.ref_lla[1, 0])), float(deg(ds.ref_lla[1, 1])),
                    float(ds.ref_lla[1, 2])],
        "initvel": [float(v0[1]), float(v0[0]), float(-v0[2])],
        "initatt": [float(deg(r0)), float(deg(p0)), float(deg(y0) % 360.0)],
        "initgyrbias": three(0), "initaccbias": three(0), "initgyrscale": three(0),
        "initaccscale": three(0),
        "initposstd": three(0.1), "initvelstd": three(0.05),
        "initattstd": [float(x) for x in np.degrees(err)],
        "initbgstd": three(units.to_deg_per_h(np.hypot(f["gyro_bias_radps"],
                                                       f["gyro_markov_radps"]))),
        "initbastd": three(units.to_milligal(np.hypot(f["accel_bias_mps2"],
                                                      f["accel_markov_mps2"]))),
        "imunoise": {"arw": three(units.to_deg_per_sqrt_h(f["gyro_arw_rad_sqrt_s"])),
                     "vrw": three(units.to_mps_per_sqrt_h(f["accel_vrw_mps_sqrt_s"])),
                     "gbstd": three(units.to_deg_per_h(f["gyro_markov_radps"])),
                     "abstd": three(units.to_milligal(f["accel_markov_mps2"])),
                     "gsstd": three(f.get("gyro_scale_ppm", 0.0)),
                     "asstd": three(f.get("accel_scale_ppm", 0.0)),
                     "corrtime": float(tau / units.HOUR)},
        "antlever": [float(x) for x in M @ np.asarray(cfg.gnss.lever_m, dtype=float)],
    }
    files.append(write_text(out / "kf-gins.yaml", "# KF-GINS configuration of a dataset "
                            "simulated by fednav (its true figures in KF-GINS's units)\n"
                            + yaml.safe_dump(yml, sort_keys=False)))
    files.append(write_kfgins_nav(out / "truth.nav", ds.t, ds.ref_lla, ds.ref_vel,
                                  ds.ref_euler))
    return files

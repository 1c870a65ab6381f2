"""The consistency certificate: ``fednav certify`` (docs/certificate.md).

Monte Carlo over every registered aiding sensor (:data:`fednav.sensors.registry.SENSORS`)
x every registered filter type (:data:`fednav.filters.registry.FILTERS`) in each of its
covariance forms, each run with its own random geometry — a lever arm of up to
:data:`LEVER_MAX_M` on every sensor that takes one, a mounting rotation on every sensor
that takes one (:meth:`~fednav.sensors.spec.SensorSpec.check_geometry`), a latency within
one filter period (what ``delay_compensation: interpolate`` bridges exactly), a rate of
its own — on trajectories whose truth, IMU signal and measurements come from
:mod:`fednav.campaign.certify_truth` (numpy only, none of fednav's simulator or sensor
code).

**Combinations.**  A *mode* is a trajectory (``land``: a car with two stops; ``air``: an
aircraft in wind) and the sensors that aid: one mode per registered sensor (that sensor
alone; ``airdata``, which has no local filter, as the wind constraint on the star
sensor's), and one per trajectory with every sensor of that trajectory at once (a
federation of many local filters).  A combination is a mode x a filter type x a form.

**Figures** of a combination over its ``N`` runs (docs/certificate.md, "Statistics"):

* ``nees.pos``, ``nees.vel``, ``nees.att`` — at every check epoch (every
  :data:`CHECK_PERIOD_S` after the start) the normalised estimation error squared of the
  position, velocity and attitude errors with the 3 x 3 block of the fused covariance,
  averaged over the runs (``N NEES`` is chi-square with ``3 N`` degrees of freedom), then
  averaged over the check epochs, per degree of freedom, against the two-sided 99 % band
  of the ``N``-run average (the average over epochs has no larger a spread than one
  epoch's: the band is conservative);
* ``nis.<sensor>.<rows>`` — the normalised innovation squared of each sensor's rows of one
  kind (``pos``, ``vel``, ``att``, ``bvel``, ``rate``; ``model`` for a sensor whose model
  is not rows; ``constraint`` for the wind constraint) with the innovation covariance of
  the equivalent centralized filter (``beta (S - R) + R``), summed over its measurements
  and runs (``M`` measurements of ``d`` rows: chi-square with ``M d`` degrees of
  freedom, innovations of a consistent filter being white), per degree of freedom,
  against the two-sided 99 % band.

A combination is in band when every figure is and no run failed; one that is not is a
defect or one of the documented limitations of :data:`LIMITATIONS` (each with its
reason).  Units: SI inside; arc-seconds, degrees and micro-g only in the figures of the
setup below, as their names say.
"""

from __future__ import annotations

import fnmatch
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..core.errors import FednavError
from . import certify_truth as ct

#: IMU sample period [s] and filter epoch [s] of every run.
IMU_PERIOD_S = 0.01
FILTER_PERIOD_S = 0.1
#: NEES check epochs: every this many seconds after the start [s].
CHECK_PERIOD_S = 1.0
#: Largest lever arm drawn [m] (its length uniform in [0, LEVER_MAX_M]).
LEVER_MAX_M = 2.0
#: Two-sided coverage of the chi-square bands.
COVERAGE = 0.99
#: Sensor periods drawn from [s] (whole filter periods: "mixed rates").
PERIODS_S = (0.1, 0.2, 0.5, 1.0)
#: Runs per combination of the quick tier (the test suite's) and the full certificate.
QUICK_RUNS = 3
FULL_RUNS = 50
#: The quick tier flies the first this many seconds of each trajectory [s] (a stop of the
#: land vehicle included).
QUICK_DURATION_S = 40.0

#: The IMU, as the ``imu:`` section gives it to the filter: a tactical MEMS unit whose
#: every error the filter models exactly (turn-on biases drawn per run, a Gauss-Markov
#: gyro drift, white noise; no accelerometer Gauss-Markov, no scale factors).
IMU_SECTION = {"random_bias": True, "gyro_bias_deg_h": 5.0, "gyro_markov_deg_h": 1.0,
               "gyro_markov_tau_s": 300.0, "gyro_arw_deg_sqrt_h": 0.05,
               "accel_bias_ug": 200.0, "accel_vrw_ug_sqrt_hz": 50.0}
_DEG = math.pi / 180.0
_UG = 9.80665e-6
IMU = ct.ImuSpec(gyro_bias=5.0 * _DEG / 3600.0, gyro_markov=1.0 * _DEG / 3600.0,
                 gyro_tau=300.0, gyro_arw=0.05 * _DEG / 60.0, accel_bias=200.0 * _UG,
                 accel_vrw=50.0 * _UG)
#: 1-sigma of the initial errors (drawn per run; the filter's P0): misalignment east,
#: north, up [arcsec], velocity [m/s] and position [m] per ENU axis.
INITIAL_ATTITUDE_ARCSEC = (30.0, 30.0, 120.0)
INITIAL_VELOCITY_MPS = 0.05
INITIAL_POSITION_M = 1.0

_R = ct.Ramp
#: The two trajectories (certify_truth.Motion: closed-form smooth steps).
TRAJECTORIES = {
    # a car: 120 s, turns both ways, a hill, body roll, two stops of 10 s (zupt, zaru)
    "land": ct.Motion(
        "land", "land", 120.0, 48.137, 11.575, 520.0, speed_mps=8.0, heading_deg=30.0,
        speed=(_R(14.0, 8.0, 4.0), _R(24.0, 10.0, -12.0), _R(44.0, 10.0, 10.0),
               _R(88.0, 10.0, -10.0), _R(108.0, 8.0, 6.0)),
        heading=(_R(4.0, 10.0, 60.0), _R(58.0, 14.0, -90.0), _R(76.0, 8.0, 45.0),
                 _R(110.0, 8.0, 30.0)),
        pitch=(_R(55.0, 5.0, 3.0), _R(78.0, 5.0, -3.0)),
        roll=(_R(4.0, 5.0, 2.0), _R(9.0, 5.0, -2.0), _R(58.0, 5.0, -2.0),
              _R(67.0, 5.0, 2.0))),
    # an aircraft: 120 s at 50-60 m/s in a 6 m/s wind, banked turns, a climb and a descent
    "air": ct.Motion(
        "air", "air", 120.0, 37.41, -122.05, 800.0, speed_mps=50.0, heading_deg=215.0,
        speed=(_R(30.0, 10.0, 10.0), _R(90.0, 10.0, -5.0)),
        heading=(_R(12.0, 16.0, 90.0), _R(50.0, 20.0, -120.0), _R(95.0, 12.0, 60.0)),
        pitch=(_R(35.0, 4.0, 5.0), _R(55.0, 4.0, -5.0), _R(75.0, 4.0, -4.0),
               _R(88.0, 4.0, 4.0)),
        roll=(_R(10.0, 4.0, 20.0), _R(26.0, 4.0, -20.0), _R(48.0, 4.0, -25.0),
              _R(68.0, 4.0, 25.0), _R(93.0, 4.0, 15.0), _R(105.0, 4.0, -15.0)),
        wind_enu_mps=(4.0, -4.5, 0.0)),
}


@dataclass(frozen=True)
class SensorSetup:
    """How the certificate flies one sensor: its section (noise; ``period_s``,
    ``lever_m``, ``mounting`` and ``timing`` are drawn per run), the same figures in SI
    for :func:`~fednav.campaign.certify_truth.measure`, the periods it may have [s], and
    its trajectories (the first is its own mode's); ``stops``: measured only while the
    vehicle stands still; ``latency``: whether it may be drawn one (ZARU may not: its
    rate rows read the mean gyro rate of the epoch that uses them, not of the time of
    validity)."""

    section: dict
    sigma: dict
    trajectories: tuple[str, ...]
    periods: tuple[float, ...] = PERIODS_S
    stops: bool = False
    latency: bool = True


_ARCSEC = _DEG / 3600.0
#: ZARU: the epoch-mean gyro rate's white noise, ARW / sqrt(T) [rad/s].
ZARU_SIGMA = IMU.gyro_arw / math.sqrt(FILTER_PERIOD_S)
#: Every sensor the certificate knows how to measure, by registered name.
SETUP: dict[str, SensorSetup] = {
    "gnss": SensorSetup({"sigma_pos_enu_m": [1.5, 1.5, 3.0],
                         "sigma_vel_mps": [0.05, 0.05, 0.1]},
                        {"pos_enu": (1.5, 1.5, 3.0), "vel_enu": (0.05, 0.05, 0.1)},
                        ("land", "air")),
    "star": SensorSetup({"sigma_arcsec": 10.0}, {"angle": 10.0 * _ARCSEC}, ("air",)),
    "sar": SensorSetup({"sigma_pos_m": 5.0, "sigma_heading_deg": 0.2},
                       {"pos": 5.0, "heading": 0.2 * _DEG}, ("air",), (0.5, 1.0, 2.0)),
    # (a filter measurement: the damping loop's noise, modelled as white process noise
    # though the filter also uses the same samples, leaves the vertical velocity
    # pessimistic, NEES about 0.7: docs/certificate.md, benchmarks/certify.py --study baro)
    "baro": SensorSetup({"sigma_m": 1.0, "damping_loop": False}, {"h": 1.0},
                        ("air", "land")),
    "sarvel": SensorSetup({"sigma_mps": 0.1}, {"vel": 0.1}, ("air",)),
    "velocity": SensorSetup({"sigma_mps": [0.05, 0.05, 0.05]},
                            {"vel_enu": (0.05, 0.05, 0.05)}, ("land", "air")),
    "odometer": SensorSetup({"sigma_mps": 0.05}, {"vel": 0.05}, ("land",)),
    "dvl": SensorSetup({"sigma_mps": [0.03, 0.03, 0.03]}, {"vel_rfu": (0.03, 0.03, 0.03)},
                       ("land", "air")),
    "zupt": SensorSetup({"sigma_mps": 0.01}, {"vel": 0.01}, ("land",), (0.1, 0.2), True),
    "mag": SensorSetup({"sigma_heading_deg": 0.5, "declination_deg": 3.0,
                        "inclination_deg": 64.0},
                       {"heading": 0.5 * _DEG, "declination": 3.0 * _DEG,
                        "inclination": 64.0 * _DEG}, ("land", "air")),
    "nhc": SensorSetup({"sigma_mps": [0.05, 0.05]}, {"vel_ru": (0.05, 0.05)}, ("land",),
                       (0.1, 0.2)),
    "zaru": SensorSetup({"sigma_radps": ZARU_SIGMA}, {}, ("land",), (0.1,), True, False),
    # (the clock's densities: a TCXO's, fednav.sensors.gnss_raw.CLOCKS, as S_f, S_g)
    "gnss_raw": SensorSetup({"sigma_pseudorange_m": 3.0, "sigma_range_rate_mps": 0.1,
                             "elevation_mask_deg": 0.0, "clock_bias_sigma_m": 1000.0,
                             "clock_drift_sigma_mps": 10.0},
                            {"pr": 3.0, "rr": 0.1, "clock0": (1000.0, 10.0),
                             "clock": (1e-19 * 299792458.0**2,
                                       4e-20 * math.pi**2 * 299792458.0**2)},
                            ("land", "air")),
    "airdata": SensorSetup({"sigma_airspeed_mps": 0.3, "wind_sigma_mps": 0.3},
                           {"airspeed": 0.3, "wind": 0.3}, ("air",), latency=False),
}


@dataclass(frozen=True)
class Mode:
    """A trajectory and the sensors that aid (and the wind constraint, if any)."""

    name: str
    trajectory: str
    aiding: tuple[str, ...]
    constraint: str | None = None

    @property
    def sensors(self) -> tuple[str, ...]:
        """Every sensor whose data the mode uses (the constraint's too)."""
        return self.aiding + (("airdata",) if self.constraint == "wind" else ())


def modes() -> list[Mode]:
    """One mode per registered sensor the certificate knows, then one per trajectory with
    all of that trajectory's aiding sensors."""
    from ..sensors.registry import SENSORS

    out = []
    for name, spec in SENSORS.items():
        if name not in SETUP:
            continue
        traj = SETUP[name].trajectories[0]
        if spec.aiding:
            out.append(Mode(name, traj, (name,)))
        else:  # a constraint: on the star sensor's local filter (one local: counted once)
            out.append(Mode(name, traj, ("star",), "wind"))
    for traj in TRAJECTORIES:
        aiding = tuple(n for n, s in SENSORS.items() if n in SETUP and s.aiding
                       and traj in SETUP[n].trajectories)
        out.append(Mode(f"{traj}-all", traj, aiding))
    return out


def uncertified_sensors() -> list[str]:
    """Registered sensors the certificate has no measurement equation for (a sensor
    registered after this module was written: it needs a :data:`SETUP` entry)."""
    from ..sensors.registry import SENSORS

    return [n for n in SENSORS if n not in SETUP]


def filter_forms() -> list[tuple[str, str]]:
    """Every registered filter type in each of its forms: (type, form)."""
    from ..filters.registry import FILTERS, square_root_names

    sr = set(square_root_names())
    return [(f, form) for f in FILTERS for form in ("standard", "square_root")
            if form == "standard" or f in sr]


# ------------------------------------------------------------------- limitations
@dataclass(frozen=True)
class Limitation:
    """A combination, or one of its figures, known to fall outside its band, and why:
    ``filter``, ``form``, ``mode`` and ``figure`` are shell patterns (``figure`` also
    matches ``error``: a run that failed)."""

    filter: str
    form: str
    mode: str
    figure: str
    reason: str

    def covers(self, filter_: str, form: str, mode: str, figure: str) -> bool:
        """Whether this limitation explains ``figure`` of the combination."""
        return all(fnmatch.fnmatchcase(v, p) for v, p in (
            (filter_, self.filter), (form, self.form), (mode, self.mode),
            (figure, self.figure)))


_SAGE_HUSA = (
    "Sage-Husa estimation of R from its own innovations (fading memory 0.97: about 33 "
    "innovations) is not meant to be consistent with a known R: the estimate's own noise "
    "leaves R too low about half the time, and the filter overconfident then (NEES 2-7 per "
    "dof, NIS 0.91-0.97 with a single sensor; docs/certificate.md; benchmarks/certify.py "
    "--study adaptive)")
#: The documented limitations (docs/certificate.md gives the figures behind each).
LIMITATIONS: tuple[Limitation, ...] = (
    Limitation("pf", "*", "*", "*",
               "the SIR particle filter at its default 1000 particles on the 18-state "
               "error, with its exact-moment draws and progressive correction (filter.pf): "
               "no run fails and sar, baro, sarvel, odometer, mag and zaru are in band, but "
               "a sample covariance of 1000 particles stays overconfident where a mode "
               "leaves directions unmeasured for long or measures far more precisely than "
               "the prior: position and velocity NEES 3.2-5 with the star sensor and air "
               "data, 1.6-2.2 in the attitude of gnss, dvl, zupt, velocity and nhc, up to "
               "5.1 in the combined modes, and 72-275 with raw GNSS (its receiver clock's "
               "10 km prior) (fednav certify --filters pf --runs 20; docs/certificate.md)"),
    Limitation("aekf", "*", "*", "*", _SAGE_HUSA),
    Limitation("aasghqf", "*", "*", "*", _SAGE_HUSA),
    Limitation("raukf", "*", "*", "*",
               "robust adaptive UKF: its IGG-III weights inflate R for every innovation "
               "component beyond 1.5 sigma (13 % of them in a consistent filter), so its "
               "NIS per dof is about 0.72 by construction; and the Sage-Husa R of aekf"),
)


def limitation(filter_: str, form: str, mode: str, figure: str) -> Limitation | None:
    """The documented limitation that explains ``figure`` of a combination, or None."""
    for lim in LIMITATIONS:
        if lim.covers(filter_, form, mode, figure):
            return lim
    return None


# ----------------------------------------------------------------------- one run's data
def _lever(rng) -> list[float]:
    """A lever arm: uniform direction, length uniform in [0, LEVER_MAX_M] [m]."""
    d = rng.standard_normal(3)
    return list(d / np.linalg.norm(d) * rng.uniform(0.0, LEVER_MAX_M))


_LETTERS = {(1, 0, 0): "R", (-1, 0, 0): "L", (0, 1, 0): "F", (0, -1, 0): "B",
            (0, 0, 1): "U", (0, 0, -1): "D"}


def _mounting(rng, vehicles) -> tuple[object, np.ndarray]:
    """A mounting (as a section writes it) and its ``C_s^b``: a quarter none, a quarter
    an axis permutation (letters), half Euler angles (pitch within +-45 deg, roll and
    heading any); redrawn while the sensor's forward axis would point within 37 deg of
    the vertical on a level vehicle (``vehicles``: its ``C_b^V`` on each of its
    trajectories), where Euler angles of the sensor's axes lose their roll and
    heading."""
    while True:
        u = rng.uniform()
        if u < 0.25:
            value, M = None, np.eye(3)
        elif u < 0.5:
            while True:
                M = np.zeros((3, 3))
                perm = rng.permutation(3)
                M[perm, np.arange(3)] = rng.choice((-1.0, 1.0), 3)
                if np.linalg.det(M) > 0:
                    break
            value = "".join(_LETTERS[tuple(int(v) for v in M[:, j])] for j in range(3))
        else:
            e = [rng.uniform(-45.0, 45.0), rng.uniform(-180.0, 180.0),
                 rng.uniform(-180.0, 180.0)]
            value, M = {"euler_deg": e}, ct.euler_to_dcm(np.radians(e))
        if all(abs((V @ M)[2, 1]) <= 0.8 for V in vehicles):
            return value, M


def _timing(rng) -> dict:
    """A third each: no latency, a fixed one, a uniform range from 0 — never over one
    filter period (what ``interpolate`` bridges exactly) [s]."""
    u = rng.uniform()
    if u < 1.0 / 3.0:
        return {}
    if u < 2.0 / 3.0:
        return {"latency_s": float(rng.uniform(0.0, FILTER_PERIOD_S))}
    return {"latency_range_s": [0.0, float(rng.uniform(0.0, FILTER_PERIOD_S))]}


def _geometry_kinds(name: str) -> tuple[bool, bool]:
    """Whether sensor ``name`` takes a lever arm, and a mounting (its spec's
    ``check_geometry`` on a probe)."""
    from ..sensors.registry import SENSORS

    spec = SENSORS[name]
    base = dict(SETUP[name].section, period_s=1.0)
    lever = spec.check_geometry(spec.config.model_validate(
        dict(base, lever_m=[0.1, 0.2, 0.3]))) is None
    mount = spec.check_geometry(spec.config.model_validate(
        dict(base, mounting="FRD"))) is None
    return lever, mount


@dataclass
class RunData:
    """One run's data: per sensor its section, lever [m] and mounting ``C_s^b``; per
    trajectory the truth, measured IMU increments and initial errors (misalignment
    [rad], velocity [m/s], position east/north/up [m]); per (sensor, trajectory) the
    measurements ``(t, t_arrival, z)``."""

    seed: int
    sections: dict
    truth: dict
    imu: dict
    initial: dict
    measurements: dict


def _stops_times(truth, period: float) -> np.ndarray:
    """Grid indices every ``period`` where the vehicle has stood still since the epoch
    before (an ideal stop detector)."""
    n = int(round(period / IMU_PERIOD_S))
    idx = np.arange(n, len(truth.t), n)
    back = np.maximum(idx - int(round(FILTER_PERIOD_S / IMU_PERIOD_S)), 0)
    still = truth.stopped[idx] & truth.stopped[back]
    return idx[still]


@lru_cache(maxsize=2)
def run_data(seed: int, duration_s: float | None = None) -> RunData:
    """Draw run ``seed``'s geometry and errors and make its truth and measurements (one
    ``numpy.random.Generator`` seeded with ``seed``; cached per process)."""
    from ..sensors.registry import SENSORS

    rng = np.random.default_rng(seed)
    sections, levers, mounts = {}, {}, {}
    nhc_M = np.eye(3)
    # (the constraint's geometry first: it turns the land vehicle's body)
    order = sorted((n for n in SENSORS if n in SETUP), key=lambda n: n != "nhc")
    for name in order:
        setup = SETUP[name]
        takes_lever, takes_mount = _geometry_kinds(name)
        sec = dict(setup.section)
        sec["period_s"] = float(rng.choice(setup.periods))
        lever = _lever(rng) if takes_lever else [0.0, 0.0, 0.0]
        if takes_lever:
            sec["lever_m"] = lever
        # (the land vehicle's body is its frame turned by the constraint's mounting)
        vehicles = [nhc_M.T if tr == "land" and name != "nhc" else np.eye(3)
                    for tr in setup.trajectories]
        value, M = _mounting(rng, vehicles) if takes_mount else (None, np.eye(3))
        if value is not None:
            sec["mounting"] = value
        if name == "nhc":
            nhc_M = M
        timing = _timing(rng) if setup.latency else {}
        if timing:
            sec["timing"] = timing
        sections[name], levers[name], mounts[name] = sec, np.asarray(lever), M
    truth, imu, initial = {}, {}, {}
    for traj, motion in TRAJECTORIES.items():
        if duration_s is not None:
            motion = _shortened(motion, duration_s)
        if traj == "land" and "nhc" in SETUP:
            tr = ct.make_truth(motion, IMU_PERIOD_S, nhc_M.T, levers["nhc"])
        else:
            tr = ct.make_truth(motion, IMU_PERIOD_S)
        truth[traj] = tr
        imu[traj] = ct.corrupt_imu(tr, IMU, rng)[:2]
        initial[traj] = (rng.standard_normal(3) * np.asarray(INITIAL_ATTITUDE_ARCSEC)
                         * _ARCSEC, rng.standard_normal(3) * INITIAL_VELOCITY_MPS,
                         rng.standard_normal(3) * INITIAL_POSITION_M)
    meas = {}
    for name in sections:
        setup = SETUP[name]
        for traj in setup.trajectories:
            tr = truth[traj]
            period = sections[name]["period_s"]
            if setup.stops:
                idx = _stops_times(tr, period)
            else:
                n = int(round(period / IMU_PERIOD_S))
                idx = np.arange(n, len(tr.t), n)
            z = ct.measure(name, tr, idx, levers[name], mounts[name], setup.sigma, rng)
            t = tr.t[idx]
            tm = sections[name].get("timing", {})
            if "latency_s" in tm:
                ta = t + tm["latency_s"]
            elif "latency_range_s" in tm:
                ta = t + rng.uniform(*tm["latency_range_s"], len(t))
            else:
                ta = t
            meas[(name, traj)] = (t, ta, z)
    return RunData(seed, sections, truth, imu, initial, meas)


def _shortened(motion: ct.Motion, duration_s: float) -> ct.Motion:
    from dataclasses import replace

    return replace(motion, duration_s=min(motion.duration_s, float(duration_s)))


# --------------------------------------------------------------------- one flight
#: Row kinds of fednav.sensors.measurement -> the figure's row group.
_GROUPS = ("pos",) * 3 + ("vel",) * 3 + ("att",) * 3 + ("bvel",) * 3 + ("rate",) * 3


def system_for(mode: Mode, filter_type: str, form: str, data: RunData):
    """The fednav system a combination flies on run ``data``."""
    from ..navigator.system import System

    names = mode.sensors
    desc = {"imu": IMU_SECTION,
            "sensors": {n: data.sections[n] for n in names},
            "aiding": list(mode.aiding), "constraint": mode.constraint,
            "filter": {"type": filter_type, "form": form, "period_s": FILTER_PERIOD_S,
                       "sharing": "equal", "reset": True}}
    if filter_type == "pf":  # (the particles' draws differ run to run)
        desc["filter"]["pf"] = {"seed": data.seed}
    return System.model_validate(desc)


def _errors(states, truth, n_per: int, idx):
    """Position (east, north, up m), velocity (ENU m/s) and misalignment (rad) errors,
    computed minus true, of the INS states at epochs ``idx``."""
    from ..ins.strapdown import STATE_LLA, STATE_Q, STATE_VEL

    k = idx * n_per
    st = states[idx]
    dp = ct.metric_difference(st[:, STATE_LLA], truth.lla[k])
    dv = st[:, STATE_VEL] - truth.vel[k]
    C_hat = ct.quat_to_dcm(st[:, STATE_Q])
    phi = -ct.dcm_to_rotvec(C_hat @ np.swapaxes(truth.C[k], -1, -2))  # C_hat = exp(-[phi x]) C
    return dp, dv, phi


def _nees(err, P):
    """``e' P^-1 e`` of each row of ``err`` (K, 3) with ``P`` (K, 3, 3)."""
    return np.einsum("ki,ki->k", err, np.linalg.solve(P, err[..., None])[..., 0])


def fly(mode: Mode, filter_type: str, form: str, data: RunData) -> dict:
    """One combination on one run: ``{"nees": {"pos": [...], ...}, "nis": {figure:
    [sum, count, dof]}, "engine": ...}``, or ``{"error": "..."}`` when the navigator
    failed (its one-line message)."""
    from ..ins import error_model as em
    from ..navigator.navigator import InitialState, Navigator
    from ..navigator.system import initial_covariance

    truth = data.truth[mode.trajectory]
    try:
        system = system_for(mode, filter_type, form, data)
        phi0, dv0, dp0 = data.initial[mode.trajectory]
        C0 = ct.rotvec_to_dcm(-phi0) @ truth.C[0]
        P0 = initial_covariance(system, IMU_PERIOD_S,
                                np.asarray(INITIAL_ATTITUDE_ARCSEC) * _ARCSEC,
                                INITIAL_VELOCITY_MPS, INITIAL_POSITION_M)
        init = InitialState(float(truth.t[0]), ct.move_metric(truth.lla[:1], dp0[None])[0],
                            truth.vel[0] + dv0, ct.dcm_to_euler(C0), P0)
        nav = Navigator(system, init, IMU_PERIOD_S, record_rows=False,
                        record_covariance=False, innovations=True)
        for name in mode.sensors:
            t, ta, z = data.measurements[(name, mode.trajectory)]
            nav.add_measurements(name, t, z, t_arrival=ta)
        dth, dv = data.imu[mode.trajectory]
        nav.add_imu(truth.t[:-1], dtheta=dth, dv=dv)
        res = nav.result()
    except (FednavError, ValueError, ArithmeticError, np.linalg.LinAlgError) as e:
        return {"error": f"{type(e).__name__}: {e}".splitlines()[0]}
    n_per = int(round(FILTER_PERIOD_S / IMU_PERIOD_S))
    every = int(round(CHECK_PERIOD_S / FILTER_PERIOD_S))
    idx = np.arange(every, len(res.states), every)
    dp, dv, phi = _errors(res.states, truth, n_per, idx)
    s = em.SCALE[:9]
    P = res.P[idx][:, :9, :9] * np.outer(s, s)
    nees = {"att": _nees(phi, P[:, 0:3, 0:3]), "vel": _nees(dv, P[:, 3:6, 3:6]),
            "pos": _nees(dp, P[:, 6:9, 6:9])}
    if not all(np.all(np.isfinite(v)) for v in nees.values()):
        return {"error": "non-finite NEES (the covariance is singular)"}
    # (4 significant digits: what the averages need, a quarter of the stored size)
    return {"nees": {k: [float(f"{x:.4g}") for x in v] for k, v in nees.items()},
            "nis": _nis(mode, system, res), "engine": res.engine,
            # the health monitor's warnings (a false alarm where the filter is in band)
            "health": res.health(band=system.health.nis_band)}


def _nis(mode: Mode, system, res) -> dict:
    """NIS sums per sensor and row group: ``{figure: [sum, count, dof]}``."""
    from ..navigator.health import centralized_S

    groups = {}
    for name in mode.aiding:
        kinds = getattr(system.sensors[name].measurement_model(), "kinds", None)
        if kinds is None:
            groups[name] = {"model": None}
            continue
        g: dict = {}
        for r, k in enumerate(kinds):
            g.setdefault(_GROUPS[int(k)], []).append(r)
        groups[name] = g
    out: dict = {}
    for rec in res.innovations:
        S = centralized_S(rec.S, rec.R, rec.beta)
        r = np.asarray(rec.r, dtype=float)
        for grp, rows in groups[rec.local].items():
            sel = np.arange(len(r)) if rows is None else np.asarray(rows)
            v = r[sel]
            x = float(v @ np.linalg.solve(S[np.ix_(sel, sel)], v))
            # (a model that is not rows may have as many rows as its measurement holds,
            # raw GNSS satellites: counted per degree of freedom)
            acc = out.setdefault(f"{rec.local}.{grp}", [0.0, 0, 1 if rows is None
                                                        else len(sel)])
            acc[0] += x
            acc[1] += len(sel) if rows is None else 1
    if mode.constraint is not None:  # the constraint's updates, in the fault log
        # (logged scaled to the whole measurement: FederatedFilter.update's share)
        dof = 2
        acc = out.setdefault("airdata.constraint", [0.0, 0, dof])
        for entry in res.fdi:
            if entry[3] == dof and np.isfinite(entry[2]):
                acc[0] += float(entry[2])
                acc[1] += 1
    return out


def certify_unit(args) -> dict:
    """A unit of work: ``(seed, filter type, form, mode names, duration [s] or None)``
    -> ``{mode: fly(...)}`` on run ``seed``'s data."""
    seed, filter_type, form, names, duration = args
    data = run_data(int(seed), duration)
    by_name = {m.name: m for m in modes()}
    return {name: fly(by_name[name], filter_type, form, data) for name in names}


# ------------------------------------------------------------------ the campaign
#: Rough cost of one run of each filter type relative to ``kf`` (units are handed out
#: costliest first).
_COST = {"sghqf": 8.0, "pf": 6.0, "aasghqf": 4.0, "raukf": 2.5, "aekf": 2.0, "cukf": 1.5,
         "cekf": 1.5}


def settings() -> dict:
    """Everything that defines the certificate's runs (the campaign store's identity:
    a folder made with other settings is refused)."""
    from dataclasses import asdict

    return {"imu_period_s": IMU_PERIOD_S, "filter_period_s": FILTER_PERIOD_S,
            "check_period_s": CHECK_PERIOD_S, "lever_max_m": LEVER_MAX_M,
            "periods_s": list(PERIODS_S), "imu": IMU_SECTION,
            "initial": [list(INITIAL_ATTITUDE_ARCSEC), INITIAL_VELOCITY_MPS,
                        INITIAL_POSITION_M],
            "trajectories": {k: repr(v) for k, v in TRAJECTORIES.items()},
            "sensors": {k: repr(asdict(v)) for k, v in SETUP.items()}}


def units(runs: int, seed: int, filters=None, forms=None, mode_names=None,
          duration_s: float | None = None, runs_of: dict | None = None) -> list[tuple]:
    """The units of work (arguments of :func:`certify_unit`): one per run and filter
    type and form, run by run (a worker reuses a run's data; a certificate stopped early
    has as many runs of every combination), costliest first within a run.  ``filters``,
    ``forms``, ``mode_names``: subsets (None: all); ``runs_of``: fewer runs for some
    filter types (type -> runs, at most ``runs``)."""
    names = tuple(m.name for m in modes() if mode_names is None or m.name in mode_names)
    pairs = [(f, form) for f, form in filter_forms()
             if (filters is None or f in filters) and (forms is None or form in forms)]
    pairs.sort(key=lambda p: -_COST.get(p[0], 1.0) * (1.3 if p[1] == "square_root" else 1))
    runs_of = runs_of or {}
    return [(seed + i, f, form, names, duration_s) for i in range(runs)
            for f, form in pairs if i < min(runs, runs_of.get(f, runs))]


def run(runs: int = QUICK_RUNS, seed: int = 1, jobs: int = 1, filters=None, forms=None,
        mode_names=None, duration_s: float | None = None, campaign=None,
        progress=None, runs_of: dict | None = None) -> dict:
    """Fly the certificate's units (:func:`units`; resumably in ``campaign``, a
    :class:`~fednav.campaign.store.Campaign`; on ``jobs`` local processes or the
    campaign's Dask scheduler) and return :func:`certificate` of their results."""
    from .store import run_units

    args = units(runs, seed, filters, forms, mode_names, duration_s, runs_of)
    results = run_units(certify_unit, args, jobs=jobs, progress=progress, campaign=campaign)
    return certificate(args, results, runs, seed, duration_s)


def band(dof: float, coverage: float = COVERAGE) -> tuple[float, float]:
    """The two-sided ``coverage`` band of a chi-square variable of ``dof`` degrees of
    freedom divided by ``dof`` (a mean per degree of freedom)."""
    from ..core.stats import chi2_ppf

    a = 0.5 * (1.0 - coverage)
    return float(chi2_ppf(a, dof) / dof), float(chi2_ppf(1.0 - a, dof) / dof)


def _figure(name: str, value: float, dof: float, count: int, extra: dict | None = None):
    lo, hi = band(dof)
    return {"figure": name, "value": value, "low": lo, "high": hi, "dof": dof,
            "count": count, "inside": bool(lo <= value <= hi), **(extra or {})}


def certificate(args: list, results: list, runs: int, seed: int,
                duration_s: float | None = None) -> dict:
    """The certificate of units ``args`` and their ``results``: per combination its
    figures against their bands, its failed runs, and its verdict (``pass``,
    ``limitation`` with the documented reasons, or ``outside``)."""
    from .. import __version__

    acc: dict = {}
    for (s, f, form, names, _), res in zip(args, results, strict=True):
        for name in names:
            a = acc.setdefault((name, f, form), {"nees": {}, "nis": {}, "errors": [],
                                                 "engines": set(), "runs": 0,
                                                 "health": [], "health_runs": 0})
            a["runs"] += 1
            r = res[name]
            if "error" in r:
                a["errors"].append({"seed": s, "error": r["error"]})
                continue
            a["engines"].add(r["engine"])
            if "health" in r:  # (not in units stored before the monitor flew along)
                a["health_runs"] += 1
                if r["health"]:
                    a["health"].append({"seed": s, "warnings": r["health"][:3]})
            for k, v in r["nees"].items():
                a["nees"].setdefault(k, []).append(v)
            for k, (total, count, dof) in r["nis"].items():
                t = a["nis"].setdefault(k, [0.0, 0, dof])
                t[0] += total
                t[1] += count
    by_mode = {m.name: m for m in modes()}
    combos = []
    for (name, f, form), a in acc.items():
        figures = []
        for k in ("pos", "vel", "att"):
            v = np.asarray(a["nees"].get(k, []), dtype=float)
            if not v.size:
                continue
            n = v.shape[0]
            per_epoch = v.mean(axis=0) / 3.0
            lo, hi = band(3.0 * n)
            figures.append(_figure(f"nees.{k}", float(per_epoch.mean()), 3.0 * n, n, {
                "epochs_in_band": float(np.mean((per_epoch >= lo) & (per_epoch <= hi))),
                "worst_epoch": float(per_epoch.max())}))
        for k, (total, count, dof) in a["nis"].items():
            if count:
                figures.append(_figure(f"nis.{k}", total / (count * dof), count * dof, count))
        problems = [x["figure"] for x in figures if not x["inside"]]
        if a["errors"]:
            problems.append("error")
        reasons = {}
        for p in problems:
            lim = limitation(f, form, name, p)
            reasons[p] = None if lim is None else lim.reason
        verdict = ("pass" if not problems else "limitation"
                   if all(v is not None for v in reasons.values()) else "outside")
        combos.append({"mode": name, "trajectory": by_mode[name].trajectory,
                       "sensors": list(by_mode[name].sensors), "filter": f, "form": form,
                       "runs": a["runs"], "failed_runs": len(a["errors"]),
                       "errors": a["errors"][:5], "engine": "/".join(sorted(a["engines"])),
                       "health_runs": a["health_runs"],
                       "health_warned_runs": len(a["health"]),
                       "health_warnings": a["health"][:3],
                       "figures": figures, "verdict": verdict, "reasons": reasons})
    order = {m: i for i, m in enumerate(by_mode)}
    forder = {p: i for i, p in enumerate(filter_forms())}
    combos.sort(key=lambda c: (forder.get((c["filter"], c["form"]), 99),
                               order.get(c["mode"], 99)))
    counts = {v: sum(c["verdict"] == v for c in combos) for v in ("pass", "limitation",
                                                                   "outside")}
    n_fig = sum(len(c["figures"]) for c in combos)
    return {"fednav_version": __version__, "runs": runs, "seed": seed,
            "duration_s": duration_s, "coverage": COVERAGE, "settings": settings(),
            "uncertified_sensors": uncertified_sensors(), "verdicts": counts,
            "figures": n_fig,
            "figures_outside": sum(not x["inside"] for c in combos for x in c["figures"]),
            "combinations": combos}


# ------------------------------------------------------------------------ outputs
def _fmt(x: dict, band_too: bool = True) -> str:
    mark = "" if x["inside"] else " !"
    if not band_too:
        return f"{x['value']:.3f}{mark}"
    return f"{x['value']:.3f} [{x['low']:.3f}, {x['high']:.3f}]{mark}"


def rows(cert: dict) -> list[list[str]]:
    """The certificate as table rows: mode, filter, form, runs (failed), NEES pos, vel,
    att (per dof; their band), NIS per sensor and rows (per dof [band]), verdict."""
    out = []
    for c in cert["combinations"]:
        fig = {x["figure"]: x for x in c["figures"]}
        nees = [fig.get(f"nees.{k}") for k in ("pos", "vel", "att")]
        b = next((x for x in nees if x is not None), None)
        nis = "; ".join(f"{x['figure'][4:]} {_fmt(x)}" for x in c["figures"]
                        if x["figure"].startswith("nis."))
        runs = f"{c['runs']}" + (f" ({c['failed_runs']} failed)" if c["failed_runs"] else "")
        out.append([c["mode"], c["filter"], c["form"], runs,
                    *["—" if x is None else _fmt(x, False) for x in nees],
                    "—" if b is None else f"[{b['low']:.2f}, {b['high']:.2f}]", nis,
                    c["verdict"]])
    return out


HEADER = ["mode", "filter", "form", "runs", "NEES pos", "NEES vel", "NEES att",
          "NEES band", "NIS per dof [band]", "verdict"]


def markdown(cert: dict) -> str:
    """``certificate.md``: the table, then every combination outside its band with the
    figures outside and the reason (or "no documented reason: a defect")."""
    n = cert["runs"]
    lines = [f"# fednav consistency certificate (up to {n} runs per combination: the "
             f"runs column; seeds from {cert['seed']})", "",
             f"fednav {cert['fednav_version']}; chi-square {cert['coverage']:.0%} "
             f"two-sided bands; {cert['figures']} figures, {cert['figures_outside']} "
             f"outside; combinations: " + ", ".join(f"{v} {k}" for k, v in
                                                    cert["verdicts"].items()) + ".", "",
             "Figures are per degree of freedom (1 for a consistent filter); `!` marks a "
             "figure outside its band.  docs/certificate.md says what each one is.", ""]
    if cert["uncertified_sensors"]:
        lines += [f"Registered sensors without a measurement equation here (not "
                  f"certified): {', '.join(cert['uncertified_sensors'])}.", ""]
    lines += ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    lines += ["| " + " | ".join(r) + " |" for r in rows(cert)]
    bad = [c for c in cert["combinations"] if c["verdict"] != "pass"]
    if bad:
        lines += ["", "## Outside their bands", ""]
        for c in bad:
            lines.append(f"* **{c['mode']} / {c['filter']} / {c['form']}** ({c['verdict']})")
            for p, why in c["reasons"].items():
                fig = next((x for x in c["figures"] if x["figure"] == p), None)
                what = (f"{p} = {_fmt(fig)}" if fig is not None else
                        f"{c['failed_runs']} of {c['runs']} runs failed: "
                        f"{c['errors'][0]['error'] if c['errors'] else ''}")
                lines.append(f"  * {what} — {why or 'no documented reason: a defect'}")
    passed = [c for c in cert["combinations"] if c["verdict"] == "pass"]
    warned = [c for c in passed if c.get("health_warned_runs")]
    lines += ["", "## The health monitor", "",
              f"Runs of the {len(passed)} combinations in band with a health warning (a "
              f"false alarm): {sum(c['health_warned_runs'] for c in warned)} of "
              f"{sum(c.get('health_runs', 0) for c in passed)} flown with the monitor."]
    for c in warned:
        w = c["health_warnings"][0]
        lines.append(f"* {c['mode']} / {c['filter']} / {c['form']}: "
                     f"{c['health_warned_runs']} runs; seed {w['seed']}: {w['warnings'][0]}")
    return "\n".join(lines) + "\n"


def write(cert: dict, out) -> list:
    """Write ``certificate.json`` and ``certificate.md`` into folder ``out``."""
    from pathlib import Path

    from ..core.atomic import json_safe, write_json, write_text

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "certificate.json", json_safe(cert))
    write_text(out / "certificate.md", markdown(cert))
    return [out / "certificate.json", out / "certificate.md"]


def print_table(cert: dict, console) -> None:
    """The certificate as a rich table on ``console``, then the combinations outside."""
    from rich.markup import escape
    from rich.table import Table

    tab = Table(title=f"consistency certificate: {cert['runs']} runs per combination, "
                      f"{cert['coverage']:.0%} chi-square bands (per dof)")
    for h in HEADER:
        tab.add_column(h, justify="left" if h in ("mode", "filter", "form", "verdict",
                                                    "NIS per dof [band]") else "right")
    colour = {"pass": "green", "limitation": "yellow", "outside": "red"}
    for r in rows(cert):
        tab.add_row(*[escape(x) for x in r[:-1]], f"[{colour[r[-1]]}]{r[-1]}[/]")
    console.print(tab)
    for c in cert["combinations"]:
        if c["verdict"] == "pass":
            continue
        for p, why in c["reasons"].items():
            console.print(f"[{colour[c['verdict']]}]{escape(c['mode'])} / {c['filter']} / "
                          f"{c['form']}: {escape(p)}[/] — "
                          f"{escape(why or 'no documented reason: a defect')}")
    v = cert["verdicts"]
    console.print(f"{v['pass']} combinations in band, {v['limitation']} outside with a "
                  f"documented limitation, {v['outside']} outside without one")

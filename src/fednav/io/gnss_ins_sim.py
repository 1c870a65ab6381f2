"""gnss-ins-sim output folders -> fednav data.

gnss-ins-sim (Aceinna, https://github.com/Aceinna/gnss-ins-sim) writes what one
simulation made into a folder of CSV files (``Sim.results(data_dir)``), one file per
quantity: ``NAME.csv`` for what every run shares (the reference and the time stamps) and
``NAME-K.csv`` for run ``K``'s sensor data (``accel-0.csv``, ``accel-1.csv`` ...).  Each
file has one header line, a column name and its unit in parentheses per column
(``gyro_x (deg/s)``), then ``numpy.savetxt`` rows.

Its conventions: navigation frame NED (``ref_frame=0``; the virtual inertial frame of
``ref_frame=1`` is refused: no Earth rotation, positions in metres), body frame
forward-right-down (FRD), Euler angles ``[yaw, pitch, roll]`` of the ZYX sequence (NED ->
FRD), positions latitude, longitude and height above the WGS-84 ellipsoid.  Vectors
convert with :data:`~fednav.io.navego.FRD_TO_RFU`, attitudes as NaveGo's
(:func:`~fednav.io.navego.navego_euler_to_fednav`).  Units are read from the headers and
converted (:data:`UNITS`); a unit not listed there is a one-line :class:`DataError`.

Files -> fednav (run ``K``):

* ``time.csv`` (the IMU's time stamps [s]), ``accel-K.csv`` (specific force, FRD),
  ``gyro-K.csv`` (angular rate, FRD) -> ``imu``.  gnss-ins-sim samples the rates at the
  start of each interval and holds them over it (its trajectory is integrated forward
  with them), fednav's convention.
* ``gps-K.csv`` (latitude, longitude, height, NED velocity) at ``gps_time.csv`` -> the
  ``gnss`` series, the epochs ``gps_visibility.csv`` marks 0 (no satellites in the
  motion definition) left out.  gnss-ins-sim writes no accuracy: the 1-sigma is the RMS
  of the fixes minus its error-free ``ref_gps.csv`` where the folder has it (per ENU
  axis, positions in metres), else its built-in GPS profile (:data:`GPS_DEFAULT`) is
  assumed, with a note.
* ``odo-K.csv`` (forward speed [m/s], at ``time.csv``) -> the ``odometer`` series
  (gnss-ins-sim scales it by an odometer scale factor it does not write, default 0.99;
  with ``ref_odo.csv`` the scale and the noise against it are in ``quality``).
* ``mag-K.csv`` (field, FRD, uT; at ``time.csv``) -> the ``mag`` series (tesla, RFU);
  with the reference attitude, the field's declination and inclination in ``quality``.
* ``ref_pos.csv``, ``ref_vel.csv`` (NED), ``ref_att_euler.csv`` at ``time.csv`` -> ``ref``.

gnss-ins-sim writes no IMU error figures (its IMU model lives in the script that ran
it): ``imu.errors`` is None and a note says so; :data:`IMU_PROFILES` holds its built-in
profiles as fednav ``imu:`` sections.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import attitude as att
from ..core import earth, units
from .data import DataError, GnssData, ImuData, Reference
from .navego import FRD_TO_RFU, navego_euler_to_fednav
from .sensorfile import SensorData

#: Units gnss-ins-sim writes (and a few more), by the kind of quantity a column holds:
#: the converter into SI.  Tesla for magnetic fields.
UNITS: dict[str, dict] = {
    "time": {"sec": None, "s": None},
    "angle": {"deg": units.deg, "rad": None},
    "rate": {"deg/s": units.deg, "rad/s": None, "deg/hr": units.deg_per_h,
             "deg/h": units.deg_per_h},
    "accel": {"m/s^2": None, "m/s/s": None, "m/s2": None, "g": units.g, "mg": units.milli_g},
    "length": {"m": None},
    "speed": {"m/s": None},
    "field": {"uT": lambda x: np.multiply(x, 1e-6), "nT": lambda x: np.multiply(x, 1e-9),
              "T": None, "gauss": lambda x: np.multiply(x, 1e-4)},
    "flag": {"": None},
}

#: gnss-ins-sim's built-in GPS error profile (``imu_model.gps_low_accuracy``, what
#: ``IMU(gps=True)`` uses without ``gps_opt``): position 1-sigma [north, east, down] m,
#: velocity 1-sigma m/s per axis; assumed when the folder has no ``ref_gps.csv``.
GPS_DEFAULT = {"stdp_ned_m": (5.0, 5.0, 7.0), "stdv_mps": 0.05}

#: gnss-ins-sim's built-in IMU profiles (``imu_model.py``: ``IMU(accuracy=...)``) as
#: fednav ``imu:`` sections: its constant bias ``b`` (zero in all three), the bias
#: instability ``b_drift`` (a first-order Gauss–Markov steady-state 1-sigma, correlation
#: time ``b_corr``) and the white noise ``arw`` / ``vrw``.
IMU_PROFILES: dict[str, dict[str, float]] = {
    name: {"gyro_bias_deg_h": 0.0, "gyro_markov_deg_h": gm, "gyro_markov_tau_s": 100.0,
           "gyro_arw_deg_sqrt_h": arw, "accel_bias_mps2": 0.0, "accel_markov_mps2": am,
           "accel_markov_tau_s": 100.0, "accel_vrw_mps_sqrt_s": vrw / 60.0}
    for name, gm, arw, am, vrw in (
        # (gyro b_drift [deg/h], arw [deg/sqrt(h)], accel b_drift [m/s^2],
        #  vrw [m/s/sqrt(h)])
        ("low-accuracy", 10.0, 0.75, 2.0e-4, 0.05),
        ("mid-accuracy", 3.5, 0.25, 5.0e-5, 0.03),
        ("high-accuracy", 0.1, 2.0e-3, 3.6e-6, 2.5e-5))}

_HEADER = re.compile(r"^\s*(.*?)\s*\(([^()]*)\)\s*$")


@dataclass
class GnssInsSimRecording:
    """What a gnss-ins-sim folder holds for one run, in fednav's frames and units.

    ``imu`` (body RFU; ``errors`` None: the folder has no IMU figures); ``series`` every
    sensor's series by registered name (``gnss``, and ``odometer``, ``mag`` when the
    folder has them): what :func:`fednav.process.process` takes; ``ref`` the true
    trajectory (ENU, ``[pitch, roll, heading]``) or None; ``run`` the run read and
    ``runs`` those in the folder; ``quality`` what the reader did and found (keys in
    :func:`read_gnss_ins_sim`); ``notes`` what it assumed or left out, one line each."""

    source: str
    imu: ImuData
    series: dict
    ref: Reference | None
    run: int = 0
    runs: list[int] = field(default_factory=list)
    quality: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def gnss(self) -> GnssData | None:
        """The GNSS series, or None."""
        return self.series.get("gnss")


class _Folder:
    """A gnss-ins-sim folder: its CSV files read with their units converted."""

    def __init__(self, folder: Path):
        self.path = folder
        self.src = str(folder)
        self.files: set[str] = set()  # (the files read)

    def has(self, name: str) -> bool:
        return (self.path / name).is_file()

    def read(self, name: str, kinds: tuple[str, ...]) -> np.ndarray:
        """File ``name``'s columns (N, len(kinds)) in SI, each converted by the unit its
        header gives for its kind (a time, an angle ...)."""
        p = self.path / name
        src = f"gnss-ins-sim file {p}"
        self.files.add(name)
        try:
            with p.open() as f:
                head = f.readline()
        except OSError as e:
            raise DataError(f"{src}: cannot be read ({e.strerror})") from None
        cols = head.rstrip("\r\n").split(",")
        if len(cols) != len(kinds):
            raise DataError(f"{src}: {len(cols)} columns in the header '{head.strip()}', "
                            f"expected {len(kinds)}")
        convert = []
        for col, kind in zip(cols, kinds, strict=True):
            m = _HEADER.match(col)
            if m is None:
                raise DataError(f"{src}: column '{col.strip()}' has no unit in parentheses "
                                f"(gnss-ins-sim writes 'name (unit)')")
            unit = m.group(2).strip()
            known = UNITS[kind]
            if unit not in known:
                raise DataError(f"{src}: column '{m.group(1)}' has the unit '{unit}', "
                                f"unknown for {'a' if kind != 'angle' else 'an'} {kind} "
                                f"(known: {', '.join(repr(u) for u in known)})")
            convert.append(known[unit])
        try:
            a = np.loadtxt(p, delimiter=",", skiprows=1, ndmin=2, dtype=float)
        except ValueError as e:
            raise DataError(f"{src}: not numeric ({str(e).splitlines()[0]})") from None
        if not a.size:
            raise DataError(f"{src}: no data rows after the header")
        if a.shape[1] != len(kinds):
            raise DataError(f"{src}: rows of {a.shape[1]} values, expected {len(kinds)}")
        for j, c in enumerate(convert):
            if c is not None:
                a[:, j] = c(a[:, j])
        return a

    def position_units(self, name: str) -> list[str]:
        """The units of a position file's header (to tell LLA from x/y/z in metres)."""
        with (self.path / name).open() as f:
            head = f.readline()
        return [m.group(2).strip() if (m := _HEADER.match(c)) else ""
                for c in head.rstrip("\r\n").split(",")]


def _runs(folder: Path) -> list[int]:
    """The runs whose accelerometer and gyro files the folder holds."""
    out = []
    for p in folder.glob("accel-*.csv"):
        k = p.stem.split("-", 1)[1]
        if k.isdigit() and (folder / f"gyro-{k}.csv").is_file():
            out.append(int(k))
    return sorted(out)


def _check_frame(d: _Folder, run: int) -> None:
    """A one-line :class:`DataError` for gnss-ins-sim's virtual inertial frame."""
    frame1 = False
    if d.has("summary.txt"):
        text = (d.path / "summary.txt").read_text(errors="replace")
        frame1 = re.search(r"Reference frame:\s*1\b", text) is not None
    for name in ("ref_pos.csv", f"gps-{run}.csv", "ref_gps.csv"):
        if d.has(name) and d.position_units(name)[:1] == ["m"]:
            frame1 = True
    if frame1:
        raise DataError(f"gnss-ins-sim folder {d.src}: simulated in its virtual inertial "
                        f"frame (ref_frame=1: positions x/y/z in metres, no Earth "
                        f"rotation in the gyro), which fednav's navigation equations do not "
                        f"describe; simulate with ref_frame=0 (NED)")


def _imu(d: _Folder, run: int, max_bridge_s: float, quality: dict) -> tuple:
    t = d.read("time.csv", ("time",))[:, 0]
    acc = d.read(f"accel-{run}.csv", ("accel",) * 3)
    gyr = d.read(f"gyro-{run}.csv", ("rate",) * 3)
    for name, a in ((f"accel-{run}.csv", acc), (f"gyro-{run}.csv", gyr)):
        if len(a) != len(t):
            raise DataError(f"gnss-ins-sim file {d.path / name}: {len(a)} rows but "
                            f"time.csv has {len(t)}")
    imu = ImuData(f"{d.src}:gyro-{run},accel-{run}", t, gyr @ FRD_TO_RFU.T,
                  acc @ FRD_TO_RFU.T, max_bridge_s=max_bridge_s)
    quality.update(imu.quality)
    quality["imu_rate_hz"] = round(1.0 / imu.period(), 6)
    return imu, t


def _rms(a: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(np.square(a), axis=0))


def _tidy(x) -> list[float]:
    """Figures to 3 significant digits (what an RMS over a few hundred samples says)."""
    return [float(f"{v:.3g}") for v in np.atleast_1d(x)]


def _gnss(d: _Folder, run: int, quality: dict, notes: list) -> GnssData | None:
    name = f"gps-{run}.csv"
    if not d.has(name):
        notes.append(f"gnss: no {name}: no GNSS (a simulation with gps=False)")
        return None
    if not d.has("gps_time.csv"):
        raise DataError(f"gnss-ins-sim folder {d.src}: {name} but no gps_time.csv (the "
                        f"GPS epochs' times)")
    t = d.read("gps_time.csv", ("time",))[:, 0]
    g = d.read(name, ("angle", "angle", "length", "speed", "speed", "speed"))
    if len(g) != len(t):
        raise DataError(f"gnss-ins-sim file {d.path / name}: {len(g)} rows but "
                        f"gps_time.csv has {len(t)}")
    seen = np.ones(len(t), dtype=bool)
    if d.has("gps_visibility.csv"):
        vis = d.read("gps_visibility.csv", ("flag",))[:, 0]
        if len(vis) == len(t):
            seen = vis > 0.5
        else:
            notes.append(f"gnss: gps_visibility.csv has {len(vis)} rows, gps_time.csv "
                         f"{len(t)}: not used (every epoch taken as visible)")
    else:
        notes.append("gnss: no gps_visibility.csv: every epoch taken as visible")
    quality["gnss_epochs_invisible"] = int((~seen).sum())
    if seen.sum() < 2:
        notes.append(f"gnss: {int(seen.sum())} visible epochs in {name}: not used")
        return None
    vel = g[:, 3:6] @ FRD_TO_RFU.T  # (NED -> ENU: the same matrix)
    sig_p = sig_v = None
    if d.has("ref_gps.csv"):
        r = d.read("ref_gps.csv", ("angle", "angle", "length", "speed", "speed", "speed"))
        if len(r) == len(t):
            s = seen
            dp = earth.llh_difference_enu(g[s, 0], g[s, 1], g[s, 2], r[s, 0], r[s, 1],
                                          r[s, 2])
            dv = vel[s] - r[s, 3:6] @ FRD_TO_RFU.T
            # (an error-free simulated GPS: a millimetre, a millimetre per second)
            sig_p = _tidy(np.maximum(_rms(dp), 1e-3))
            sig_v = _tidy(np.maximum(_rms(dv), 1e-3))
            quality["gnss_sigma_from"] = "ref_gps"
            notes.append(f"gnss: 1-sigma from the RMS of {name} minus ref_gps.csv (the "
                         f"simulator's error-free GPS): position east/north/up {sig_p} m, "
                         f"velocity {sig_v} m/s")
        else:
            notes.append(f"gnss: ref_gps.csv has {len(r)} rows, gps_time.csv {len(t)}: "
                         f"not used")
    if sig_p is None:
        n, e, dd = GPS_DEFAULT["stdp_ned_m"]
        sig_p, sig_v = [e, n, dd], [GPS_DEFAULT["stdv_mps"]] * 3
        quality["gnss_sigma_from"] = "assumed"
        notes.append(f"gnss: gnss-ins-sim writes no GPS accuracy and the folder has no "
                     f"usable ref_gps.csv: its built-in profile assumed (position "
                     f"east/north/up {sig_p} m, velocity {sig_v[0]} m/s); give sensors.gnss "
                     f"sigma_pos_enu_m / sigma_vel_mps if the simulation set gps_opt")
    quality.update(gnss_sigma_pos_enu_m=sig_p, gnss_sigma_vel_mps=sig_v)
    out = GnssData(f"{d.src}:{name}", t[seen], g[seen, :3], vel[seen], np.array(sig_p),
                   np.array(sig_v), np.zeros(3))
    quality.update(out.quality)
    return out


def _odometer(d: _Folder, run: int, t: np.ndarray, quality: dict,
              notes: list) -> SensorData | None:
    name = f"odo-{run}.csv"
    if not d.has(name):
        return None
    v = d.read(name, ("speed",))[:, 0]
    if len(v) != len(t):
        notes.append(f"odometer: {name} has {len(v)} rows, time.csv {len(t)}: not used")
        return None
    if d.has("ref_odo.csv"):
        r = d.read("ref_odo.csv", ("speed",))[:, 0]
        if len(r) == len(v) and np.any(np.abs(r) > 0.5):
            m = np.abs(r) > 0.5
            scale = float(r[m] @ v[m] / (r[m] @ r[m]))
            quality["odometer_scale_vs_ref"] = _tidy(scale)[0]
            quality["odometer_noise_rms_mps"] = _tidy(_rms(v[m] - scale * r[m]))[0]
    notes.append("odometer: gnss-ins-sim scales its odometer by a factor it does not write "
                 "(its default 0.99; 'odometer_scale_vs_ref' in quality when the folder has "
                 "ref_odo.csv): give sensors.odometer.scale (or auto) and sigma_mps")
    return SensorData("odometer", f"{d.src}:{name}", t, v[:, None],
                      quality={"odometer_rows": len(v)})


def _mag(d: _Folder, run: int, t: np.ndarray, ref: Reference | None, quality: dict,
         notes: list) -> SensorData | None:
    name = f"mag-{run}.csv"
    if not d.has(name):
        return None
    b = d.read(name, ("field",) * 3)
    if len(b) != len(t):
        notes.append(f"mag: {name} has {len(b)} rows, time.csv {len(t)}: not used")
        return None
    b = b @ FRD_TO_RFU.T
    if ref is not None and ref.euler is not None and len(ref.t) == len(t):
        # the field in ENU through the true attitude: its direction (the simulator's WMM
        # field at the start: declination from true north, dip below the horizon)
        bn = np.einsum("nij,nj->ni", att.euler_to_dcm(ref.euler), b)
        bn = np.median(bn, axis=0)
        quality["mag_declination_deg"] = _tidy(np.degrees(np.arctan2(bn[0], bn[1])))[0]
        quality["mag_inclination_deg"] = _tidy(np.degrees(np.arctan2(
            -bn[2], np.hypot(bn[0], bn[1]))))[0]
        notes.append(f"mag: declination {quality['mag_declination_deg']} deg and "
                     f"inclination {quality['mag_inclination_deg']} deg from {name} turned "
                     f"by the reference attitude")
    return SensorData("mag", f"{d.src}:{name}", t, b, quality={"mag_rows": len(b)})


def _reference(d: _Folder, t: np.ndarray, quality: dict, notes: list) -> Reference | None:
    missing = [n for n in ("ref_pos.csv", "ref_vel.csv") if not d.has(n)]
    if missing:
        notes.append(f"reference: no {' or '.join(missing)}: no reference")
        return None
    pos = d.read("ref_pos.csv", ("angle", "angle", "length"))
    vel = d.read("ref_vel.csv", ("speed",) * 3) @ FRD_TO_RFU.T
    euler = None
    if d.has("ref_att_euler.csv"):
        ypr = d.read("ref_att_euler.csv", ("angle",) * 3)
        euler = navego_euler_to_fednav(ypr[:, 2], ypr[:, 1], ypr[:, 0])
    else:
        notes.append("reference: no ref_att_euler.csv: no reference attitude")
    for name, a in (("ref_pos.csv", pos), ("ref_vel.csv", vel),
                    ("ref_att_euler.csv", euler)):
        if a is not None and len(a) != len(t):
            raise DataError(f"gnss-ins-sim file {d.path / name}: {len(a)} rows but "
                            f"time.csv has {len(t)}")
    ref = Reference(f"{d.src}:ref_pos,ref_vel,ref_att_euler", t, pos, vel, euler)
    quality["reference_rows_skipped"] = ref.quality["reference_rows_skipped"]
    return ref


def read_gnss_ins_sim(folder, *, run: int = 0, max_bridge_s: float = 0.1,
                      mounting=None) -> GnssInsSimRecording:
    """Read run ``run`` of a gnss-ins-sim output folder (module docstring).

    Parameters
    ----------
    folder : str or Path
        The folder ``Sim.results(data_dir)`` wrote.
    run : int
        Which simulation run (``accel-RUN.csv``, ``gyro-RUN.csv`` ...).
    max_bridge_s : float
        The longest run of faulty IMU samples bridged [s] (:class:`~fednav.io.ImuData`).
    mounting : str or dict, optional
        The IMU's axes in the body when they are not gnss-ins-sim's FRD (axis letters or
        ``{euler_deg: [pitch, roll, heading]}``, :mod:`fednav.core.mounting`).

    Returns
    -------
    GnssInsSimRecording
        ``quality``: ``run``, ``runs``, ``imu_rate_hz`` and ImuData's checks;
        ``gnss_epochs_invisible`` (``gps_visibility`` 0), ``gnss_epochs_skipped``,
        ``gnss_sigma_from`` ('ref_gps' or 'assumed'), ``gnss_sigma_pos_enu_m``,
        ``gnss_sigma_vel_mps``; ``odometer_scale_vs_ref``, ``odometer_noise_rms_mps``;
        ``mag_declination_deg``, ``mag_inclination_deg``; ``reference_rows_skipped``;
        ``files`` the files read.

    Raises
    ------
    DataError
        One line: a folder that is missing or not gnss-ins-sim output (naming the files
        it lacks), a run it does not hold, a unit not in :data:`UNITS`, the virtual
        inertial frame, files whose rows disagree.
    """
    path = Path(folder)
    if not path.is_dir():
        raise DataError(f"gnss-ins-sim folder {path}: "
                        f"{'is a file, not a folder' if path.is_file() else 'not found'}")
    d = _Folder(path)
    runs = _runs(path)
    if not d.has("time.csv") or not runs:
        need = [n for n in ("time.csv", "accel-0.csv", "gyro-0.csv")
                if not (n != "time.csv" and runs) and not d.has(n)]
        raise DataError(f"{path}: not a gnss-ins-sim output folder: no "
                        f"{', '.join(need)} (gnss-ins-sim writes time.csv and "
                        f"accel-K.csv, gyro-K.csv per run K)")
    if run not in runs:
        missing = " and ".join(n for n in (f"accel-{run}.csv", f"gyro-{run}.csv")
                               if not d.has(n))
        raise DataError(f"gnss-ins-sim folder {path}: no {missing} (run {run}; the folder "
                        f"holds run{'s' if len(runs) > 1 else ''} "
                        f"{', '.join(map(str, runs))})")
    _check_frame(d, run)
    quality: dict = {"run": run, "runs": runs}
    notes: list[str] = []
    imu, t = _imu(d, run, max_bridge_s, quality)
    imu.mounting, imu.mounting_name = FRD_TO_RFU, "FRD"
    if mounting is not None:
        imu = imu.remount(mounting)
    notes.append("imu: gnss-ins-sim writes no IMU error figures (its IMU model is in the "
                 "script that ran it): give them in imu: (its built-in profiles: "
                 "fednav.io.gnss_ins_sim.IMU_PROFILES)")
    ref = _reference(d, t, quality, notes)
    series = {}
    for name, s in (("gnss", _gnss(d, run, quality, notes)),
                    ("odometer", _odometer(d, run, t, quality, notes)),
                    ("mag", _mag(d, run, t, ref, quality, notes))):
        if s is not None:
            series[name] = s
    quality["files"] = sorted(d.files)
    return GnssInsSimRecording(str(path), imu, series, ref, run, runs, quality, notes)

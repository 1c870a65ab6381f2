"""RINEX observation and navigation files (GPS), through ``georinex``.

:func:`read_rinex_obs` gives a receiver's raw observations — pseudorange, carrier phase,
Doppler and C/N0 per epoch and satellite — and :func:`read_rinex_nav` the broadcast
ephemerides (GPS LNAV) with the Klobuchar ionosphere coefficients of the header.  Times
are GPS time in seconds since the GPS epoch (1980-01-06 00:00:00, no leap seconds):
``t % 604800`` is the time of week.  Only GPS satellites (``Gnn``) are kept; a file
with none is one line.

``georinex`` (RINEX 2.x and 3.x, observation and navigation) was chosen over a reader
of fednav's own: on the static stations of ``../shared/data/rinex-static`` (1 h at 30 s,
11 and 12 satellites) it reads an observation file in 0.02 s and a navigation file in
0.01 s (the first read of a process also imports georinex and xarray: 0.4 s); a day at
30 s (2 880 epochs of 10 satellites, 2 MB, written by :func:`write_rinex_obs`) in
0.17 s, 0.58x the time ``fednav process`` takes for the 600 s car drive of
``examples/car-drive.yaml`` in the same run (``benchmarks/rinex_read.py``).
:func:`write_rinex_obs` writes RINEX 2.11 observation files (simulated receivers,
tests).
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from ..core.atomic import write_text
from ..core.errors import DataError
from ..sensors import satellites
from ..sensors.satellites import Ephemerides
from .data import import_for

#: The GPS epoch (GPS time 0).
GPS_EPOCH = np.datetime64("1980-01-06T00:00:00", "ns")
#: Seconds in a GPS week.
WEEK_S = 604800.0


def gps_seconds(times) -> np.ndarray:
    """GPS time [s since the GPS epoch] of ``datetime64`` stamps in GPS time."""
    return (np.asarray(times, dtype="datetime64[ns]") - GPS_EPOCH) / np.timedelta64(1, "s")


@dataclass
class RinexObs:
    """A receiver's observations: ``t`` (N,) GPS time [s], ``sv`` (M,) satellite ids
    (``G01`` ...), ``obs`` the observation codes' values (N, M) (``C1``/``P2``/``C1C``
    pseudoranges [m], ``L1`` carrier phases [cycles], ``D1`` Dopplers [Hz], ``S1`` C/N0
    [dB-Hz]; NaN where a satellite was not observed), the header's approximate antenna
    position ``approx_xyz`` (3,) ECEF [m] (None if absent)."""

    source: str
    t: np.ndarray
    sv: np.ndarray
    obs: dict[str, np.ndarray] = field(default_factory=dict)
    approx_xyz: np.ndarray | None = None

    def code(self, *names: str) -> np.ndarray:
        """The first of the codes ``names`` the file has (N, M): ``code("C1", "C1C")`` for
    the L1 C/A pseudorange of a RINEX 2 or 3 file."""
        for n in names:
            if n in self.obs:
                return self.obs[n]
        raise DataError(f"{self.source}: none of the observation codes {', '.join(names)} "
                        f"(the file has {', '.join(self.obs) or 'none'})")


#: georinex's name of each ephemeris element.
_ELEMENTS = {"af0": "SVclockBias", "af1": "SVclockDrift", "af2": "SVclockDriftRate",
             "crs": "Crs", "delta_n": "DeltaN", "m0": "M0", "cuc": "Cuc", "e": "Eccentricity",
             "cus": "Cus", "sqrt_a": "sqrtA", "cic": "Cic", "omega0": "Omega0", "cis": "Cis",
             "i0": "Io", "crc": "Crc", "omega": "omega", "omega_dot": "OmegaDot",
             "idot": "IDOT", "tgd": "TGD", "health": "health", "week": "GPSWeek",
             "toe_sow": "Toe"}


def _load(path, what: str):
    gr = import_for(path, "georinex", f"RINEX {what}", extra="gnss")
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{path}: no such file")
    with warnings.catch_warnings():  # (georinex's own FutureWarnings of xarray)
        warnings.simplefilter("ignore", FutureWarning)
        try:
            return gr.load(p, use="G")
        except Exception as e:  # noqa: BLE001  (georinex raises many kinds)
            raise DataError(f"{path}: not a RINEX {what} file georinex reads "
                            f"({type(e).__name__}: {e})") from None


def read_rinex_obs(path) -> RinexObs:
    """A RINEX 2.x/3.x observation file's GPS observations.

    Parameters
    ----------
    path : str or Path
        The observation file (``.05o``, ``.rnx``; Hatanaka-compressed files as georinex
        reads them).

    Returns
    -------
    RinexObs
        Times in GPS time [s], pseudoranges [m], phases [cycles], Dopplers [Hz].

    Raises
    ------
    DataError
        One line: no file, not RINEX, or no GPS satellite.
    """
    ds = _load(path, "observation")
    sv = np.asarray(ds.sv.values).astype(str)
    keep = np.char.startswith(sv, "G")
    if not keep.any():
        raise DataError(f"{path}: no GPS satellite in the observation file")
    t = gps_seconds(ds.time.values)
    obs = {str(k): np.asarray(ds[k].values, dtype=float)[:, keep] for k in ds.data_vars
           if ds[k].dims == ("time", "sv")}
    pos = ds.attrs.get("position")
    return RinexObs(str(path), t, sv[keep], obs,
                    None if pos is None else np.asarray(pos, dtype=float))


def read_rinex_nav(path) -> Ephemerides:
    """A RINEX 2.x/3.x navigation file's GPS broadcast ephemerides.

    Parameters
    ----------
    path : str or Path
        The navigation file (``.05n``, ``.rnx``).

    Returns
    -------
    Ephemerides
        One row per (satellite, record); the header's Klobuchar coefficients.

    Raises
    ------
    DataError
        One line: no file, not RINEX, no GPS ephemeris, or elements missing.
    """
    ds = _load(path, "navigation")
    if "sqrtA" not in ds:
        raise DataError(f"{path}: no GPS ephemeris in the navigation file")
    rows = ds.to_dataframe().dropna(subset=["sqrtA"]).reset_index()
    # (georinex names a satellite's records of a repeated epoch G05_1 ...: the same one)
    rows["sv"] = rows["sv"].astype(str).str[:3]
    rows = rows[rows["sv"].astype(str).str.startswith("G")]
    if not len(rows):
        raise DataError(f"{path}: no GPS ephemeris in the navigation file")
    el = {k: rows[v].to_numpy(dtype=float) for k, v in _ELEMENTS.items() if v in rows}
    missing = sorted(set(_ELEMENTS) - set(el) - {"tgd", "health"})
    if missing:
        raise DataError(f"{path}: the ephemerides lack {', '.join(missing)}")
    el.setdefault("tgd", np.zeros(len(rows)))
    el.setdefault("health", np.zeros(len(rows)))
    toe = el.pop("week") * WEEK_S + el.pop("toe_sow")
    iono = ds.attrs.get("ionospheric_corr_GPS")
    return Ephemerides(str(path), rows["sv"].astype(str).to_numpy(),
                       gps_seconds(rows["time"].to_numpy()), toe, el,
                       None if iono is None else np.asarray(iono, dtype=float))


def read_raw_gnss(obs_path, nav_path, *, mask_deg: float = 10.0, t0: float | None = None):
    """A receiver's RINEX observation and navigation files as the raw GNSS sensor's
    series (``gnss_raw``, :func:`fednav.sensors.gnss_raw.from_observations`): every
    epoch's GPS satellites above ``mask_deg`` [deg] with their L1 C/A pseudorange and,
    where the file has it, Doppler (``D1``/``D1C``), C/N0 (``S1``/``S1C``) weighting.

    Times are GPS time [s] since the GPS epoch, less ``t0`` when given (the IMU
    recording's own zero in GPS time, so both share one clock).

    Raises
    ------
    DataError
        One line: a file missing or unreadable, no L1 pseudorange, or no epoch with four
        satellites to place the receiver.
    """
    obs, eph = read_rinex_obs(obs_path), read_rinex_nav(nav_path)
    dop = next((obs.obs[c] for c in ("D1", "D1C") if c in obs.obs), None)
    cn0 = next((obs.obs[c] for c in ("S1", "S1C") if c in obs.obs), None)
    return raw_series(f"{obs_path} + {nav_path}", obs.t, obs.code("C1", "C1C"), dop, cn0,
                      obs.sv, eph, mask_deg=mask_deg, t0=t0)


def is_observation_file(path) -> bool:
    """Whether ``path``'s name is a RINEX observation file's: ``.YYo`` (RINEX 2),
    ``.obs``, or a RINEX 3 long name ending ``_MO.rnx`` (``.crx`` not read)."""
    name = Path(path).name
    return bool(re.search(r"\.\d\d[oO]$", name) or name.lower().endswith(".obs")
                or re.search(r"_[A-Z]O\.rnx$", name))


def navigation_beside(path) -> Path:
    """The navigation file beside observation file ``path``: ``.YYn`` (``N``, ``p``,
    ``P``) for ``.YYo``, ``.nav`` for ``.obs``, ``_GN.rnx`` / ``_MN.rnx`` for
    ``_MO.rnx``; a one-line :class:`DataError` naming those tried when none is there."""
    p = Path(path)
    name = p.name
    tries = []
    m = re.search(r"\.(\d\d)[oO]$", name)
    if m:
        tries = [name[:-1] + c for c in "nNpP"]
    elif name.lower().endswith(".obs"):
        tries = [name[:-4] + ".nav", name[:-4] + ".NAV"]
    elif re.search(r"_[A-Z]O\.rnx$", name):
        tries = [re.sub(r"_[A-Z]O\.rnx$", f"_{c}N.rnx", name) for c in "GM"]
    for n in tries:
        if (p.parent / n).is_file():
            return p.parent / n
    raise DataError(f"{path}: no navigation file beside it (tried {', '.join(tries) or '-'}"
                    f"); the raw GNSS needs the broadcast ephemerides")


def read_raw_gnss_file(path, t0: float | None = None):
    """The raw GNSS series of a receiver's file (what ``fednav process --gnss_raw FILE``
    reads): a u-blox ``.ubx`` raw log (:func:`fednav.io.ubx_raw.read_ubx_raw_gnss`) or a
    RINEX observation file with its navigation file beside it (:func:`read_raw_gnss`,
    :func:`navigation_beside`); None for any other file (fednav's CSV)."""
    if Path(path).suffix.lower() == ".ubx":
        from .ubx_raw import read_ubx_raw_gnss

        return read_ubx_raw_gnss(path, t0=t0)
    if is_observation_file(path):
        return read_raw_gnss(path, navigation_beside(path), t0=t0)
    return None


def raw_series(source: str, t, pr, dop, cn0, sv, eph, *, mask_deg: float = 10.0,
               t0: float | None = None):
    """The ``gnss_raw`` series of a receiver's observations ``t`` (N,) GPS time [s],
    ``pr`` (N, M) L1 pseudoranges [m], ``dop`` (N, M) Dopplers [Hz] or None, ``cn0``
    (N, M) [dB-Hz] or None, of satellites ``sv`` (M,) with ephemerides ``eph``
    (:func:`fednav.sensors.gnss_raw.from_observations`); times less ``t0``.  What the
    RINEX and the u-blox readers share."""
    from ..sensors.gnss_raw import from_observations
    from .data import SensorData

    try:
        tt, z, used = from_observations(t, pr, dop, np.asarray(sv), eph, mask_deg=mask_deg,
                                         cn0=cn0)
    except ValueError as e:
        raise DataError(f"{source}: {e}") from None
    return SensorData("gnss_raw", source, tt - (0.0 if t0 is None else float(t0)), z,
                      quality={"gnss_raw_epochs": int(len(tt)),
                               "gnss_raw_epochs_without_satellites": int(len(t) - len(tt)),
                               "gnss_raw_satellites_mean": float(np.mean(used)) if len(used)
                               else 0.0,
                               "gnss_raw_doppler": dop is not None})


def _calendar(t: float) -> tuple:
    """(year, month, day, hour, minute, seconds) of GPS time ``t`` [s]."""
    whole = np.floor(t)
    d = (GPS_EPOCH + np.timedelta64(int(whole), "s")).astype("datetime64[s]").item()
    return d.year, d.month, d.day, d.hour, d.minute, d.second + float(t - whole)


def write_rinex_obs(path, t, sv, obs: dict, *, approx_xyz=None, marker: str = "FEDNAV",
                    program: str = "fednav", overwrite: bool = False) -> Path:
    """A RINEX 2.11 GPS observation file: epochs ``t`` (N,) GPS time [s], satellites
    ``sv`` (M,) (``G01`` ...), ``obs`` code -> (N, M) values (``C1`` pseudorange [m],
    ``D1`` Doppler [Hz], ``S1`` C/N0 [dB-Hz], ``L1`` phase [cycles]; NaN: not observed),
    ``approx_xyz`` the antenna's position ECEF [m].  An existing file is not overwritten
    (:class:`DataError`) unless ``overwrite`` (a file the caller wrote itself before:
    ``fednav simulate`` into its own folder).  What :func:`read_rinex_obs` reads back."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise DataError(f"{path}: exists; fednav does not overwrite a file")
    t = np.asarray(t, dtype=float)
    codes = list(obs)
    if not 0 < len(codes) <= 9:
        raise DataError(f"{path}: RINEX 2.11's header line holds 1 to 9 observation types, "
                        f"got {len(codes)}")
    sv = [f"G{int(v):02d}" if not str(v)[:1].isalpha() else str(v) for v in sv]
    if any(len(v) != 3 for v in sv):
        raise DataError(f"{path}: satellites are written as a letter and two digits (G05)")
    vals = np.stack([np.asarray(obs[c], dtype=float) for c in codes], axis=-1)  # N, M, K

    def h(text: str, label: str) -> str:
        return f"{text:<60.60}{label:<20}\n"

    now = datetime.now(UTC).strftime("%Y%m%d %H%M%S UTC")
    xyz = np.zeros(3) if approx_xyz is None else np.asarray(approx_xyz, dtype=float)
    y, mo, d, hh, mi, ss = _calendar(t[0])
    types = f"{len(codes):6d}" + "".join(f"{c:>6}" for c in codes)
    lines = [h(f"{2.11:9.2f}{'':11}{'OBSERVATION DATA':<20}{'G (GPS)':<20}",
               "RINEX VERSION / TYPE"),
             h(f"{program:<20}{'':20}{now:<20}", "PGM / RUN BY / DATE"),
             h(marker, "MARKER NAME"), h(f"{'':20}{program:<40}", "OBSERVER / AGENCY"),
             h(f"{'':20}{program + ' simulated':<20}", "REC # / TYPE / VERS"),
             h("", "ANT # / TYPE"),
             h("".join(f"{v:14.4f}" for v in xyz), "APPROX POSITION XYZ"),
             h(f"{0.0:14.4f}{0.0:14.4f}{0.0:14.4f}", "ANTENNA: DELTA H/E/N"),
             h(f"{1:6d}{1:6d}", "WAVELENGTH FACT L1/2"), h(types, "# / TYPES OF OBSERV")]
    if len(t) > 1:
        lines.append(h(f"{float(np.median(np.diff(t))):10.3f}", "INTERVAL"))
    lines += [h(f"{y:6d}{mo:6d}{d:6d}{hh:6d}{mi:6d}{ss:13.7f}     GPS", "TIME OF FIRST OBS"),
              h("", "END OF HEADER")]
    out = ["".join(lines)]
    for i, ti in enumerate(t):
        seen = np.flatnonzero(np.isfinite(vals[i]).any(axis=1))
        y, mo, d, hh, mi, ss = _calendar(ti)
        names = [str(sv[j]) for j in seen]
        head = f" {y % 100:02d}{mo:3d}{d:3d}{hh:3d}{mi:3d}{ss:11.7f}  0{len(names):3d}"
        out.append(head + "".join(names[:12]) + "\n")
        for k in range(12, len(names), 12):
            out.append(" " * 32 + "".join(names[k:k + 12]) + "\n")
        for j in seen:
            fields = ["" if not np.isfinite(v) else f"{v:14.3f}  " for v in vals[i, j]]
            for k in range(0, len(fields), 5):
                out.append("".join(f"{f:<16}" for f in fields[k:k + 5]).rstrip() + "\n")
    return write_text(path, "".join(out))


def write_rinex_nav(path, eph: Ephemerides, *, program: str = "fednav",
                    overwrite: bool = False) -> Path:
    """A RINEX 2.11 GPS navigation file of the broadcast ephemerides ``eph`` (one record
    per row; its Klobuchar coefficients, where it has them, as ``ION ALPHA`` / ``ION
    BETA``): what :func:`read_rinex_nav` reads back, and RTKLIB or any RINEX reader
    takes.  An existing file is not overwritten (:class:`DataError`) unless ``overwrite``
    (as :func:`write_rinex_obs`)."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise DataError(f"{path}: exists; fednav does not overwrite a file")

    def h(text: str, label: str) -> str:
        return f"{text:<60.60}{label:<20}\n"

    def d(*values) -> str:
        return "".join(f"{float(v):19.12E}" for v in values)

    now = datetime.now(UTC).strftime("%Y%m%d %H%M%S UTC")
    out = [h(f"{2.11:9.2f}{'':11}{'N: GPS NAV DATA':<40}", "RINEX VERSION / TYPE"),
           h(f"{program:<20}{'':20}{now:<20}", "PGM / RUN BY / DATE")]
    if eph.iono is not None:
        a, b = np.asarray(eph.iono[:4], dtype=float), np.asarray(eph.iono[4:8], dtype=float)
        out += [h("  " + "".join(f"{v:12.4E}" for v in a), "ION ALPHA"),
                h("  " + "".join(f"{v:12.4E}" for v in b), "ION BETA")]
    out.append(h("", "END OF HEADER"))
    g = eph.elements
    for k in range(len(eph.sv)):
        sv = str(eph.sv[k])
        prn = int(sv[1:]) if sv[:1].isalpha() else int(sv)
        y, mo, dd, hh, mi, ss = _calendar(float(eph.toc[k]))
        week, sow = divmod(float(eph.toe[k]), WEEK_S)
        iod = float(k % 256)
        out.append(f"{prn:2d}{y % 100:3d}{mo:3d}{dd:3d}{hh:3d}{mi:3d}{ss:5.1f}"
                   + d(g["af0"][k], g["af1"][k], g["af2"][k]) + "\n")
        for row in ((iod, g["crs"][k], g["delta_n"][k], g["m0"][k]),
                    (g["cuc"][k], g["e"][k], g["cus"][k], g["sqrt_a"][k]),
                    (sow, g["cic"][k], g["omega0"][k], g["cis"][k]),
                    (g["i0"][k], g["crc"][k], g["omega"][k], g["omega_dot"][k]),
                    (g["idot"][k], 1.0, week, 0.0),
                    (2.0, g["health"][k], g["tgd"][k], iod),
                    (sow, 4.0)):
            out.append("   " + d(*row) + "\n")
    return write_text(path, "".join(out))


def write_raw_receiver(folder, series, truth, section,
                       overwrite: bool = False) -> tuple[list[Path], str, dict]:
    """A simulated raw receiver (``gnss_raw``: its series, the truth it flew, its system
    section) as the files a real one gives: ``gnss_raw.obs`` (RINEX 2.11 observations in
    GPS time: ``C1`` the L1 pseudorange with the satellite clock, the troposphere
    (Saastamoinen at the true position) and the ionosphere (Klobuchar, where the
    ephemerides carry coefficients) put back, what :func:`read_raw_gnss` takes out
    again; ``D1`` the Doppler [Hz]) and ``gnss_raw.nav`` (the sky's broadcast
    ephemerides, :func:`write_rinex_nav`; ``overwrite``: as theirs).  Returns the files,
    the one to name in the
    system description's ``files:`` and the section's keys that go with it
    (``time_offset_s``: the files' GPS time back onto the simulation's clock)."""
    from ..core import earth
    from ..sensors.gnss_raw import FIELDS, PR, PRN, RR, SLOTS, SX, SZ
    from ..sensors.satellites import (
        F_L1,
        C,
        azimuth_elevation,
        klobuchar,
        nearest_ephemeris,
        saastamoinen,
        satellite_states,
    )

    folder = Path(folder)
    receiver = section.sensor()
    t = np.asarray(series.t, dtype=float)
    eph = receiver.sky(float(t[-1]) if len(t) else 0.0)
    start = float(receiver.start_gps_s)
    z = np.asarray(series.z, dtype=float).reshape(len(t), SLOTS, len(FIELDS))
    lla = truth.at(t)["lla"]
    r = earth.llh_to_ecef(lla[:, 0], lla[:, 1], lla[:, 2])
    i, j = np.nonzero(np.isfinite(z[:, :, PRN]))  # (every epoch's occupied slots)
    prns = np.unique(z[i, j, PRN].astype(np.int64))
    sv = np.array([f"G{p:02d}" for p in prns])
    k = np.searchsorted(prns, z[i, j, PRN].astype(np.int64))  # (each slot's satellite)
    n = (len(t), len(prns))
    pos, pr, rr = np.full((*n, 3), np.nan), np.full(n, np.nan), np.full(n, np.nan)
    pos[i, k], pr[i, k], rr[i, k] = z[i, j, SX:SZ + 1], z[i, j, PR], z[i, j, RR]
    gps = t + start
    tau = np.linalg.norm(pos - r[:, None, :], axis=-1) / C
    _, _, clk, drift = satellite_states(eph, nearest_ephemeris(eph, sv, gps),
                                        gps[:, None] - np.nan_to_num(tau), True)
    az, el = azimuth_elevation(lla[:, None, :], r[:, None, :], pos)
    delay = saastamoinen(lla[:, None, 0], lla[:, None, 2], el)
    if eph.iono is not None:
        delay = delay + klobuchar(eph.iono, lla[:, None, 0], lla[:, None, 1], az, el,
                                  np.mod(gps[:, None], WEEK_S))
    obs = {"C1": pr - C * clk + delay, "D1": (C * drift - rr) * F_L1 / C}
    files = [write_rinex_obs(folder / "gnss_raw.obs", gps, sv, obs, approx_xyz=r[0],
                             overwrite=overwrite),
             write_rinex_nav(folder / "gnss_raw.nav", eph, overwrite=overwrite)]
    return files, "gnss_raw.obs", {"time_offset_s": -start}


satellites.NAVIGATION_READER = read_rinex_nav  # (the simulated sky from a real file)

__all__ = ["Ephemerides", "GPS_EPOCH", "RinexObs", "WEEK_S", "gps_seconds",
           "is_observation_file", "navigation_beside", "raw_series", "read_raw_gnss",
           "read_raw_gnss_file", "read_rinex_nav", "read_rinex_obs", "write_raw_receiver",
           "write_rinex_nav", "write_rinex_obs"]

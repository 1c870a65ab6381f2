"""Any registered sensor's CSV file, from its entry in the sensor registry.

A sensor's file is ``t_s`` (time of validity), the columns its
:class:`~fednav.sensors.spec.SensorSpec` lists (one per component of its measurement,
unit in the name: degrees and metres at the edge, converted here), and optionally
``t_arrival_s`` (when the measurement reached the navigator, for processing delays).
Adding a sensor to the registry adds its file layout; nothing here names a sensor.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..sensors import registry
from .csvdata import _read, write_csv
from .data import DataError, SensorData  # noqa: F401  (fednav.io.sensorfile's name)

#: Optional column: when the measurement reached the navigator [s].
ARRIVAL = "t_arrival_s"


def columns(name: str) -> tuple[str, ...]:
    """The header of sensor ``name``'s file (without the optional ``t_arrival_s`` and
    1-sigma columns)."""
    return ("t_s",) + tuple(c.name for c in registry.spec(name).columns)


def sigma_columns(name: str) -> tuple[str, ...]:
    """The optional per-row 1-sigma columns of sensor ``name``'s file (one per component,
    or one for several: the magnetometer's heading)."""
    return tuple(dict.fromkeys(c.sigma_column[0] for c in registry.spec(name).columns))


def read_sensor_file(name: str, path) -> SensorData:
    """Sensor ``name``'s recording from ``path``: a file format of the sensor's own when
    the file's name says so (:data:`OWN_FORMATS`: the raw GNSS's u-blox ``.ubx`` logs and
    RINEX observation files), else fednav's CSV (:func:`read_sensor_csv`)."""
    own = OWN_FORMATS.get(name)
    out = own(path) if own is not None else None
    return read_sensor_csv(name, path) if out is None else out


def _raw_gnss_file(path):
    from .rinex import read_raw_gnss_file

    return read_raw_gnss_file(path)


#: sensor -> a reader of its own file formats (the series, or None for fednav's CSV)
OWN_FORMATS = {"gnss_raw": _raw_gnss_file}


def _raw_gnss_writer(folder, series, truth, section):
    from .rinex import write_raw_receiver

    # (fednav simulate's folder: its own files of an earlier run are replaced, as its CSVs)
    return write_raw_receiver(folder, series, truth, section, overwrite=True)


#: sensor -> a writer of a simulated recording in the sensor's own file formats (what a
#: real one gives: the raw receiver's RINEX), ``(folder, series, truth, section) ->
#: (files, the file for files:, the section's keys)``; any other sensor: its CSV
OWN_WRITERS = {"gnss_raw": _raw_gnss_writer}


def read_sensor_csv(name: str, path) -> SensorData:
    """Read any registered sensor's CSV file (``docs/data-formats.md``).

    Columns ``t_s``, the sensor's own (each in the unit its name says), optional
    ``t_arrival_s`` and optional 1-sigma columns (all of the sensor's or none; positive).
    Rows with an empty or non-finite value, or that the sensor does not take for a
    measurement, are dropped and counted; times must increase.

    Parameters
    ----------
    name : str
        The sensor's registered name (``star``, ``baro``, ``odometer`` ...;
        :mod:`fednav.sensors.registry`).
    path : str or Path
        The CSV file.

    Returns
    -------
    SensorData
        :class:`fednav.io.SensorData`: times of validity and arrival [s], values ``z``
        and 1-sigma in the sensor's SI layout [rad, m, m/s ...], for
        ``process_data(imu, {"gnss": gnss, name: data}, cfg)``.

    Raises
    ------
    DataError
        One line naming the file and what is wrong.
    """
    spec = registry.spec(name)
    if not spec.columns:
        raise DataError(f"sensor '{name}' declares no file columns")
    head = columns(name)
    sig_cols = tuple(c.sigma_column[0] for c in spec.columns)  # (per component)
    alt = spec.alternative
    optional = (ARRIVAL,) + sig_cols + (alt[0] if alt else ())
    src, df = _read(path, f"{name} sensor", ("t_s",), numeric=optional + head[1:])
    have = set(df.names)
    absent = tuple(j for j, c in enumerate(spec.columns)
                   if c.absent is not None and c.name not in have)
    if all(c.name in have or j in absent for j, c in enumerate(spec.columns)):
        z = np.column_stack([df.column(c.name) * c.to_si if j not in absent
                             else np.full(df.rows, np.nan)
                             for j, c in enumerate(spec.columns)])
    elif alt and all(c in have for c in alt[0]):
        z = np.asarray(alt[1](df.stack(alt[0])), dtype=float)
    else:
        missing = [c for c in head if c not in have]
        other = f" (or {', '.join(alt[0])})" if alt else ""
        raise DataError(f"{src}: missing column(s) {', '.join(missing)}{other} "
                        f"(have {', '.join(df.names)})")
    t = df.column("t_s")
    want = list(dict.fromkeys(c for j, c in enumerate(sig_cols) if j not in absent))
    given = [c in have for c in want]
    sig = None
    if any(given):
        if not all(given):
            lack = [c for c, g in zip(want, given, strict=True) if not g]
            raise DataError(f"{src}: 1-sigma columns are all of {', '.join(want)} or "
                            f"none; missing {', '.join(lack)}")
        sig = np.column_stack([df.column(c.sigma_column[0]) * c.sigma_column[1]
                               if j not in absent else np.ones(df.rows)
                               for j, c in enumerate(spec.columns)])
    ta = None
    if ARRIVAL in have:
        ta = df.column(ARRIVAL)
    used = [j for j in range(z.shape[1]) if j not in absent]
    ok = np.isfinite(t) if spec.sparse else np.isfinite(z[:, used]).all(axis=1) & \
        np.isfinite(t)
    if spec.valid is not None:
        with np.errstate(invalid="ignore"):
            ok &= spec.valid(z)
    if ta is not None:
        ok &= np.isfinite(ta)
    if sig is not None:
        ok &= np.isfinite(sig).all(axis=1)
    quality = {f"{name}_rows_dropped": int((~ok).sum())}
    rows = np.flatnonzero(ok) + 1  # data row numbers in the file
    t, z = t[ok], z[ok]
    if not len(t):
        raise DataError(f"{src}: no row with every value of {', '.join(head)} finite")
    if len(t) > 1:
        d = np.diff(t)
        if np.any(d <= 0):
            i = int(np.argmax(d <= 0)) + 1
            raise DataError(f"{src}: column 't_s' is not increasing at data row {rows[i]} "
                            f"({t[i - 1]:.6f} s then {t[i]:.6f} s)")
    if sig is not None:
        sig = sig[ok]
        bad = (sig[:, used] <= 0).any(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            j = int(np.argmax(sig[i] <= 0))
            v = sig[i, j] / spec.columns[j].sigma_column[1]
            raise DataError(f"{src}: column '{sig_cols[j]}' is {v:g} at data row {rows[i]}: "
                            f"a 1-sigma must be positive")
    if ta is not None:
        ta = ta[ok]
        early = ta < t - 1e-9
        if early.any():
            i = int(np.argmax(early))
            raise DataError(f"{src}: data row {rows[i]} arrives at {ta[i]:.6f} s, before "
                            f"the time it describes ({t[i]:.6f} s)")
    for j, c in enumerate(spec.columns):
        if c.wrap_2pi:
            z[:, j] = np.mod(z[:, j], 2.0 * np.pi)
    return SensorData(name, src, t, z, ta, quality, sig, absent)


def write_sensor_csv(path, series, sigma: bool = False) -> Path:
    """A simulated :class:`~fednav.sensors.base.MeasurementSeries` as its sensor's file
    (``t_arrival_s`` when it arrives later than it describes; with ``sigma`` each row's
    1-sigma columns), every value to 17 significant digits (the file reads back to the
    same doubles, but for the unit conversions' rounding)."""
    spec = registry.spec(series.kind)
    cols = {"t_s": series.t}
    columns = spec.columns[:series.z.shape[1]]  # (optional columns a simulation lacks)
    for j, c in enumerate(columns):
        cols[c.name] = series.z[:, j] / c.to_si
    if series.t_avail is not None and np.any(series.t_avail != series.t):
        cols[ARRIVAL] = series.t_avail
    try:  # (a sensor whose z holds its own 1-sigma, the raw GNSS's, has no columns)
        s = np.broadcast_to(np.asarray(series.sigma, dtype=float), series.z.shape)
    except ValueError:
        sigma = False
    if sigma:
        for j, c in enumerate(columns):
            name, to_si = c.sigma_column
            cols[name] = s[:, j] / to_si
    return write_csv(path, cols, significant=17)

"""fednav's plain CSV layout for IMU, GNSS, velocity and reference data.

One header row; column names carry their unit; body axes right-forward-up, ENU
velocities, degrees for latitude/longitude/angles (the edge convention of the CLI).
The layouts are documented in ``docs/data-formats.md``:

* IMU: ``t_s, gyro_x_radps, gyro_y_radps, gyro_z_radps, accel_x_mps2, accel_y_mps2,
  accel_z_mps2``;
* GNSS: ``t_s, lat_deg, lon_deg, h_m`` [``, vE_mps, vN_mps, vU_mps``];
* velocity: ``t_s, vE_mps, vN_mps, vU_mps, sigma_vE_mps, sigma_vN_mps, sigma_vU_mps``;
* reference: ``t_s, lat_deg, lon_deg, h_m, vE_mps, vN_mps, vU_mps``
  [``, pitch_deg, roll_deg, heading_deg``].
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..core import units
from ..core.atomic import write_bytes, write_text
from ..sensors.gnss import neu_to_enu
from .data import (
    DataError,
    GnssData,
    ImuData,
    Reference,
    VelocityData,
    check_time,
    require_file,
)

IMU_COLUMNS = ("t_s", "gyro_x_radps", "gyro_y_radps", "gyro_z_radps", "accel_x_mps2",
               "accel_y_mps2", "accel_z_mps2")
#: IMU increments over the interval that ends at ``t_s`` (instead of the rates).
INCREMENT_COLUMNS = ("dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_mps", "dv_y_mps",
                     "dv_z_mps")
POS_COLUMNS = ("lat_deg", "lon_deg", "h_m")
VEL_COLUMNS = ("vE_mps", "vN_mps", "vU_mps")
VEL_SIGMA_COLUMNS = ("sigma_vE_mps", "sigma_vN_mps", "sigma_vU_mps")
EULER_COLUMNS = ("pitch_deg", "roll_deg", "heading_deg")


class Columns:
    """A CSV file's columns by name: every numeric column as a float array (empty cells,
    ``nan``: NaN), ``names`` in the file's order (text columns named, not held)."""

    def __init__(self, names: list[str], data: dict[str, np.ndarray], rows: int):
        self.names, self._data, self.rows = names, data, rows

    def __contains__(self, name) -> bool:
        return name in self._data

    def column(self, name: str) -> np.ndarray:
        """Column ``name`` as floats (N,)."""
        return self._data[name]

    def stack(self, names) -> np.ndarray:
        """Columns ``names`` side by side (N, len(names))."""
        return np.column_stack([self._data[c] for c in names])

    def has(self, names) -> bool:
        return all(c in self._data for c in names)


def _arrow_columns(path: Path, numbers: set) -> Columns | None:
    """The file by pyarrow's CSV reader (multithreaded; with it a command does not
    import pandas, 0.3 s of its start): None where pyarrow is not installed or the
    file holds anything :func:`_pandas_columns` has to explain (a row of another
    width, text in a column of numbers, a repeated column name)."""
    try:
        import pyarrow as pa
        import pyarrow.csv as pc
    except ImportError:
        return None
    try:
        tab = pc.read_csv(path)
    except (pa.ArrowException, OSError):
        return None
    names = [c.strip() for c in tab.column_names]  # (', ' separators: pandas' too)
    if len(set(names)) < len(names):
        return None
    data = {}
    for name, col in zip(names, tab.columns, strict=True):
        if pa.types.is_integer(col.type) or pa.types.is_floating(col.type) \
                or pa.types.is_null(col.type):
            data[name] = _floats(col.cast(pa.float64()))
        elif name in numbers:
            return None
    return Columns(names, data, tab.num_rows)


def _floats(col) -> np.ndarray:
    """A pyarrow float64 column as a new float array, nulls (empty cells) NaN — read
    from its buffers: pyarrow's own ``to_numpy`` imports pandas, which this reader
    spares a command."""
    out = []
    for c in col.chunks:
        n, off = len(c), c.offset
        valid, data = c.buffers()
        if data is None:  # (a column of empty cells only)
            out.append(np.full(n, np.nan))
            continue
        x = np.frombuffer(data, np.float64, count=n, offset=off * 8)
        if c.null_count:
            bits = np.unpackbits(np.frombuffer(valid, np.uint8), bitorder="little")
            x = np.where(bits[off:off + n].astype(bool), x, np.nan)
        out.append(x)
    return np.concatenate(out) if out else np.empty(0)


def _pandas_columns(path: Path, src: str, numbers: set) -> Columns:
    """The file by pandas, every refusal one line naming the file, column and row."""
    import pandas as pd

    try:
        df = pd.read_csv(path, skipinitialspace=True, encoding="utf-8-sig")
    except Exception as e:  # pandas raises several types for unreadable content
        msg = str(e).strip().splitlines()[-1] if str(e).strip() else type(e).__name__
        raise DataError(f"{src}: not a readable CSV file ({msg})") from None
    data = {}
    for c in df.columns:
        v = pd.to_numeric(df[c], errors="coerce")
        # empty cells, NaN and inf are faulty samples (the data policy screens them);
        # text that is not a number means the file is not what it claims to be
        text = v.isna().to_numpy() & df[c].notna().to_numpy()
        if not text.any():
            data[c] = v.to_numpy(dtype=float)
        elif c in numbers:
            i = int(np.argmax(text))
            raise DataError(f"{src}: column '{c}' has a non-numeric value "
                            f"{str(df[c].iloc[i])[:20]!r} at data row {i + 1}")
    return Columns([str(c) for c in df.columns], data, len(df))


def _read(path, kind: str, required: tuple, numeric: tuple = (),
          expected: tuple | None = None) -> tuple[str, Columns]:
    """The CSV file's :class:`Columns`: ``required`` columns present, they and the known
    optional ones (and ``numeric``) numbers; one-line :class:`DataError` s."""
    path = Path(path)
    require_file(path, kind)
    src = str(path)
    try:
        with open(path, encoding="utf-8-sig") as f:  # a UTF-8 byte-order mark is accepted
            header = f.readline()
    except UnicodeDecodeError:
        raise DataError(f"{src}: not a UTF-8 text file") from None
    if not header.strip():
        raise DataError(f"{src}: empty file (expected a header row: "
                        f"{', '.join(expected or required)})")
    for sep, name in ((";", "';'"), ("\t", "tabs"), ("|", "'|'")):
        if sep in header and "," not in header:
            raise DataError(f"{src}: columns are separated by {name}: fednav's CSV files "
                            f"use ','")
    numbers = set(required + numeric + VEL_COLUMNS + EULER_COLUMNS + VEL_SIGMA_COLUMNS)
    df = _arrow_columns(path, numbers) or _pandas_columns(path, src, numbers)
    missing = [c for c in required if c not in df.names]
    if missing:
        raise DataError(f"{src}: missing column(s) {', '.join(missing)} "
                        f"(have {', '.join(df.names)})")
    if not df.rows:
        raise DataError(f"{src}: no data rows (header only)")
    if kind == "IMU":
        check_time(src, df.column("t_s"), "t_s")
    return src, df


def _arrival(df: Columns) -> np.ndarray | None:
    """The optional ``t_arrival_s`` column (when each row reached the navigator)."""
    return df.column("t_arrival_s") if "t_arrival_s" in df else None


def read_imu_csv(path, max_bridge_s: float = 0.1, mounting=None) -> ImuData:
    """Read an IMU CSV file (``docs/data-formats.md``).

    Body right-forward-up axes: rates (``gyro_*_radps``, ``accel_*_mps2``: the rate at
    ``t_s``, held until the next sample) or increments (``dtheta_*_rad``, ``dv_*_mps``:
    over the interval that ends at ``t_s``), as the column names declare.  Jittered or
    missing time stamps are integrated over each sample's own interval onto a uniform
    grid; faulty samples and gaps are bridged up to ``max_bridge_s``
    (:func:`~fednav.io.data.regular_imu`).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    max_bridge_s : float
        Longest gap or run of faulty samples bridged [s]; a longer one is refused.
    mounting : str or dict, optional
        How the IMU's axes in the file are mounted (``imu.mounting``: axis letters such
        as ``FRD`` or ``{euler_deg: [pitch, roll, heading]}``, :mod:`fednav.core.mounting`);
        default: the format's own axes (right-forward-up, ``RFU``).

    Returns
    -------
    ImuData
        :class:`fednav.io.ImuData`: ``t`` [s], ``gyro`` [rad/s] and ``accel`` [m/s^2]
        in body right-forward-up axes on a uniform grid.

    Raises
    ------
    DataError
        One line naming the file and what is wrong.
    """
    src, df = _read(path, "IMU", ("t_s",), numeric=IMU_COLUMNS[1:] + INCREMENT_COLUMNS,
                    expected=IMU_COLUMNS)
    t = df.column("t_s")
    if df.has(INCREMENT_COLUMNS):
        imu = ImuData.from_increments(src, t, df.stack(INCREMENT_COLUMNS[:3]),
                                      df.stack(INCREMENT_COLUMNS[3:]),
                                      max_bridge_s=max_bridge_s)
        return imu if mounting is None else imu.remount(mounting)
    missing = [c for c in IMU_COLUMNS if c not in df.names]
    if missing:
        raise DataError(f"{src}: missing column(s) {', '.join(missing)} (have "
                        f"{', '.join(df.names)}; increments instead of rates: "
                        f"dtheta_x_rad ... dv_z_mps)")
    imu = ImuData(src, t, df.stack(IMU_COLUMNS[1:4]), df.stack(IMU_COLUMNS[4:7]),
                  max_bridge_s=max_bridge_s)
    return imu if mounting is None else imu.remount(mounting)


def _lla(df) -> np.ndarray:
    p = df.stack(POS_COLUMNS)
    return np.column_stack([units.deg(p[:, 0]), units.deg(p[:, 1]), p[:, 2]])


#: Optional per-fix 1-sigma of a GNSS file [north, east, up m, vE, vN, vU m/s].
GNSS_SIGMA_COLUMNS = ("sigma_north_m", "sigma_east_m", "sigma_up_m") + VEL_SIGMA_COLUMNS


def read_gnss_csv(path, sigma_pos_enu=None, sigma_vel=(0.1, 0.1, 0.1),
                  lever=(0.0, 0.0, 0.0), *, sigma_pos=None) -> GnssData:
    """Read a GNSS CSV file (``docs/data-formats.md``).

    Positions ``lat_deg, lon_deg, h_m`` and/or ENU velocities ``vE_mps, vN_mps, vU_mps``
    (a position-only or velocity-only receiver), optionally each fix's 1-sigma
    (``sigma_north_m, sigma_east_m, sigma_up_m`` and/or ``sigma_vE_mps ...``, for the
    components the file has).  The figures used where the file has none and the antenna
    lever arm come from the caller (the system description's ``sensors.gnss``).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    sigma_pos_enu : float or sequence of float, optional
        Position 1-sigma [east, north, up] [m] (one value for all three) where the file
        has none (default 5 m
        each).
    sigma_vel : float or sequence of float, optional
        Velocity 1-sigma [east, north, up] [m/s] (one value for all three) where the file
        has none (None: 0.1 m/s).
    lever : sequence of float, optional
        Antenna position from the IMU, body right-forward-up [m] (None: zero).
    sigma_pos : sequence of float, optional
        Deprecated: the position 1-sigma in the old order [north, east, up] [m], read
        and reordered with a ``FutureWarning`` for one more release (not with
        ``sigma_pos_enu``).

    Returns
    -------
    GnssData
        :class:`fednav.io.GnssData`: ``t`` [s], ``lla`` lat/lon [rad], h [m] (or None),
        ENU ``vel`` [m/s] (or None), the sigmas and the lever arm.

    Raises
    ------
    DataError
        One line naming the file and what is wrong.
    TypeError
        When both ``sigma_pos`` and ``sigma_pos_enu`` are given.
    """
    if sigma_pos is not None and sigma_pos_enu is not None:
        raise TypeError("read_gnss_csv: sigma_pos ([north, east, up]) and sigma_pos_enu "
                        "([east, north, up]) are the same setting; give sigma_pos_enu "
                        "only")
    src, df = _read(path, "GNSS", ("t_s",),
                    numeric=POS_COLUMNS + GNSS_SIGMA_COLUMNS + ("t_arrival_s",),
                    expected=("t_s",) + POS_COLUMNS + VEL_COLUMNS)
    has_pos, has_vel = df.has(POS_COLUMNS), df.has(VEL_COLUMNS)
    partial = [g for g in (POS_COLUMNS, VEL_COLUMNS)
               if not df.has(g) and any(c in df.names for c in g)]
    have = ", ".join(df.names)
    if partial:
        missing = [c for c in partial[0] if c not in df.names]
        raise DataError(f"{src}: missing column(s) {', '.join(missing)} (have {have})")
    if not has_pos and not has_vel:
        raise DataError(f"{src}: missing column(s) {', '.join(POS_COLUMNS)} and/or "
                        f"{', '.join(VEL_COLUMNS)} (a GNSS file has positions, velocities or "
                        f"both; have {have})")
    n = df.rows
    lla = _lla(df) if has_pos else None
    vel = df.stack(VEL_COLUMNS) if has_vel else None
    sig = None
    want = [c for c, used in zip(GNSS_SIGMA_COLUMNS, [has_pos] * 3 + [has_vel] * 3,
                                 strict=True) if used]
    given = [c for c in want if c in df.names]
    if given:
        if len(given) != len(want):
            raise DataError(f"{src}: 1-sigma columns are all of {', '.join(want)} or none; "
                            f"missing {', '.join(c for c in want if c not in given)}")
        sig = np.ones((n, 6))
        for j, c in enumerate(GNSS_SIGMA_COLUMNS):
            if c in df.names and c in want:
                sig[:, j] = df.column(c)
    if sigma_pos is not None:  # the old keyword, reordered
        warnings.warn("read_gnss_csv(sigma_pos=[north, east, up]) is now "
                      "read_gnss_csv(sigma_pos_enu=[east, north, up]): read and reordered "
                      "for one more release", FutureWarning, stacklevel=2)
        sigma_pos_enu = neu_to_enu(np.asarray(sigma_pos, dtype=float))
    # (a system description's values as they are: one value for three axes, None for
    # what it leaves out)
    pos = _three(5.0 if sigma_pos_enu is None else sigma_pos_enu)
    return GnssData(src, df.column("t_s"), lla, vel,
                    sigma_vel=_three(0.1 if sigma_vel is None else sigma_vel),
                    lever=_three(0.0 if lever is None else lever), sigma_rows=sig,
                    t_arrival=_arrival(df), sigma_pos_enu=pos)


def _three(v) -> np.ndarray:
    """One value as three, three values as they are (anything else: for the container's
    check to name)."""
    a = np.asarray(v, dtype=float)
    return np.full(3, float(a)) if a.ndim == 0 else a


def read_velocity_csv(path, lever=(0.0, 0.0, 0.0)) -> VelocityData:
    """Velocity CSV (ENU m/s with per-axis 1-sigma)."""
    src, df = _read(path, "velocity", ("t_s",) + VEL_COLUMNS + VEL_SIGMA_COLUMNS,
                    numeric=("t_arrival_s",))
    sig = df.stack(VEL_SIGMA_COLUMNS)
    cov = np.zeros((df.rows, 3, 3))
    cov[:, np.arange(3), np.arange(3)] = sig**2
    return VelocityData(src, df.column("t_s"), df.stack(VEL_COLUMNS), cov,
                        np.asarray(lever), t_arrival=_arrival(df))


def read_reference_csv(path) -> Reference:
    """Read a reference (truth) trajectory CSV file (``docs/data-formats.md``).

    Columns ``t_s, lat_deg, lon_deg, h_m, vE_mps, vN_mps, vU_mps`` and optionally
    ``pitch_deg, roll_deg, heading_deg``.

    Parameters
    ----------
    path : str or Path
        The CSV file.

    Returns
    -------
    Reference
        :class:`fednav.io.Reference`: ``t`` [s], ``lla`` lat/lon [rad], h [m], ENU
        ``vel`` [m/s], ``euler`` [pitch, roll, heading] [rad] or None.

    Raises
    ------
    DataError
        One line naming the file and what is wrong.
    """
    src, df = _read(path, "reference", ("t_s",) + POS_COLUMNS + VEL_COLUMNS)
    euler = units.deg(df.stack(EULER_COLUMNS)) if df.has(EULER_COLUMNS) else None
    return Reference(src, df.column("t_s"), _lla(df), df.stack(VEL_COLUMNS), euler)


def write_csv(path, columns: dict[str, np.ndarray], decimals: dict[str, int] | None = None,
              significant: int = 10) -> Path:
    """Write named numeric columns as a CSV file (written then renamed).

    With ``decimals`` (a count per column name) each column gets that many decimals, by
    the compiled :func:`fednav.io.fixed_format.format_rows`; otherwise ``significant``
    digits (``%.10g``), one C-level format of a whole block of rows (5x faster than
    ``DataFrame.to_csv``)."""
    path = Path(path)
    names = list(columns)
    X = np.column_stack([np.asarray(columns[k], dtype=float) for k in names])
    header = ",".join(names) + "\n"
    if decimals is not None:
        from .fixed_format import format_rows

        body = format_rows(X, [decimals[k] for k in names])
        if body is not None:
            write_bytes(path, header.encode() + body)
            return path
    row = ",".join([f"%.{significant}g"] * len(names)) + "\n"
    parts = [header]
    for a in range(0, len(X), 50_000):
        block = X[a:a + 50_000]
        parts.append((row * len(block)) % tuple(block.ravel().tolist()))
    write_text(path, "".join(parts))
    return path

"""Outputs of ``fednav process``: solution CSV files, plots and ``summary.json``."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from ..core import plots, units
from ..core.atomic import replacing, write_json
from ..core.drawer import Drawer
from ..io.csvdata import write_csv
from ..io.data import Reference
from ..navigator.solution import consistency as _consistency
from . import outages
from .run import ProcessResult, Solution, errors_against, rmse

#: Columns of the RMSE block of summary.json, in the solution's order: ENU position and
#: velocity, then the Euler angles [pitch, roll, heading] (only with a reference attitude).
RMSE_KEYS = ("east_m", "north_m", "up_m", "ve_mps", "vn_mps", "vu_mps", "pitch_deg",
             "roll_deg", "yaw_deg")


def solution_columns(sol: Solution) -> dict[str, np.ndarray]:
    """The solution as named columns (degrees for angles, ENU, 1-sigma columns)."""
    e = units.to_deg(sol.euler)
    s = sol.sigma
    return {
        "t_s": sol.t, "lat_deg": units.to_deg(sol.lla[:, 0]),
        "lon_deg": units.to_deg(sol.lla[:, 1]), "h_m": sol.lla[:, 2],
        "vE_mps": sol.vel[:, 0], "vN_mps": sol.vel[:, 1], "vU_mps": sol.vel[:, 2],
        "pitch_deg": e[:, 0], "roll_deg": e[:, 1], "heading_deg": e[:, 2],
        "sigma_phiE_deg": units.to_deg(s[:, 0]), "sigma_phiN_deg": units.to_deg(s[:, 1]),
        "sigma_phiU_deg": units.to_deg(s[:, 2]), "sigma_vE_mps": s[:, 3],
        "sigma_vN_mps": s[:, 4], "sigma_vU_mps": s[:, 5], "sigma_E_m": s[:, 6],
        "sigma_N_m": s[:, 7], "sigma_U_m": s[:, 8],
        "sigma_pitch_deg": units.to_deg(sol.sigma_euler[:, 0]),
        "sigma_roll_deg": units.to_deg(sol.sigma_euler[:, 1]),
        "sigma_heading_deg": units.to_deg(sol.sigma_euler[:, 2]),
        **(sol.levels or {}),
    }


def solution_decimals(names) -> dict[str, int]:
    """Decimals of each solution column: time 1 us, latitude/longitude 1e-9 deg (0.1 mm),
    height 0.1 mm, velocity 10 um/s, angles 1e-6 deg, sigmas 1e-6 of their unit."""
    def d(name):
        if name == "t_s" or name.startswith("sigma_"):
            return 6
        return {"lat_deg": 9, "lon_deg": 9, "h_m": 4, "integrity_alert": 0,
                "excluded": 0}.get(name, 5 if name.endswith("mps") else 6)
    return {k: d(k) for k in names}


#: Rows per second of the solution files when neither ``--output-rate`` nor the system's
#: ``output_rate_hz`` says (at most the IMU's rate): what a 10-minute drive needs for a
#: plot or a comparison, 1/20 of a 200 Hz IMU's rows.  ``imu`` (or 0) keeps every sample.
DEFAULT_OUTPUT_RATE_HZ = 10.0
#: Solution file formats (``--format``; Parquet needs the ``parquet`` extra: pyarrow).
FORMATS = ("csv", "parquet")


def parse_rate(value) -> float | str | None:
    """An ``--output-rate``: None (not given: :data:`DEFAULT_OUTPUT_RATE_HZ`, or fewer
    rows when the IMU has them), ``"imu"`` (every IMU sample; also ``0``), ``"filter"``
    (the filter epochs) or a rate [Hz] > 0.  A ValueError names anything else."""
    if value is None or isinstance(value, float | int) and not isinstance(value, bool):
        v = value
    else:
        word = str(value).strip().lower()
        if word in ("imu", "filter"):
            return word
        try:
            v = float(word)
        except ValueError:
            raise ValueError(f"--output-rate {value}: a rate in Hz, 'imu' (every IMU "
                             f"sample) or 'filter' (the filter epochs)") from None
    if v is None:
        return None
    if v == 0:
        return "imu"
    if not np.isfinite(v) or v < 0:
        raise ValueError(f"--output-rate {value}: must be positive (0 or 'imu': every IMU "
                         f"sample)")
    return float(v)


def decimate(sol: Solution, rate_hz: float | str | None) -> Solution:
    """The solution rows to write at ``rate_hz`` (:func:`parse_rate`'s values): None —
    :data:`DEFAULT_OUTPUT_RATE_HZ`, every row where the solution has fewer; ``"imu"`` —
    every row; ``"filter"`` — the filter epochs' rows; a rate — every
    ``round(1 / (rate_hz dt))``-th row, starting with the first (a rate above the IMU's
    is a ValueError)."""
    rate = parse_rate(rate_hz)
    if rate == "imu":
        return sol
    if rate == "filter":
        return sol if sol.epoch_rows is None else sol.rows(sol.epoch_rows)
    dt = float(sol.t[1] - sol.t[0]) if len(sol.t) > 1 else 1.0
    if rate is None:
        rate = min(DEFAULT_OUTPUT_RATE_HZ, 1.0 / dt)
    elif rate > 1.0 / dt * (1 + 1e-9):
        raise ValueError(f"--output-rate {rate:g} Hz: must be positive and at most the IMU "
                         f"rate ({1.0 / dt:g} Hz)")
    return sol.rows(slice(None, None, max(1, int(round(1.0 / (rate * dt))))))


def check_format(fmt: str | None) -> str:
    """The solution file format (``csv`` when None); a ValueError names an unknown one,
    or the missing extra for ``parquet``."""
    fmt = (fmt or "csv").lower()
    if fmt not in FORMATS:
        raise ValueError(f"--format {fmt}: must be csv or parquet")
    if fmt == "parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise ValueError("--format parquet needs pyarrow: pip install 'fednav[parquet]'"
                             ) from None
    return fmt


def write_solution(path: Path, sol: Solution) -> Path:
    """One solution file: CSV (fixed decimals, :func:`solution_decimals`) or, for a
    ``.parquet`` path, Parquet (the same columns in float64, unrounded; zstd)."""
    cols = solution_columns(sol)
    path = Path(path)
    if path.suffix == ".parquet":
        check_format("parquet")
        import pandas as pd

        with replacing(path) as tmp:
            pd.DataFrame(cols).to_parquet(tmp, index=False, compression="zstd")
        return path
    return write_csv(path, cols, solution_decimals(cols))


def consistency(sol: Solution) -> dict[str, dict[str, float]]:
    """Per local filter: mean normalized innovation squared per degree of freedom and the
    fraction isolated (:func:`fednav.navigator.solution.consistency` of ``sol.fdi``)."""
    return _consistency(sol.fdi)


def error_states(optional: dict) -> dict:
    """The optional error states at the end of the run, as ``summary.json`` has them, in
    their filter units (:data:`fednav.ins.states.BLOCKS`): ``{"gyro_scale_ppm":
    {"estimate": [x, y, z], "sigma": [...]}, "gnss_markov_enu_m": ...}`` (body axes for
    scale factors, east/north/up for a sensor's error)."""
    from ..ins.states import BLOCKS

    out = {}
    for name, v in optional.items():
        b = BLOCKS[name]
        out[f"{name}_{b.suffix}"] = {key: [round(float(x) / b.unit, 6) for x in v[key]]
                                     for key in ("estimate", "sigma")}
    return out


def summary(res: ProcessResult, ref: Reference | None, inputs: dict,
            others: dict | None = None) -> dict:
    """``summary.json`` content; ``others``: further references by name (an autopilot's
    own estimate), each compared under ``against``."""
    quality = dict(res.data_quality)
    if ref is not None:
        quality.update(ref.quality)
    out: dict = {"inputs": inputs, "run_time_s": res.run_time_s, "epochs": res.epochs,
                 "data_quality": quality, "warnings": list(res.warnings),
                 "hints": list(res.hints),
                 "consistency": res.consistency or consistency(res.forward),
                 "alignment": res.alignment}
    if res.optional_states:
        out["error_states"] = error_states(res.optional_states)
    if res.noise is not None:
        out["noise"] = res.noise.summary()
    if ref is not None:
        out["rmse"] = _rmse_block(res.forward, ref)
        if res.smoothed is not None:
            out["rmse_smoothed"] = _rmse_block(res.smoothed, ref)
        if res.outages:
            out["outages"] = _outage_blocks(res, ref)
    if res.integrity is not None:
        errs = None
        if ref is not None:
            e = _errors(res.forward, ref)
            errs = {"t": e["t"], "horizontal": np.hypot(e["east_m"], e["north_m"]),
                    "vertical": e["up_m"], "heading": e.get("yaw_rad")}
        out["integrity"] = res.integrity.summary(errs)
        if errs is not None:  # (the Stanford diagram's regions, stanford.png)
            from .stanford import regions

            ig, cfg = res.integrity, res.integrity.config
            i = ig.rows_at(errs["t"])
            out["integrity"]["stanford"] = {
                axis: regions(errs[axis], np.interp(errs["t"], ig.t, lvl), ig.detected[i],
                              lim)
                for axis, lvl, lim in (
                    ("horizontal", ig.hpl, cfg and cfg.alert_limit_horizontal_m),
                    ("vertical", ig.vpl, cfg and cfg.alert_limit_vertical_m))}
    for name, other in (others or {}).items():
        block = {"source": other.source, "rmse": _rmse_block(res.forward, other)}
        if res.smoothed is not None:
            block["rmse_smoothed"] = _rmse_block(res.smoothed, other)
        out.setdefault("against", {})[name] = block
    return out


#: The error series ``write`` has computed, by (solution, reference) (while it runs).
_MEMO: dict | None = None


def _errors(sol: Solution, ref: Reference) -> dict:
    """:func:`~fednav.process.run.errors_against`, once per solution and reference while
    :func:`write` runs (its summary, errors file and plots each want them; 55 ms a pair
    for a 10-minute drive).  The series are shared: read them, do not change them."""
    if _MEMO is None:
        return errors_against(sol, ref)
    key = (id(sol), id(ref))
    if key not in _MEMO:
        _MEMO[key] = (sol, ref, errors_against(sol, ref))  # (holds them: ids stay theirs)
    return _MEMO[key][2]


def _outage_blocks(res: ProcessResult, ref: Reference) -> dict:
    """Per sensor with ``outages_s``: each window withheld, with the RMSE of the forward
    (and smoothed) solution inside it (:func:`fednav.process.outages.scored`)."""
    out = {}
    for name, windows in res.outages.items():
        rows = outages.scored(_errors(res.forward, ref), windows)
        if res.smoothed is not None:
            for row, sm in zip(rows, outages.scored(_errors(res.smoothed, ref), windows),
                               strict=True):
                row["rmse_smoothed"] = sm["rmse"]
        for row in rows:
            for key in ("rmse", "rmse_smoothed"):
                if key in row:
                    row[key] = {k: row[key][k] for k in RMSE_KEYS if k in row[key]}
        out[name] = rows
    return out


def _rmse_block(sol: Solution, ref: Reference) -> dict[str, float]:
    r = rmse(_errors(sol, ref))
    return {k: r[k] for k in RMSE_KEYS if k in r}


def _thin(n: int, most: int = 20_000) -> slice:
    """Every k-th row so that a line of ``n`` points draws at most ``most`` of them."""
    return slice(None, None, max(1, -(-n // most)))


#: errors.png panels, a row per quantity: (error key, sigma column, title) — columns of
#: Solution.sigma for position and velocity, of Solution.sigma_euler for the angles
_PANELS = ((("east_m", 6, "east position"), ("north_m", 7, "north position"),
            ("up_m", 8, "up position")),
           (("ve_mps", 3, "east velocity"), ("vn_mps", 4, "north velocity"),
            ("vu_mps", 5, "up velocity")),
           (("pitch_deg", 0, "pitch"), ("roll_deg", 1, "roll"), ("yaw_deg", 2, "yaw")))
_UNITS = ("m", "m/s", "deg")
_WHAT = ("position error", "velocity error", "attitude error")


def epoch_sigma(sol: Solution) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The solution's 1-sigma at its filter epochs (the state after each update; between
    epochs the IMU-rate sigmas rise towards the next prediction, a sawtooth): ``t`` (K,),
    ``sigma`` (K, 9) and ``sigma_euler`` (K, 3) — every row where the epochs are not
    known."""
    k = slice(None) if sol.epoch_rows is None else sol.epoch_rows
    return sol.t[k], sol.sigma[k], sol.sigma_euler[k]


#: the protection level drawn on each panel (row, sigma column) and its name
_LEVEL_NAMES = {(0, 6): "HPL", (0, 7): "HPL", (0, 8): "VPL", (2, 2): "heading PL"}


def _level_of(sol: Solution, row: int, j: int) -> np.ndarray | None:
    """The protection level a panel draws (m, or deg for the heading), else None."""
    if sol.levels is None or (row, j) not in _LEVEL_NAMES:
        return None
    return sol.levels[{"HPL": "hpl_m", "VPL": "vpl_m",
                       "heading PL": "heading_pl_deg"}[_LEVEL_NAMES[(row, j)]]]


def errors_figure(res: ProcessResult, ref: Reference, fixes=None, title: str = ""):
    """``errors.png`` as a :class:`~matplotlib.figure.Figure`: east, north, up position
    [m], velocity [m/s] and (with a reference attitude) pitch, roll, yaw [deg] errors of
    the forward (and smoothed) solution against ``ref``, each with its filter's +-3 sigma
    at the filter epochs (the smoothed one's from the RTS covariance; over more than 500
    epochs their upper envelope, :func:`fednav.core.plots.envelope`), the protection
    levels when integrity was asked for (HPL on east and north, VPL on up, the
    heading's on yaw), GNSS outages (``fixes``' gaps) shaded, one legend beside the axes."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    sols = [s for s in (res.forward, res.smoothed) if s is not None]
    errs = [_errors(s, ref) for s in sols]
    rmses = [rmse(e) for e in errs]
    rows = 3 if "yaw_rad" in errs[0] else 2
    fig, axes = plots.new_figure(rows, 3, figsize=(15, 3.0 * rows + 0.9), sharex=True)
    styles = plots.mode_styles([s.label for s in sols])
    outages = plots.gaps(fixes.t) if fixes is not None and fixes.t is not None else []
    sigmas = [epoch_sigma(s) for s in sols]
    for i, panels in enumerate(_PANELS[:rows]):
        unit = _UNITS[i]
        for ax, (key, j, name) in zip(axes[i], panels, strict=True):
            angle = i == 2
            ek = key[:-4] + "_rad" if angle else key
            arrays = []
            for e, (te, sg, sge), st in zip(errs, sigmas, styles.values(), strict=True):
                k = _thin(len(e["t"]))
                v = units.to_deg(e[ek][k]) if angle else e[ek][k]
                ax.plot(e["t"][k], v, color=st["color"], lw=0.8)
                ts, sd = plots.envelope(te, units.to_deg(sge[:, j]) if angle else sg[:, j])
                for sgn in (1, -1):
                    ax.plot(ts, sgn * 3 * sd, color=st["color"], ls=":", lw=1.0, gid="sigma")
                arrays += [v, 3 * sd]
            level = _level_of(res.forward, i, j)
            if level is not None:  # (the protection level, when integrity was asked for)
                k = _thin(len(res.forward.t))
                for sgn in (1, -1):
                    ax.plot(res.forward.t[k], sgn * level[k], color="k", ls="--", lw=0.9,
                            gid="protection_level")
            plots.shade_spans(ax, outages, facecolor="tab:red", alpha=0.12)
            # the start-up transient (alignment, heading not yet known) would set the scale
            lim = 1.1 * max(plots.robust_scale(a) for a in arrays)
            off = level is not None and plots.robust_scale(level) > 5 * lim
            if level is not None and not off:  # (a level far above the errors: said)
                lim = max(lim, 1.1 * plots.robust_scale(level))
            ax.set_ylim(-lim, lim)
            rms = ", ".join(f"{s.label} {r[key]:.3g}" for s, r in zip(sols, rmses, strict=True))
            pl = "" if level is None else (f"; {_LEVEL_NAMES[(i, j)]} median "
                                             f"{np.median(level[np.isfinite(level)]):.3g}"
                                             + (" (off scale)" if off else ""))
            ax.set_title(f"{name}\nRMSE {rms} {unit}{pl}", fontsize=9.5)
            ax.set_ylabel(f"{name} error [{unit}]")
            ax.axhline(0.0, color="0.6", lw=0.6, zorder=0)
            ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    handles = []
    for s, st in zip(sols, styles.values(), strict=True):
        handles += [Line2D([], [], color=st["color"], lw=1.3, label=f"{s.label} error"),
                    Line2D([], [], color=st["color"], ls=":", lw=1.0,
                           label=f"{s.label} ±3σ (at filter epochs)")]
    if res.forward.levels is not None:
        handles.append(Line2D([], [], color="k", ls="--", lw=0.9,
                              label="protection levels"))
    if outages:
        handles.append(Patch(facecolor="tab:red", alpha=0.2, label="GNSS outage"))
    plots.legend_outside(fig, handles, x=0.84, y=0.92)
    fig.suptitle(f"Navigation errors (solution − reference){' ' + title if title else ''}"
                 f", reference {Path(str(ref.source)).name}", fontsize=11)
    fig.subplots_adjust(left=0.06, right=0.83, bottom=0.07 if rows == 3 else 0.1,
                        top=0.89 if rows == 3 else 0.84, wspace=0.28, hspace=0.42)
    return fig


def plot_errors(res: ProcessResult, ref: Reference, path: Path, fixes=None,
                title: str = "") -> Path:
    """Plot the solution's errors against a reference (``errors.png`` of ``fednav
    process``; :func:`errors_figure`).

    Position east, north, up [m], velocity [m/s] and, with a reference attitude, pitch,
    roll, yaw [deg] errors of the forward (and smoothed) solution with their +-3 sigma.

    Parameters
    ----------
    res : ProcessResult
        What :func:`fednav.process_data` gave (its ``forward`` and ``smoothed``).
    ref : Reference
        The reference (:func:`fednav.read_reference_csv`; lat/lon [rad], h [m], ENU
        velocity [m/s]).
    path : str or Path
        The image file to write (its suffix picks the format: ``.png``, ``.pdf``, ...).
    fixes : GnssData, optional
        The GNSS data, to shade its outages (gaps in its time stamps [s]).
    title : str
        The figure's title.

    Returns
    -------
    Path
        The file written.
    """
    return plots.save(errors_figure(res, ref, fixes, title), path)


def write_errors(res: ProcessResult, ref: Reference, path: Path,
                 output_rate: float | str | None = "imu") -> Path:
    """``errors.csv``: the forward (and smoothed, ``*_smoothed``) solution minus the
    reference at the reference's time stamps: ``east_m, north_m, up_m, ve_mps, vn_mps,
    vu_mps`` and, with a reference attitude, ``pitch_deg, roll_deg, yaw_deg``
    (:func:`~fednav.process.run.errors_against`; 10 significant digits), thinned like
    the solution to ``output_rate`` (:func:`decimate`; ``"imu"``: every reference
    stamp)."""
    cols = {}
    for sol, tag in ((res.forward, ""), (res.smoothed, "_smoothed")):
        if sol is None:
            continue
        err = _errors(sol, ref)
        if not cols:
            cols["t_s"] = err["t"]
        for k, v in err.items():
            if k.endswith("_rad"):
                cols[k[:-4] + "_deg" + tag] = units.to_deg(v)
            elif k != "t":
                cols[k + tag] = v
    k = _thin_stamps(cols["t_s"], res.forward, output_rate)
    return write_csv(path, {c: v[k] for c, v in cols.items()})


def _thin_stamps(t: np.ndarray, sol: Solution, output_rate) -> slice:
    """Every k-th of the time stamps ``t`` so that they come at most at ``output_rate``
    (:func:`decimate`'s values; ``"filter"``: the filter period of ``sol``)."""
    rate = parse_rate(output_rate)
    if rate == "imu" or len(t) < 2:
        return slice(None)
    if rate == "filter":
        e = sol.t if sol.epoch_rows is None else sol.t[sol.epoch_rows]
        step = float(np.median(np.diff(e))) if len(e) > 1 else 0.0
    else:
        step = 1.0 / (DEFAULT_OUTPUT_RATE_HZ if rate is None else rate)
    return slice(None, None, max(1, int(round(step / float(np.median(np.diff(t)))))))


def _zoom_window(res: ProcessResult, ref: Reference | None, outages):
    """What the track's zoom panel shows: ``(what, rows of the forward solution to frame,
    smallest half-width [m])`` — the longest GNSS outage, else the largest horizontal
    error against the reference past the start-up (framed 8 times as wide as the error),
    else the first 30 s."""
    f = res.forward
    if outages:
        a, b = max(outages, key=lambda o: o[1] - o[0])
        m = (f.t >= a - 0.25 * (b - a)) & (f.t <= b + 0.25 * (b - a))
        return f"longest GNSS outage, {a:.1f}–{b:.1f} s", m, 5.0
    if ref is not None:
        # (past the start-up: the first tenth of the run, a minute at most)
        e = _errors(f, ref)
        h = np.hypot(e["north_m"], e["east_m"])
        h[e["t"] < e["t"][0] + min(60.0, 0.1 * np.ptp(e["t"]))] = np.nan
        if np.isfinite(h).any():
            i = int(np.nanargmax(h))
            tc = float(e["t"][i])
            m = np.zeros(len(f.t), dtype=bool)
            m[min(int(np.searchsorted(f.t, tc)), len(f.t) - 1)] = True
            return (f"largest horizontal error ({h[i]:.2g} m), t = {tc:.1f} s", m,
                    max(1.0, 8.0 * float(h[i])))
    return "first 30 s", f.t <= f.t[0] + 30.0, 5.0


def track_figure(res: ProcessResult, fixes, ref: Reference | None):
    """``track.png`` as a :class:`~matplotlib.figure.Figure`: east/north [m] from the
    first GNSS fix — GNSS fixes, the forward and smoothed solutions and the reference,
    start and end marked, GNSS outages (gaps over 3 median periods) in red on the forward
    track, epochs whose measurement fault detection isolated marked — and a zoom panel
    (the longest outage, else the largest error against the reference, else the start)
    framed on the overview."""
    from matplotlib.patches import Rectangle

    from ..core import earth

    has_fixes = fixes is not None and fixes.lla is not None
    o = fixes.lla[0] if has_fixes else res.forward.lla[0]

    def en(lla):
        d = earth.llh_difference_enu(lla[:, 0], lla[:, 1], lla[:, 2], o[0], o[1], o[2])
        return d[:, 0], d[:, 1]

    from matplotlib.figure import Figure

    fig = Figure(figsize=(15, 7.5))
    ax = fig.add_axes((0.06, 0.08, 0.5, 0.84))
    zax = fig.add_axes((0.63, 0.4, 0.34, 0.52))
    f = res.forward
    outages = plots.gaps(fixes.t) if fixes is not None and len(fixes.t) > 1 else []
    what, zoom, least = _zoom_window(res, ref, outages)
    if not zoom.any():  # (an outage outside the solution's span)
        what, zoom, least = "first 30 s", f.t <= f.t[0] + 30.0, 5.0
    styles = plots.mode_styles([s.label for s in (res.forward, res.smoothed) if s is not None])
    # what both panels draw, in east/north once: (x, y, format, keywords)
    under, over = [], []
    if has_fixes:
        under.append((*en(fixes.lla), ".", dict(ms=2.5, color="0.55", alpha=0.6,
                                               label="GNSS fixes")))
    if ref is not None:
        under.append((*en(ref.lla[_thin(len(ref.t))]), "k-", dict(lw=2.2, alpha=0.3,
                                                                  label="reference")))
    for i, (t0, t1) in enumerate(outages):
        m = (f.t > t0) & (f.t < t1)
        over.append((*en(f.lla[m]), "r-", dict(lw=2.4, label="forward in GNSS outage"
                                                if i == 0 else None)))
    if f.fdi:  # (t, local, nis, dof, threshold, isolated) per measurement
        t_fdi, local, _, _, _, isolated = (np.array(c) for c in zip(*f.fdi, strict=True))
        t_fdi, isolated = t_fdi.astype(float), isolated.astype(bool)
        for name, marker in zip(dict.fromkeys(local.tolist()), "x+*^vo<>sd", strict=False):
            t_iso = t_fdi[(local == name) & isolated]
            if len(t_iso):
                i = np.clip(np.searchsorted(f.t, t_iso), 0, len(f.t) - 1)
                over.append((*en(f.lla[i]), marker, dict(ms=5, color="m",
                                                          label=f"{name} isolated "
                                                                f"({len(t_iso)})")))
    e, n = en(f.lla[[0, -1]])
    over.append((e[0], n[0], "^", dict(ms=11, mfc="tab:green", mec="k", zorder=5,
                                       label="start")))
    over.append((e[1], n[1], "s", dict(ms=9, mfc="tab:red", mec="k", zorder=5, label="end")))
    for a in (ax, zax):
        for x, y, fmt, kw in under:
            a.plot(x, y, fmt, **kw)
        for s, ls, lw in ((res.forward, "-", 1.5), (res.smoothed, (0, (4, 2)), 1.2)):
            if s is not None:
                # the zoom panel draws every row (its window is a few metres wide)
                k = _thin(len(s.t)) if a is ax else slice(None)
                a.plot(*en(s.lla[k]), ls=ls, lw=lw, color=styles[s.label]["color"],
                       label=s.label)
        for x, y, fmt, kw in over:
            a.plot(x, y, fmt, **kw)
        a.set_aspect("equal", adjustable="datalim")
        a.set_xlabel("east [m]")
        a.set_ylabel("north [m]")
        a.grid(alpha=0.3)
    # the zoom: the window's forward (and reference) rows, framed with a margin
    ze, zn = en(f.lla[zoom])
    if ref is not None:
        mr = (ref.t >= f.t[zoom][0]) & (ref.t <= f.t[zoom][-1])
        re, rn = en(ref.lla[mr])
        ze, zn = np.concatenate([ze, re]), np.concatenate([zn, rn])
    half = max(0.6 * max(np.ptp(ze), np.ptp(zn)), least)
    ce, cn = 0.5 * (ze.min() + ze.max()), 0.5 * (zn.min() + zn.max())
    zax.set_xlim(ce - half, ce + half)
    zax.set_ylim(cn - half, cn + half)
    zax.set_aspect("equal", adjustable="box")
    zax.set_title(f"zoom: {what}", fontsize=10)
    ax.add_patch(Rectangle((ce - half, cn - half), 2 * half, 2 * half, fill=False,
                           ec="tab:purple", lw=1.2, zorder=6))
    ax.plot(ce, cn, "o", ms=16, mfc="none", mec="tab:purple", mew=1.2, zorder=6)
    ax.annotate("zoom", (ce, cn), color="tab:purple", fontsize=9, xytext=(10, -14),
                textcoords="offset points")
    ax.set_title(f"Track from the first {'GNSS fix' if has_fixes else 'solution row'} "
                 f"({(f.t[-1] - f.t[0]):.0f} s)", fontsize=11)
    h, lab = ax.get_legend_handles_labels()
    fig.legend(h, lab, loc="upper left", bbox_to_anchor=(0.63, 0.31), ncol=2, fontsize=9,
               frameon=False)
    return fig


def plot_track(res: ProcessResult, fixes, ref: Reference | None, path: Path) -> Path:
    """Plot the track (``track.png`` of ``fednav process``; :func:`track_figure`).

    East and north [m] from the first GNSS fix: the GNSS fixes, the forward and smoothed
    solutions and the reference, start and end marked, GNSS outages and isolated
    measurements shown, with a zoom panel.

    Parameters
    ----------
    res : ProcessResult
        What :func:`fednav.process_data` gave.
    fixes : GnssData or None
        The GNSS fixes (lat/lon [rad], h [m]).
    ref : Reference or None
        The reference trajectory (lat/lon [rad], h [m]).
    path : str or Path
        The image file to write.

    Returns
    -------
    Path
        The file written.
    """
    return plots.save(track_figure(res, fixes, ref), path)


#: the files :func:`write` may write into its folder (``errors_NAME.*`` besides)
OUTPUT_NAMES = ("solution.csv", "solution_smoothed.csv", "solution.parquet",
                "solution_smoothed.parquet", "errors.csv", "errors.png", "track.png",
                "stanford.png", "summary.json", "report.html")


def would_overwrite(out: Path, path: Path) -> bool:
    """Whether writing ``process``'s outputs into ``out`` would replace ``path``."""
    from ..sensors import registry

    path, out = Path(path).resolve(), Path(out).resolve()
    return path.parent == out and (path.name in OUTPUT_NAMES
                                   or (path.name.startswith("errors_")
                                       and path.suffix in (".csv", ".png"))
                                   or (path.suffix == ".png"  # (a sensor's own figure)
                                       and path.stem in registry.SENSORS))


def write(out: Path, res: ProcessResult, ref: Reference | None, inputs: dict,
          output_rate: float | str | None = None, fixes=None,
          others: dict | None = None, fmt: str = "csv",
          drawer: Drawer | None = None) -> list[Path]:
    """Write the solution file(s) at ``output_rate`` (:func:`decimate`: by default
    :data:`DEFAULT_OUTPUT_RATE_HZ`; ``"imu"`` every IMU sample), in ``fmt`` (``csv`` or
    ``parquet``), errors.csv (thinned alike), the plots and summary.json into ``out``;
    returns the files.  The
    figures of summary.json and the plots come from the full-rate solution whatever the
    output rate.  ``others``: further references by name (``errors_NAME.csv``,
    ``errors_NAME.png``, ``against`` in the summary).  ``drawer``: a
    :class:`~fednav.core.drawer.Drawer` that draws the plots while the files are written
    (None: drawn here, in turn)."""
    global _MEMO
    fmt = check_format(fmt)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    _MEMO = {}
    try:
        return _write(out, res, ref, inputs, output_rate, fixes, others, fmt,
                      drawer or Drawer(workers=0))
    finally:
        _MEMO = None


def _write(out, res, ref, inputs, output_rate, fixes, others, fmt,
           drawer: Drawer) -> list[Path]:
    if res.fixes_flown is not None:  # (the outages withheld: the plots shade them)
        fixes = res.fixes_flown
    # the files in their order: a plot is handed to the drawer when met, a data file
    # written after every plot was handed over (while they are drawn)
    steps: list = []

    def draw(fn, *args) -> None:
        steps.append(("drawn", drawer.submit(fn, *args)))

    def write(fn, *args) -> None:
        steps.append(("write", functools.partial(fn, *args)))

    for name, sol in (("solution", res.forward), ("solution_smoothed", res.smoothed)):
        if sol is not None:
            write(write_solution, out / f"{name}.{fmt}", decimate(sol, output_rate))
    draw(plot_track, res, fixes, ref, out / "track.png")
    if ref is not None:
        write(write_errors, res, ref, out / "errors.csv", output_rate)
        draw(plot_errors, res, ref, out / "errors.png", fixes)
        if res.integrity is not None:
            from .stanford import plot_run

            draw(plot_run, res, _errors(res.forward, ref), out / "stanford.png")
    for name, figure in res.figures.items():  # (a sensor's own: the raw GNSS's satellites)
        draw(save_drawn, figure, out / f"{name}.png")
    for name, other in (others or {}).items():
        write(write_errors, res, other, out / f"errors_{name}.csv", output_rate)
        draw(plot_errors, res, other, out / f"errors_{name}.png", fixes,
             f"against {other.source}")
    done = [(how, step() if how == "write" else step) for how, step in steps]
    s = summary(res, ref, inputs, others)
    files = [drawer.result(v) if how == "drawn" else v for how, v in done]
    p = out / "summary.json"  # (the last file: a finished run's mark)
    write_json(p, s)
    files.append(p)
    return files


def save_drawn(draw, path: Path) -> Path:
    """Save the figure ``draw()`` makes to ``path``."""
    return plots.save(draw(), path)

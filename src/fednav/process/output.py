"""Outputs of ``fednav process``: solution CSV files, plots and ``summary.json``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..core import units
from ..core.atomic import save_figure, write_json
from ..io.csvdata import write_csv
from ..io.data import Reference
from ..navigator.solution import consistency as _consistency
from .run import ProcessResult, Solution, errors_against, rmse

#: Columns of the RMSE block of summary.json (attitude ones only with a reference attitude).
RMSE_KEYS = ("north_m", "east_m", "down_m", "vn_mps", "ve_mps", "vd_mps", "roll_deg",
             "pitch_deg", "yaw_deg")


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
    }


def solution_decimals(names) -> dict[str, int]:
    """Decimals of each solution column: time 1 us, latitude/longitude 1e-9 deg (0.1 mm),
    height 0.1 mm, velocity 10 um/s, angles 1e-6 deg, sigmas 1e-6 of their unit."""
    def d(name):
        if name == "t_s" or name.startswith("sigma_"):
            return 6
        return {"lat_deg": 9, "lon_deg": 9, "h_m": 4}.get(name, 5 if name.endswith("mps")
                                                         else 6)
    return {k: d(k) for k in names}


def decimate(sol: Solution, rate_hz: float | None) -> Solution:
    """Every ``round(1 / (rate_hz dt))``-th row of an IMU-rate solution, starting with the
    first (None: every row).  A rate above the IMU's is a ValueError."""
    if rate_hz is None:
        return sol
    dt = float(sol.t[1] - sol.t[0]) if len(sol.t) > 1 else 1.0
    if not rate_hz > 0 or rate_hz > 1.0 / dt * (1 + 1e-9):
        raise ValueError(f"--output-rate {rate_hz:g} Hz: must be positive and at most the IMU "
                         f"rate ({1.0 / dt:g} Hz)")
    return sol.rows(slice(None, None, max(1, int(round(1.0 / (rate_hz * dt))))))


def consistency(sol: Solution) -> dict[str, dict[str, float]]:
    """Per local filter: mean normalized innovation squared per degree of freedom and the
    fraction isolated (:func:`fednav.navigator.solution.consistency` of ``sol.fdi``)."""
    return _consistency(sol.fdi)


def summary(res: ProcessResult, ref: Reference | None, inputs: dict,
            others: dict | None = None) -> dict:
    """``summary.json`` content; ``others``: further references by name (an autopilot's
    own estimate), each compared under ``against``."""
    quality = dict(res.data_quality)
    if ref is not None:
        quality.update(ref.quality)
    out: dict = {"inputs": inputs, "run_time_s": res.run_time_s, "epochs": res.epochs,
                 "data_quality": quality, "warnings": list(res.warnings),
                 "consistency": consistency(res.forward), "alignment": res.alignment}
    if ref is not None:
        out["rmse"] = _rmse_block(res.forward, ref)
        if res.smoothed is not None:
            out["rmse_smoothed"] = _rmse_block(res.smoothed, ref)
    for name, other in (others or {}).items():
        block = {"source": other.source, "rmse": _rmse_block(res.forward, other)}
        if res.smoothed is not None:
            block["rmse_smoothed"] = _rmse_block(res.smoothed, other)
        out.setdefault("against", {})[name] = block
    return out


def _rmse_block(sol: Solution, ref: Reference) -> dict[str, float]:
    r = rmse(errors_against(sol, ref))
    return {k: r[k] for k in RMSE_KEYS if k in r}


def _thin(n: int, most: int = 20_000) -> slice:
    """Every k-th row so that a line of ``n`` points draws at most ``most`` of them."""
    return slice(None, None, max(1, -(-n // most)))


#: errors.png panels, a row per quantity: (error key, sigma column) — columns of
#: Solution.sigma for position and velocity, of Solution.sigma_euler for the angles
_PANELS = ((("north_m", 7), ("east_m", 6), ("down_m", 8)),
           (("vn_mps", 4), ("ve_mps", 3), ("vd_mps", 5)),
           (("roll_deg", 1), ("pitch_deg", 0), ("yaw_deg", 2)))


def plot_errors(res: ProcessResult, ref: Reference, path: Path) -> Path:
    """Plot the solution's errors against a reference (``errors.png`` of ``fednav
    process``).

    Position north, east, down [m], velocity [m/s] and, with a reference attitude, roll,
    pitch, yaw [deg] errors of the forward (and smoothed) solution with the forward
    filter's +-3 sigma.

    Parameters
    ----------
    res : ProcessResult
        What :func:`fednav.process_data` gave (its ``forward`` and ``smoothed``).
    ref : Reference
        The reference (:func:`fednav.read_reference_csv`; lat/lon [rad], h [m], ENU
        velocity [m/s]).
    path : str or Path
        The image file to write (its suffix picks the format: ``.png``, ``.pdf``, ...).

    Returns
    -------
    Path
        The file written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sols = [s for s in (res.forward, res.smoothed) if s is not None]
    errs = [errors_against(s, ref) for s in sols]
    rows = 3 if "yaw_rad" in errs[0] else 2
    fig, axes = plt.subplots(rows, 3, figsize=(14, 3.0 * rows + 0.5), sharex=True)
    f = res.forward
    r = rmse(errs[0])
    th = _thin(len(f.t))
    for i, panels in enumerate(_PANELS[:rows]):
        for ax, (key, j) in zip(axes[i], panels, strict=True):
            angle = i == 2
            ek = key[:-4] + "_rad" if angle else key
            for s, e in zip(sols, errs, strict=True):
                k = _thin(len(e["t"]))
                v = units.to_deg(e[ek][k]) if angle else e[ek][k]
                ax.plot(e["t"][k], v, lw=0.7, label=s.label)
            sd = units.to_deg(f.sigma_euler[th, j]) if angle else f.sigma[th, j]
            ax.plot(f.t[th], 3 * sd, "k:", lw=0.7, label="forward ±3σ")
            ax.plot(f.t[th], -3 * sd, "k:", lw=0.7)
            lim = 8 * r[key]  # the start-up transient would otherwise set the scale
            ax.set_ylim(-lim, lim)
            ax.set_title(f"{key} (forward RMSE {r[key]:.3g})", fontsize=9)
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
    return path


def write_errors(res: ProcessResult, ref: Reference, path: Path) -> Path:
    """``errors.csv``: the forward (and smoothed, ``*_smoothed``) solution minus the
    reference at the reference's time stamps: ``north_m, east_m, down_m, vn_mps, ve_mps,
    vd_mps`` and, with a reference attitude, ``pitch_deg, roll_deg, yaw_deg``
    (:func:`~fednav.process.run.errors_against`; 10 significant digits)."""
    cols = {}
    for sol, tag in ((res.forward, ""), (res.smoothed, "_smoothed")):
        if sol is None:
            continue
        err = errors_against(sol, ref)
        if not cols:
            cols["t_s"] = err["t"]
        for k, v in err.items():
            if k.endswith("_rad"):
                cols[k[:-4] + "_deg" + tag] = units.to_deg(v)
            elif k != "t":
                cols[k + tag] = v
    return write_csv(path, cols)


def plot_track(res: ProcessResult, gnss, ref: Reference | None, path: Path) -> Path:
    """Plot the track (``track.png`` of ``fednav process``).

    East and north [m] from the first GNSS fix: the GNSS fixes, the forward and smoothed
    solutions and the reference; GNSS outages (gaps over 3 median periods) drawn in red
    on the forward track, epochs whose measurement fault detection isolated marked.

    Parameters
    ----------
    res : ProcessResult
        What :func:`fednav.process_data` gave.
    gnss : GnssData or None
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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..core import earth

    fixes = gnss is not None and gnss.lla is not None
    o = gnss.lla[0] if fixes else res.forward.lla[0]

    def en(lla):
        d = earth.llh_difference_enu(lla[:, 0], lla[:, 1], lla[:, 2], o[0], o[1], o[2])
        return d[:, 0], d[:, 1]

    fig, ax = plt.subplots(figsize=(8, 7))
    if fixes:
        ax.plot(*en(gnss.lla), ".", ms=2, color="0.6", label="GNSS")
    if ref is not None:
        k = _thin(len(ref.t))
        ax.plot(*en(ref.lla[k]), "k-", lw=1.5, alpha=0.35, label="reference")
    for s in (res.forward, res.smoothed):
        if s is not None:
            k = _thin(len(s.t))
            ax.plot(*en(s.lla[k]), lw=0.9, label=s.label)
    f = res.forward
    outages = []
    if gnss is not None and len(gnss.t) > 1:
        gap = 3.0 * float(np.median(np.diff(gnss.t)))
        outages = [(a, b) for a, b in zip(gnss.t[:-1], gnss.t[1:], strict=True) if b - a > gap]
    for i, (a, b) in enumerate(outages):
        m = (f.t > a) & (f.t < b)
        ax.plot(*en(f.lla[m]), "r-", lw=2.0, label="GNSS outage" if i == 0 else None)
    if f.fdi:
        log = pd.DataFrame(f.fdi, columns=["t", "local", "nis", "dof", "thr", "isolated"])
        for name, marker in zip(log.local.unique(), "x+*^vo<>sd", strict=False):
            t_iso = log.t[(log.local == name) & log.isolated].to_numpy(dtype=float)
            if len(t_iso):
                i = np.clip(np.searchsorted(f.t, t_iso), 0, len(f.t) - 1)
                ax.plot(*en(f.lla[i]), marker, ms=5, color="m",
                        label=f"{name} isolated ({len(t_iso)})")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
    return path


#: the files :func:`write` may write into its folder (``errors_NAME.*`` besides)
OUTPUT_NAMES = ("solution.csv", "solution_smoothed.csv", "errors.csv", "errors.png",
                "track.png", "summary.json", "report.html")


def would_overwrite(out: Path, path: Path) -> bool:
    """Whether writing ``process``'s outputs into ``out`` would replace ``path``."""
    path, out = Path(path).resolve(), Path(out).resolve()
    return path.parent == out and (path.name in OUTPUT_NAMES
                                   or (path.name.startswith("errors_")
                                       and path.suffix in (".csv", ".png")))


def write(out: Path, res: ProcessResult, ref: Reference | None, inputs: dict,
          output_rate: float | None = None, gnss=None,
          others: dict | None = None) -> list[Path]:
    """Write solution CSV(s) (every IMU sample, or decimated to ``output_rate`` Hz), the
    plots and summary.json into ``out``; returns the files.  ``others``: further
    references by name (``errors_NAME.csv``, ``errors_NAME.png``, ``against`` in the
    summary)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    for name, sol in (("solution.csv", res.forward), ("solution_smoothed.csv", res.smoothed)):
        if sol is not None:
            cols = solution_columns(decimate(sol, output_rate))
            files.append(write_csv(out / name, cols, solution_decimals(cols)))
    files.append(plot_track(res, gnss, ref, out / "track.png"))
    if ref is not None:
        files.append(write_errors(res, ref, out / "errors.csv"))
        files.append(plot_errors(res, ref, out / "errors.png"))
    for name, other in (others or {}).items():
        files.append(write_errors(res, other, out / f"errors_{name}.csv"))
        files.append(plot_errors(res, other, out / f"errors_{name}.png"))
    s = summary(res, ref, inputs, others)
    p = out / "summary.json"
    write_json(p, s)
    files.append(p)
    return files

"""Outputs of ``fednav process``: solution CSV files, plots and ``summary.json``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from . import units
from .atomic import save_figure, write_text
from .io.csvdata import write_csv
from .io.data import Reference
from .process import ProcessResult, Solution, errors_against, rmse

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
    }


def consistency(sol: Solution) -> dict[str, dict[str, float]]:
    """Per local filter: mean normalized innovation squared per degree of freedom (about 1
    for a consistent filter; well above 1: the noise figures are too optimistic) and the
    fraction of measurements isolated by fault detection."""
    if not sol.fdi:
        return {}
    log = pd.DataFrame(sol.fdi, columns=["t", "local", "nis", "dof", "thr", "isolated"])
    out = {}
    for name, g in log.groupby("local"):
        out[str(name)] = {"nis_per_dof": float((g.nis / g.dof).mean()),
                          "isolated_fraction": float(g.isolated.mean()),
                          "measurements": int(len(g))}
    return out


def summary(res: ProcessResult, ref: Reference | None, inputs: dict) -> dict:
    """``summary.json`` content."""
    quality = dict(res.data_quality)
    if ref is not None:
        quality.update(ref.quality)
    out: dict = {"inputs": inputs, "run_time_s": res.run_time_s, "epochs": res.epochs,
                 "data_quality": quality, "warnings": list(res.warnings),
                 "consistency": consistency(res.forward)}
    if ref is not None:
        out["rmse"] = _rmse_block(res.forward, ref)
        if res.smoothed is not None:
            out["rmse_smoothed"] = _rmse_block(res.smoothed, ref)
    return out


def _rmse_block(sol: Solution, ref: Reference) -> dict[str, float]:
    r = rmse(errors_against(sol, ref))
    return {k: r[k] for k in RMSE_KEYS if k in r}


def plot(res: ProcessResult, ref: Reference | None, path: Path) -> Path:
    """Trajectory and (with a reference) position/velocity errors with the filter's 3-sigma."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sols = [s for s in (res.forward, res.smoothed) if s is not None]
    if ref is None:
        fig, ax = plt.subplots(figsize=(6, 6))
        for s in sols:
            ax.plot(units.to_deg(s.lla[:, 1]), units.to_deg(s.lla[:, 0]), label=s.label)
        ax.set_xlabel("longitude [deg]")
        ax.set_ylabel("latitude [deg]")
        ax.legend()
    else:
        fig, axes = plt.subplots(2, 3, figsize=(13, 6), sharex=True)
        names = (("north_m", 7), ("east_m", 6), ("down_m", 8), ("vn_mps", 4), ("ve_mps", 3),
                 ("vd_mps", 5))
        for s in sols:
            e = errors_against(s, ref)
            for ax, (k, _) in zip(axes.flat, names, strict=True):
                ax.plot(e["t"], e[k], lw=0.7, label=s.label)
        f = res.forward
        r = rmse(errors_against(f, ref))
        for ax, (k, j) in zip(axes.flat, names, strict=True):
            ax.plot(f.t, 3 * f.sigma[:, j], "k:", lw=0.7)
            ax.plot(f.t, -3 * f.sigma[:, j], "k:", lw=0.7, label="forward ±3σ")
            lim = 8 * r[k]  # the start-up transient would otherwise set the scale
            ax.set_ylim(-lim, lim)
            ax.set_title(f"{k} (forward RMSE {r[k]:.3g})")
            ax.grid(alpha=0.3)
        axes[0, 0].legend(fontsize=7)
        for ax in axes[1]:
            ax.set_xlabel("t [s]")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
    return path


def write(out: Path, res: ProcessResult, ref: Reference | None, inputs: dict) -> list[Path]:
    """Write solution CSV(s), the plot and summary.json into ``out``; returns the files."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files = [write_csv(out / "solution.csv", solution_columns(res.forward))]
    if res.smoothed is not None:
        files.append(write_csv(out / "solution_smoothed.csv", solution_columns(res.smoothed)))
    files.append(plot(res, ref, out / ("errors.png" if ref is not None else "trajectory.png")))
    s = summary(res, ref, inputs)
    p = out / "summary.json"
    write_text(p, json.dumps(s, indent=2))
    files.append(p)
    return files

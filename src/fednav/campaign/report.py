"""Reproduction reports: summary.json, per-run CSV, side-by-side tables and error plots."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd
from rich.console import Console
from rich.table import Table

from ..core import plots, units
from ..core.atomic import write_frame, write_json
from .evaluation import NULL_REASONS, mean_ci95
from .numbers import (  # noqa: F401  (ARCSEC_BELOW_DEG, attitude_unit: read here for
    # one more release, CHANGELOG.md; their place is campaign.numbers)
    ARCSEC_BELOW_DEG,
    attitude_unit,
    format_attitude,
    format_number,
    is_attitude_deg,
)


def summarize(rows: list[dict], paper_tables: dict, paper: str, runs: int, seed: int) -> dict:
    """``summary.json`` structure: tables -> rows -> columns -> {ours, ci95, paper}."""
    df = pd.DataFrame(rows)
    tables = {}
    for tname, trows in paper_tables.items():
        out_rows = {}
        for row, cols in trows.items():
            sub = df[df["mode"] == row]
            if sub.empty:
                continue
            out_rows[row] = {}
            for col, pv in cols.items():
                m, h = mean_ci95(sub[col].to_numpy())
                out_rows[row][col] = {"ours": m, "ci95": h, "paper": pv}
        tables[tname] = {"rows": out_rows}
    return {"paper": paper, "runs": runs, "seed": seed, "tables": tables}


def print_tables(summary: dict, titles: dict[str, str], console: Console | None = None) -> None:
    """Print each table as the HTML report shows it: a row per filter (and statistic), a
    column per measure with its label and unit; each cell fednav's value (± 95 % CI where
    the Monte Carlo gives one), the paper's value and the ratio, and outside ×3 whether
    that is better or worse than the paper (:mod:`fednav.campaign.explain`; timings are
    not judged).  Under the tables, the reason of each worse cell and the docs section
    that explains it."""
    from rich.markup import escape

    from . import explain

    console = console or Console()
    paper = str(summary.get("paper", ""))
    reasons: list = []
    for tname, t in summary["tables"].items():
        if not t.get("rows"):
            continue
        g = explain.grid(t)
        head = f"{titles.get(tname) or t.get('title') or f'Table {tname}'}\n" + explain.what(
            t, summary.get("runs"), summary.get("seed"), g)
        if g.has_paper:
            head += " | paper | fednav / paper"
        console.print(f"[bold]{escape(head)}[/]", highlight=False)  # (a title would wrap)
        tab = Table()
        tab.add_column("")
        if g.stats:
            tab.add_column("statistic")
        for c in g.shown:
            tab.add_column(escape(explain.label(c)), justify="right")
        last = None
        keys = list(g.cells)
        for k, ((row, stat), by_col) in enumerate(g.cells.items()):
            cells = []
            for c in g.shown:
                v = by_col.get(c)
                if v is None:
                    cells.append("–")
                    continue
                num = (partial(format_attitude, unit_of=v.get("ours"))
                       if is_attitude_deg(c) else format_number)
                text = num(v.get("ours"))
                if explain.present(v.get("ci95")):
                    text += f" ± {num(v['ci95'])}"
                if v.get("paper") is not None:
                    q = f"{c} / {stat}" if stat else c
                    verdict = explain.compare(v.get("ours"), v["paper"], q)
                    paper_text = (format_attitude(v["paper"]) if is_attitude_deg(c)
                                  else format_number(v["paper"]))
                    text += f" | {paper_text} {verdict.text}"
                    if verdict.kind == "better":
                        text += " [green]better[/]"
                    elif verdict.kind == "timing":
                        text += " (timing: not compared)"
                    elif verdict.flagged:
                        r = explain.reason(paper, tname, row, q)
                        if r is not None and r not in reasons:
                            reasons.append(r)
                        text += f" [red]{verdict.kind}[/]" + (
                            "" if r is None else f" \\[{reasons.index(r) + 1}]")
                text += "".join(f" ({escape(k)}: {format_number(x)})"
                                for k, x in explain.extras(v))
                cells.append(text)
            first = [escape(explain.row_label(row)) if row != last else ""]
            last = row
            nxt = keys[k + 1][0] if k + 1 < len(keys) else None
            tab.add_row(*first, *([escape(stat)] if g.stats else []), *cells,
                        end_section=nxt != row)
        console.print(tab)
        if g.left_out:
            console.print("not computed in this run (no value in any row): "
                          + escape(", ".join(explain.label(c) for c in g.left_out)),
                          highlight=False)
    if reasons:
        console.print(f"Why cells are worse than the paper (outside ×{explain.FAR:g}):")
        for i, r in enumerate(reasons, 1):
            console.print(f"  \\[{i}] {escape(r.text)} — {r.doc}#{r.anchor}", highlight=False)


def write_outputs(out: Path, summary: dict, rows: list[dict], series: dict) -> list[Path]:
    """Write summary.json, runs.csv and error plots of the first run into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    written = [write_frame(pd.DataFrame(rows), out / "runs.csv")]
    if series:
        written.append(plot_errors(series, out / "errors.png"))
    written.insert(0, write_json(out / "summary.json", summary, why=NULL_REASONS))
    return written


#: errors.png of a reproduction, a row per quantity: (RunResult attribute, first column of
#: RunResult.sigma, factor from SI, the three components' names, what, unit)
_QUANTITIES = (("pos", 6, 1.0, ("east", "north", "up"), "position error", "m"),
               ("vel", 3, 1.0, ("east", "north", "up"), "velocity error", "m/s"),
               ("att", 0, 1.0 / units.ARCSEC, ("φE (east)", "φN (north)", "φU (azimuth)"),
                "misalignment", "arcsec"))


def error_statistics(runs_series, mode: str, quantities=_QUANTITIES) -> dict:
    """One mode's errors over the Monte Carlo runs: ``t`` (K,) and ``panels``, row-major
    over ``quantities`` (:data:`_QUANTITIES`) x their three components, each the
    :func:`fednav.core.plots.monte_carlo` statistics (``rms``, ``lo``, ``hi`` and, where
    the runs carry the filter's 1-sigma, ``sigma``) in the panel's unit."""
    res = [rs[mode] for rs in runs_series if mode in rs]
    n = min(len(r.t) for r in res)
    panels = []
    for attr, s0, k, _, _, _ in quantities:
        for j in range(3):
            e = np.stack([getattr(r, attr)[:n, j] for r in res]) * k
            sig = None
            if all(r.sigma is not None and r.sigma.shape[0] >= n for r in res):
                sig = np.stack([r.sigma[:n, s0 + j] for r in res]) * k
            panels.append(plots.monte_carlo(e, sig))
    return {"t": res[0].t[:n], "runs": len(res), "panels": panels}


def errors_figure(runs_series, title: str = "", quantities=_QUANTITIES,
                  time_label: str = "time [s]"):
    """The reproduction's ``errors.png`` as a :class:`~matplotlib.figure.Figure`: east,
    north, up position [m], velocity [m/s] and misalignment [arcsec] errors versus time,
    per mode the RMS over the Monte Carlo runs (line), the 5-95 % band of the runs' signed
    errors (shaded) and the filter's +-3 sigma averaged over the runs (dotted, where the
    runs carry it).  ``runs_series``: one dict mode -> RunResult per run (or one such
    dict); ``quantities``: the rows (:data:`_QUANTITIES`: RunResult's; paper 001 gives
    its launch-frame ones).  Modes are drawn from wide to narrow lines; modes whose
    curves coincide in every panel are drawn dashed over solid and named in a note,
    those that coincide in one panel named in its title; a mode far off the others'
    scale (a free INS) runs off the linear axes, also noted."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    if isinstance(runs_series, dict):
        runs_series = [runs_series]
    modes = list(runs_series[0])
    stats = {m: error_statistics(runs_series, m, quantities) for m in modes}
    curves = {m: [a for p in s["panels"] for a in (p["rms"], p["lo"], p["hi"])]
              for m, s in stats.items()}
    groups = plots.coinciding_groups(curves)
    styles = plots.mode_styles(modes, groups)
    fig, axes = plots.new_figure(3, 3, figsize=(15, 9.8), sharex=True)
    off: dict[str, list[str]] = {}
    for i, (_, _, _, comps, what, unit) in enumerate(quantities):
        for j in range(3):
            ax = axes[i, j]
            scales = {}
            for m in modes:
                s, st = stats[m], styles[m]
                p = s["panels"][3 * i + j]
                ax.fill_between(s["t"], p["lo"], p["hi"], color=st["color"], alpha=0.1,
                                lw=0)
                ax.plot(s["t"], p["rms"], color=st["color"], ls=st["ls"], lw=st["lw"])
                arrays = [p["rms"], p["lo"], p["hi"]]
                sig = p.get("sigma")
                if sig is not None and np.isfinite(sig).any():
                    for sgn in (1, -1):
                        ax.plot(s["t"], sgn * 3 * sig, color=st["color"], ls=":", lw=0.9,
                                alpha=0.9, gid="sigma")
                    arrays.append(3 * sig)
                scales[m] = max(plots.robust_scale(a) for a in arrays)
            here = plots.coinciding_groups(
                {m: [stats[m]["panels"][3 * i + j][k] for k in ("rms", "lo", "hi")]
                 for m in modes})
            here = [g for g in here if not any(set(g) <= set(h) for h in groups)]
            lim, gone = plots.shared_limit(scales)
            ax.set_ylim(-lim, lim)
            for m in gone:
                peak = max(np.nanmax(np.abs(stats[m]["panels"][3 * i + k]["rms"]))
                           for k in range(3))
                off.setdefault(m, [])
                if not any(x.startswith(what) for x in off[m]):
                    off[m].append(f"{what} up to {format_number(peak)} {unit}")
            head = f"{comps[j]} {what.split()[0]}"
            if here and len(here) == 1 and len(here[0]) == len(modes):
                head += f" (all {len(modes)} modes coincide)"
            elif here:
                head += " (coincide: " + "; ".join(" ≈ ".join(g) for g in here) + ")"
            ax.set_title(head, fontsize=9.5)
            ax.set_ylabel(f"{what} [{unit}]")
            ax.axhline(0.0, color="0.6", lw=0.6, zorder=0)
            ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel(time_label)
    runs = max(s["runs"] for s in stats.values())
    handles = [Line2D([], [], color=styles[m]["color"], ls=styles[m]["ls"],
                      lw=styles[m]["lw"], label=m) for m in modes]
    handles += [Line2D([], [], color="k", lw=1.3, label=f"RMS over {runs} run"
                                                         f"{'s' if runs != 1 else ''}"),
                Patch(facecolor="0.4", alpha=0.3, lw=0, label="5–95 % of the runs"),
                Line2D([], [], color="k", ls=":", lw=0.9,
                       label="filter ±3σ (mean over runs)")]
    plots.legend_outside(fig, handles, x=0.815, y=0.93)
    notes = [plots.identical_note(groups, curves)]
    notes += [f"off the axes: {m} ({', '.join(v)})" for m, v in off.items()]
    plots.note(fig, "\n".join(n for n in notes if n))
    fig.suptitle(f"{title + ': ' if title else ''}navigation errors (computed − true), "
                 f"{runs} Monte Carlo run{'s' if runs != 1 else ''}")
    # A fixed layout: tight_layout would draw every axis twice (half the plotting time).
    fig.subplots_adjust(left=0.055, right=0.8, bottom=0.085, top=0.93, wspace=0.3,
                        hspace=0.22)
    return fig


def plot_errors(runs_series, path: Path, title: str = "") -> Path:
    """Write :func:`errors_figure` to ``path``."""
    return plots.save(errors_figure(runs_series, title), path)


def fdi_figure(fdi: pd.DataFrame, title: str = ""):
    """Chi-square statistic of every local filter against its threshold, isolations
    marked, as a :class:`~matplotlib.figure.Figure`: a panel per local filter (log axis:
    the statistic spans decades), one legend beside the panels."""
    from matplotlib.lines import Line2D

    locals_ = list(dict.fromkeys(fdi["local"]))
    fig, axes = plots.new_figure(len(locals_), 1, figsize=(12, 2.6 * len(locals_) + 0.8),
                                 sharex=True)
    for ax, name in zip(axes[:, 0], locals_, strict=True):
        d = fdi[fdi["local"] == name]
        ax.semilogy(d["t"], d["statistic"], lw=0.8, color="C0")
        if d["threshold"].notna().any():
            ax.plot(d["t"], d["threshold"], "k--", lw=1)
        iso = d[d["isolated"]]
        ax.plot(iso["t"], iso["statistic"], "r.", ms=4)
        ax.set_title(f"local filter '{name}' ({len(iso)} of {len(d)} isolated)", fontsize=9.5)
        ax.set_ylabel("T = r' S⁻¹ r [-]")
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    handles = [Line2D([], [], color="C0", lw=0.8, label="statistic T"),
               Line2D([], [], color="k", ls="--", lw=1, label="threshold"),
               Line2D([], [], color="r", marker=".", ls="", label="isolated")]
    plots.legend_outside(fig, handles, x=0.86, y=0.9)
    fig.suptitle(title or "Chi-square fault detection")
    fig.subplots_adjust(left=0.08, right=0.85, bottom=0.12 if len(locals_) < 3 else 0.07,
                        top=0.86 if len(locals_) < 3 else 0.91, hspace=0.35)
    return fig


def plot_fdi(fdi: pd.DataFrame, path: Path, title: str = "") -> Path:
    """Write :func:`fdi_figure` to ``path``."""
    return plots.save(fdi_figure(fdi, title), path)

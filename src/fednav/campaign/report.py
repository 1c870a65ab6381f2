"""Reproduction reports: summary.json, per-run CSV, side-by-side tables and error plots."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from rich.console import Console
from rich.table import Table

from ..core import units
from ..core.atomic import save_figure, write_frame, write_json
from .evaluation import NULL_REASONS, mean_ci95


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


def format_number(x: float | None) -> str:
    """A table number with 3 significant figures (whole numbers from 100 up); "–" for
    a missing or non-finite value."""
    if x is None or not np.isfinite(x):
        return "–"
    a = abs(x)
    if a >= 100:
        return f"{x:.0f}"
    if a >= 10:
        return f"{x:.1f}"
    if a >= 1:
        return f"{x:.2f}"
    return f"{x:.3g}"


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
                text = format_number(v.get("ours"))
                if explain.present(v.get("ci95")):
                    text += f" ± {format_number(v['ci95'])}"
                if v.get("paper") is not None:
                    q = f"{c} / {stat}" if stat else c
                    verdict = explain.compare(v.get("ours"), v["paper"], q)
                    text += f" | {format_number(v['paper'])} {verdict.text}"
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


def plot_errors(series: dict, path: Path) -> Path:
    """Position, velocity and misalignment errors versus time for each mode (one run)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 3, figsize=(14, 9), sharex=True)
    labels = [("east pos. [m]", "north pos. [m]", "up pos. [m]"),
              ("vE [m/s]", "vN [m/s]", "vU [m/s]"),
              ('phiE ["]', 'phiN ["]', 'phiU ["]')]
    for mode, r in series.items():
        data = (r.pos, r.vel, units.to_arcsec(r.att))
        for i in range(3):
            for j in range(3):
                axes[i, j].plot(r.t, data[i][:, j], lw=0.8, label=mode)
                axes[i, j].set_ylabel(labels[i][j])
    for ax in axes.ravel():
        ax.grid(alpha=0.3)
    for j in range(3):
        axes[2, j].set_xlabel("time [s]")
    axes[0, 0].legend(fontsize=8)
    axes[0, 0].set_yscale("symlog", linthresh=1.0)
    axes[0, 1].set_yscale("symlog", linthresh=1.0)
    fig.suptitle("Navigation errors (computed − true), first Monte Carlo run")
    # A fixed layout: tight_layout would draw every axis twice (half the plotting time).
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.06, top=0.94, wspace=0.22,
                        hspace=0.08)
    save_figure(fig, path)
    plt.close(fig)
    return path


def plot_fdi(fdi: pd.DataFrame, path: Path, title: str = "") -> Path:
    """Chi-square statistic of every local filter against its threshold, isolations marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    locals_ = list(dict.fromkeys(fdi["local"]))
    fig, axes = plt.subplots(len(locals_), 1, figsize=(11, 2.6 * len(locals_)), sharex=True,
                             squeeze=False)
    for ax, name in zip(axes[:, 0], locals_, strict=True):
        d = fdi[fdi["local"] == name]
        ax.semilogy(d["t"], d["statistic"], lw=0.8, label=f"{name}: T = r' S^-1 r")
        if d["threshold"].notna().any():
            ax.plot(d["t"], d["threshold"], "k--", lw=1, label="threshold")
        iso = d[d["isolated"]]
        ax.plot(iso["t"], iso["statistic"], "r.", ms=3, label="isolated")
        ax.set_ylabel("statistic")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(title or "Chi-square fault detection")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
    return path

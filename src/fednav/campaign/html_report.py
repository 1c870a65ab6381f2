"""``report.html``: one self-contained page for a reproduction or ``process`` folder.

A reproduction folder (``fednav reproduce``): every table of ``summary.json`` under its
human title, one row per filter (or case), one column per measure with its label and
unit, each cell fednav's value (± its 95 % CI where the Monte Carlo gives one) over the
paper's value and the ratio.  A cell outside ×3 of the paper is coloured by what it
means (:mod:`fednav.campaign.explain`): green when it is *better* than the paper (a
smaller error, a larger improvement), red when it is worse or, for a measure with no
better side, different — and a red cell links to its reason, a one-line summary of the
section of ``docs/paperNNN.md`` that explains it, quoted at the end of the page.  Timing
columns (``ms_per_cycle``, run time) are shown but not judged: the paper's machine is
another.  The summary's further results (paper 002's observability per flight phase,
the values left out of the tables and why) become labelled tables; the error plots of
the folder are embedded as base64 PNG, with the run metadata (fednav version, scenario
hash, seeds, engine, times) from ``campaign.json`` and ``summary.json``.  A design's
folder (``fednav run``: ``summary.json`` names a ``design``) has no paper column: its
tables give each statistic's value ± 95 % CI.

A ``process`` folder (``summary.json`` with ``epochs`` and ``consistency``): the inputs,
every warning, a summary of the solution file (span, rows, distance, final σ), the
initial alignment, the consistency of each local filter (NIS/dof), the data quality, the
RMSE against each reference and the plots.

Nothing is fetched from the network: the file can be mailed or archived as it is.
"""

from __future__ import annotations

import base64
import json
from datetime import UTC, datetime
from html import escape
from pathlib import Path

from ..core import units
from ..core.errors import FednavError
from . import explain
from .explain import FAR, Reason

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;
max-width:1300px;color:#222;line-height:1.4;padding:0 1em}
h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.2em;margin-top:2em}
h3{font-size:1.02em;margin-top:1.4em}
table{border-collapse:collapse;margin:.5em 0 1em 0;font-size:.9em}
th,td{border-bottom:1px solid #ddd;padding:.25em .6em;text-align:right;vertical-align:top}
th{background:#f3f3f3;font-weight:600}td.l,th.l{text-align:left}
tr.first td{border-top:2px solid #bbb}
td{white-space:nowrap}td .p{display:block;font-size:.8em;color:#666;white-space:normal}
td.l{white-space:normal}
td.worse,td.differs{background:#fbd5d0}td.worse .p,td.differs .p{color:#8a1c10}
td.better{background:#d9f0dc}td.better .p{color:#1d6b2f}
td.timing .p{color:#888;font-style:italic}
span.worse{background:#fbd5d0;color:#8a1c10;padding:0 .2em}
td a.why{font-weight:600;color:#8a1c10;text-decoration:none}
td.better a.why{color:#1d6b2f}
dl{display:grid;grid-template-columns:max-content auto;gap:.2em 1.2em}dt{font-weight:600}
img{max-width:100%;border:1px solid #ddd;margin:.5em 0}
.note{color:#555;font-size:.9em}.legend span{padding:0 .3em}
.legend .better{background:#d9f0dc}.legend .worse{background:#fbd5d0}
.warn{background:#fff4d6;border-left:4px solid #e0a800;padding:.4em .8em;margin:.3em 0}
.reason{margin:.8em 0;padding:.4em .8em;border-left:4px solid #d88}
pre.doc{white-space:pre-wrap;background:#f7f7f7;padding:.6em;font-size:.85em}
"""


class ReportError(FednavError, ValueError):
    """A folder that holds no reproduction or processing run to report on."""


def _num(x, key: str = "", unit_of=None) -> str:
    """A number for a cell; of an attitude key (:func:`~fednav.campaign.report.
    is_attitude_deg`) in arc-seconds below 0.01° (in the unit of ``unit_of`` [deg] when
    given: a CI in its value's)."""
    from .numbers import format_attitude, format_number, is_attitude_deg

    if x is None or isinstance(x, bool) or not isinstance(x, int | float):
        return "–" if x is None else escape(str(x))
    if is_attitude_deg(key):
        return format_attitude(x, unit_of=unit_of)
    return format_number(x)


_present = explain.present


class _Reasons:
    """The reasons the flagged cells point at, numbered in order of first use."""

    def __init__(self, paper: str):
        self.paper = paper
        self.items: list[Reason] = []

    def ref(self, table: str, row: str, quantity: str,
            general: bool = True) -> tuple[int, Reason] | None:
        """The number and reason of a cell (None: none; ``general``: the catch-all
        counts)."""
        r = explain.reason(self.paper, table, row, quantity)
        if r is None or (r.general and not general):
            return None
        if r not in self.items:
            self.items.append(r)
        return self.items.index(r) + 1, r

    def html(self) -> str:
        if not self.items:
            return ""
        d = explain.docs_dir()
        out = ["<h2 id='why'>Why cells differ from the paper</h2>",
               "<p class='note'>Each coloured cell links here. The sections quoted are "
               "those of the documentation that explain the difference.</p>"]
        for i, r in enumerate(self.items, 1):
            where = f"{r.doc}#{r.anchor}"
            link = escape(where)
            if d is not None:
                uri = (d / Path(r.doc).name).as_uri() + f"#{r.anchor}"
                link = f"<a href='{escape(uri)}'>{escape(where)}</a>"
            text = explain.doc_excerpt(r)
            quote = ("" if text is None else
                     f"<details><summary>the section</summary><pre class='doc'>"
                     f"{escape(text)}</pre></details>")
            out.append(f"<div class='reason' id='why-{i}'><strong>[{i}]</strong> {escape(r.text)}. "
                       f"<span class='note'>Explained in {link}.</span>{quote}</div>")
        return "\n".join(out)


_LEGEND = (f"<p class='note legend'>Each cell: fednav's value, under it the paper's and "
           f"the ratio fednav / paper. Outside ×{FAR:g}: "
           "<span class='better'>green</span> better than the paper, "
           "<span class='worse'>red</span> worse (or different, for a measure with no "
           "better side), with its reason [n]; timings are not compared (the paper's "
           "machine is another).</p>")


def table_html(name: str, table: dict, title: str, runs, seed,
               reasons: _Reasons | None = None) -> str:
    """One summary table as HTML: a row per table row (and statistic, for paper 003's
    nested cells), a column per measure; each cell fednav's value ± CI over the paper's
    and the verdict."""
    reasons = reasons or _Reasons("")
    g = explain.grid(table)
    shown, left_out, stats = g.shown, g.left_out, g.stats
    paper_any = g.has_paper
    head = [f"<h2 id='h-{escape(name)}'>{escape(title)}</h2>",
            f"<p class='note'>{escape(explain.what(table, runs, seed, g))}"
            + ("" if paper_any else "; the paper gives no values for this table") + "</p>"]
    if left_out:
        head.append("<p class='note'>Not computed in this run (no value in any row): "
                    + escape(", ".join(explain.label(c) for c in left_out)) + "</p>")
    out = [*head, f"<table id='table-{escape(name)}'><tr><th class='l'>"
                  f"{'' if not stats else 'row'}</th>"
           + ("<th class='l'>statistic</th>" if stats else "")
           + "".join(f"<th>{escape(explain.label(c))}</th>" for c in shown) + "</tr>"]
    last_row = None
    for (row, stat), by_col in g.cells.items():
        first = " class='first'" if row != last_row else ""
        tds = [f"<td class='l'>{escape(explain.row_label(row)) if row != last_row else ''}"
               "</td>"]
        if stats:
            tds.append(f"<td class='l'>{escape(stat)}</td>")
        last_row = row
        for c in shown:
            v = by_col.get(c)
            if v is None:
                tds.append("<td>–</td>")
                continue
            q = f"{c} / {stat}" if stat else c
            tds.append(_cell(name, row, q, v, reasons))
        out.append(f"<tr{first}>{''.join(tds)}</tr>")
    out.append("</table>")
    return "\n".join(out)


def _cell(table: str, row: str, quantity: str, v: dict, reasons: _Reasons) -> str:
    ours, paper, ci = v.get("ours"), v.get("paper"), v.get("ci95")
    col = quantity.partition(" / ")[0]
    value = _num(ours, col) + (f" ± {_num(ci, col, ours)}" if _present(ci) else "")
    verdict = explain.compare(ours, paper, quantity)
    if paper is None:
        return f"<td>{value}</td>"
    verdict_line, tip = "", ""
    if verdict.kind in ("worse", "differs", "better"):
        ref = reasons.ref(table, row, quantity, verdict.kind != "better")
        link = ""
        if ref is not None:
            i, r = ref
            link = f" <a class='why' href='#why-{i}'>[{i}]</a>"
            tip = r.text
        if verdict.kind == "better":
            tip = "better than the paper" + (f"; {tip}" if tip else "")
            verdict_line = "better than the paper" + link
        elif ref is None:
            tip = f"outside ×{FAR:g} of the paper: not explained yet"
            verdict_line = f"{verdict.kind}: not explained yet"
        else:
            verdict_line = f"{verdict.kind}: why{link}"
    elif verdict.kind == "timing":
        verdict_line = "timing: not compared"
        tip = "a timing on this machine: the paper's machine is another, so it is not judged"
    title = f" title='{escape(tip)}'" if tip else ""
    line = f"<span class='p'>{verdict_line}</span>" if verdict_line else ""
    line += "".join(f"<span class='p'>{escape(k)}: {_num(x)}</span>"
                    for k, x in explain.extras(v))
    return (f"<td class='{verdict.kind}'{title}>{value}<span class='p'>paper "
            f"{_num(paper, col)}"
            f" · {escape(verdict.text)}</span>{line}</td>")


def _image(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f"<figure><img alt='{escape(path.name)}' src='data:image/png;base64,{data}'>"
            f"<figcaption class='note'>{escape(path.name)}</figcaption></figure>")


_DESIGN_STATS = {"rmse": "RMSE", "mean": "mean |error|", "max": "max |error|",
                 "nis_per_dof": "NIS / dof"}


def design_table_html(name: str, table: dict, title: str, seed,
                      labels: dict | None = None) -> str:
    """One table of a design (``fednav run``): mode, quantity (its label in ``labels``),
    then value ± 95 % CI of each statistic (rows -> quantity -> statistic -> {value,
    ci95})."""
    labels = labels or {}
    cols: list[str] = []
    for qs in table["rows"].values():
        for stats in qs.values():
            cols += [c for c in stats if c not in cols]
    runs = table.get("runs")
    out = [f"<h2>{escape(title)}</h2><p class='note'>Monte Carlo mean ± half-width of its "
           f"95 % confidence interval over {escape(str(runs))} runs (seed "
           f"{escape(str(seed))})</p>",
           f"<table id='table-{escape(name)}'><tr><th class='l'>mode</th>"
           "<th class='l'>quantity</th>"
           + "".join(f"<th>{escape(_DESIGN_STATS.get(c, explain.label(c)))}</th>"
                     for c in cols) + "</tr>"]
    for row, qs in table["rows"].items():
        for i, (q, stats) in enumerate(qs.items()):
            cells = []
            for c in cols:
                v = stats.get(c) or {}
                h = v.get("ci95")
                cells.append(f"<td>{_num(v.get('value'), q)}"
                             + ("" if h is None else f" ± {_num(h, q, v.get('value'))}")
                             + "</td>")
            first = " class='first'" if i == 0 else ""
            out.append(f"<tr{first}><td class='l'>"
                       f"{escape(explain.row_label(row)) if i == 0 else ''}</td>"
                       f"<td class='l'>{escape(str(labels.get(q, q)))}</td>{''.join(cells)}</tr>")
    out.append("</table>")
    return "\n".join(out)


# ------------------------------------------------------------- other results as tables
_OTHER_TITLES = {
    "observability_phases": "Observability degree per flight phase",
    "si": "SVD degree, SI units", "filter_units": "SVD degree, filter units",
    "particles_per_local_filter": "particles per local filter",
    "seconds_per_run": "Time per run on this machine [s]",
    "failures": "Runs that failed",
    "null_values": "Values missing from the tables, and why",
    "health": "Health checks",
}


def _title(key) -> str:
    return _OTHER_TITLES.get(str(key)) or explain.label(key)


def _scalar(v) -> bool:
    return v is None or isinstance(v, str | int | float | bool)


def _simple_table(tid: str, head: list[str], rows: list[list[str]],
                  text: tuple[int, ...] = (0,)) -> str:
    """A plain table (cells already HTML); columns ``text`` are left-aligned."""
    def cls(i: int) -> str:
        return " class='l'" if i in text else ""
    return (f"<table id='table-{escape(tid)}'><tr>"
            + "".join(f"<th{cls(i)}>{escape(h)}</th>" for i, h in enumerate(head)) + "</tr>"
            + "".join("<tr>" + "".join(f"<td{cls(i)}>{c}</td>" for i, c in enumerate(r))
                      + "</tr>" for r in rows)
            + "</table>")


def _val(v) -> str:
    if isinstance(v, list) and all(_scalar(x) for x in v):
        return escape(", ".join(_val(x) for x in v)) if v else "–"
    if isinstance(v, float | int) and not isinstance(v, bool):
        return _num(v)
    return escape(str(v)) if v is not None else "–"


def _where(path: str, titles: dict) -> str:
    """A JSON pointer into summary.json as words: /tables/fault/rows/isolated/
    detect_delay_s/ours -> "Fault experiment …: isolated, detection delay [s], fednav"."""
    parts = [p for p in path.split("/") if p]
    if len(parts) >= 4 and parts[0] == "tables" and parts[2] == "rows":
        last = {"ours": "fednav value", "ci95": "its 95 % CI", "paper": "paper"}
        tail = [last.get(parts[-1], parts[-1])] if len(parts) > 4 else []
        mid = [explain.label(p) for p in parts[4:-1]] if len(parts) > 5 else []
        return (f"{titles.get(parts[1], parts[1])}: {explain.row_label(parts[3])}, "
                + ", ".join([*mid, *tail]))
    return " / ".join(parts)


def _null_values(tid: str, items: list, titles: dict) -> str:
    rows = []
    for it in items:
        where = [_where(p, titles) for p in it.get("paths", [])]
        rows.append([escape(str(it.get("why", ""))), escape(str(it.get("was", ""))),
                     "<br>".join(escape(w) for w in where)])
    return ("<p class='note'>Values the tables show as “–” (JSON has no NaN: "
            "summary.json holds them as null)</p>"
            + _simple_table(tid, ["why", "value", "where"], rows, text=(0, 1, 2)))


def other_html(key: str, value, prefix: str = "other", level: int = 2,
               titles: dict | None = None) -> str:
    """A further result of a summary as labelled tables: a mapping of scalars as two
    columns, a mapping of mappings as a matrix, deeper mappings as one table each, a list
    of records as rows, a scalar as one line."""
    tid = f"{prefix}-{key}"
    h = f"<h{level} id='h-{escape(tid)}'>{escape(_title(key))}</h{level}>"
    if key == "null_values" and isinstance(value, list):
        return h + _null_values(tid, value, titles or {})
    if _scalar(value) or (isinstance(value, list) and all(_scalar(x) for x in value)):
        shown = "none" if value in ([], None) else _val(value)
        return (f"<dl id='{escape(tid)}'><dt>{escape(_title(key))}</dt><dd>{shown}</dd>"
                "</dl>")
    if isinstance(value, list):
        recs = [x for x in value if isinstance(x, dict)]
        cols = list(dict.fromkeys(k for r in recs for k in r))
        return h + _simple_table(tid, [explain.label(c) for c in cols],
                                 [[_val(r.get(c)) for c in cols] for r in recs])
    if not isinstance(value, dict):
        return h + f"<p>{escape(str(value))}</p>"
    if all(_scalar(v) or isinstance(v, list) for v in value.values()):
        return h + _simple_table(tid, ["", "value"], [[escape(explain.row_label(k)),
                                                        _val(v)] for k, v in value.items()])
    if all(isinstance(v, dict) and all(_scalar(x) or isinstance(x, list)
                                        for x in v.values()) for v in value.values()):
        cols = list(dict.fromkeys(c for v in value.values() for c in v))
        if len(cols) > max(8, len(value)):  # many columns, few rows: turned round
            value = {c: {r: v.get(c) for r, v in value.items()} for c in cols}
            cols = list(dict.fromkeys(c for v in value.values() for c in v))
        return h + _simple_table(tid, ["", *(explain.label(c) for c in cols)],
                                 [[escape(explain.row_label(r)), *(_val(v.get(c))
                                                                   for c in cols)]
                                  for r, v in value.items()])
    return h + "\n".join(other_html(str(k), v, tid, min(level + 1, 4))
                         for k, v in value.items())


# ------------------------------------------------------------------------ the pages
def _load(folder: Path) -> tuple[dict, Path]:
    sfile = folder / "summary.json"
    if not sfile.is_file():
        raise ReportError(f"{folder}: no summary.json (not a fednav reproduce or process "
                          "folder, or its run did not finish)")
    try:
        summary = json.loads(sfile.read_text())
    except json.JSONDecodeError as e:
        raise ReportError(f"{sfile}: not a fednav summary ({e})") from None
    if not isinstance(summary, dict):
        raise ReportError(f"{sfile}: not a fednav summary (not a mapping)")
    return summary, sfile


def is_process_summary(summary: dict) -> bool:
    """Whether a summary.json is a ``fednav process`` run's (not a reproduction's)."""
    return "tables" not in summary and "epochs" in summary and "consistency" in summary


def _page(title: str, head: str, body: list[str]) -> str:
    return "\n".join(["<!doctype html><html lang='en'><head><meta charset='utf-8'>",
                      f"<title>fednav — {escape(title)}</title><style>{_CSS}</style></head>"
                      "<body>", f"<h1>{escape(head)}</h1>", *body, "</body></html>"])


def _dl(meta: dict) -> str:
    return "<dl>" + "".join(f"<dt>{escape(str(k))}</dt><dd>{escape(str(v))}</dd>"
                            for k, v in meta.items()) + "</dl>"


def render(folder: Path, titles: dict[str, str] | None = None) -> str:
    """The HTML text of the report on ``folder`` (a reproduction's or a ``process``
    run's); ``titles``: the heading of each table by its key (``fednav report`` passes
    the paper module's; without them a table is headed by the paper's own title where
    the summary holds one, else "Table KEY")."""
    folder = Path(folder)
    summary, sfile = _load(folder)
    if is_process_summary(summary):
        return render_process(folder, summary)
    tables = summary.get("tables")
    if not isinstance(tables, dict):
        raise ReportError(f"{sfile}: not a fednav summary (no tables, and not a process "
                          "run's summary)")
    manifest = {}
    mfile = folder / "campaign.json"
    if mfile.is_file():
        try:
            manifest = json.loads(mfile.read_text())
        except json.JSONDecodeError:
            manifest = {}
    paper = str(summary.get("paper", "?"))
    design = summary.get("design")
    titles = titles or {}
    runs, seed = summary.get("runs"), summary.get("seed")
    camp = summary.get("campaign", {})
    seeds = (f"{seed} … {seed + runs - 1} (run i uses seed + i)"
             if isinstance(seed, int) and isinstance(runs, int) else str(seed))
    meta = {
        **({"design": design} if design is not None else {"paper": paper}),
        "fednav version": manifest.get("fednav_version", "?"),
        "scenario hash": manifest.get("scenario_hash", "?"),
        "seeds": seeds,
        "Monte Carlo runs": runs,
        "engine": camp.get("engine", "?"),
        "units of work": (f"{camp.get('runs_total', '?')} ({camp.get('runs_computed', '?')} "
                          f"computed, {camp.get('runs_reused', '?')} reused)"),
        "campaign created": manifest.get("created", "?"),
        "summary written": datetime.fromtimestamp(sfile.stat().st_mtime, UTC)
                                   .isoformat(timespec="seconds"),
        "folder": str(folder.resolve()),
    }
    what = f"design {design}" if design is not None else f"paper {paper}"
    head = (f"fednav design {design} (fednav run)" if design is not None
            else f"fednav reproduction of paper {paper}")
    body = [_dl(meta)]
    shown = [(n, t) for n, t in tables.items() if isinstance(t, dict) and t.get("rows")]
    if shown:
        body.append("<p class='note'>Tables: " + ", ".join(
            f"<a href='#h-{escape(n)}'>{escape(titles.get(n) or t.get('title') or n)}</a>"
            for n, t in shown) + "</p>")
    reasons = _Reasons(paper)
    if design is None and shown:
        body.append(_LEGEND)
    for name, t in shown:
        title = titles.get(name) or t.get("title") or f"Table {name}"
        if design is not None:
            body.append(design_table_html(name, t, title, seed, summary.get("quantities")))
        else:
            body.append(table_html(name, t, title, runs, seed, reasons))
    rest = {k: v for k, v in summary.items()
            if k not in ("paper", "design", "runs", "seed", "tables", "campaign",
                         "quantities")}
    if rest:
        body.append("<h2>Other results</h2>")
        body.extend(other_html(k, v, level=3, titles=titles) for k, v in rest.items())
    body.append(reasons.html())
    images = sorted(folder.glob("*.png"))
    if images:
        body.append("<h2>Plots</h2>")
        body.extend(_image(p) for p in images)
    return _page(what, head, body)


# ----------------------------------------------------------------- a process folder
def _solution_summary(folder: Path) -> tuple[str, list[list[str]]] | None:
    """(file name, rows) summing up the solution file of a process folder."""
    import numpy as np
    import pandas as pd

    for name in ("solution.csv", "solution.parquet"):
        p = folder / name
        if not p.is_file():
            continue
        try:
            df = pd.read_csv(p) if p.suffix == ".csv" else pd.read_parquet(p)
        except Exception as e:  # noqa: BLE001 - said in the report, not a crash
            return name, [["could not be read", escape(f"{type(e).__name__}: {e}")]]
        rows = [["rows", str(len(df))]]
        if "t_s" in df and len(df):
            t = df["t_s"].to_numpy()
            rows.append(["time span [s]", f"{_num(float(t[0]))} … {_num(float(t[-1]))} "
                                          f"({_num(float(t[-1] - t[0]))} s)"])
            if len(t) > 1:
                rows.append(["output rate [Hz]",
                             _num(float((len(t) - 1) / max(t[-1] - t[0], 1e-9)))])
        if {"lat_deg", "lon_deg"} <= set(df) and len(df):
            from ..core.earth import A as WGS84_A

            lat, lon = units.deg(df["lat_deg"].to_numpy()), units.deg(df["lon_deg"].to_numpy())
            dn = np.diff(lat) * WGS84_A
            de = np.diff(lon) * WGS84_A * np.cos(lat[:-1])
            rows.append(["start (lat, lon, h)", escape(
                f"{df['lat_deg'].iloc[0]:.7f}°, {df['lon_deg'].iloc[0]:.7f}°, "
                f"{df['h_m'].iloc[0]:.1f} m" if "h_m" in df else "")])
            rows.append(["end (lat, lon, h)", escape(
                f"{df['lat_deg'].iloc[-1]:.7f}°, {df['lon_deg'].iloc[-1]:.7f}°, "
                f"{df['h_m'].iloc[-1]:.1f} m" if "h_m" in df else "")])
            rows.append(["horizontal distance [m]", _num(float(np.hypot(dn, de).sum()))])
        if {"vE_mps", "vN_mps"} <= set(df) and len(df):
            sp = np.hypot(df["vE_mps"], df["vN_mps"])
            rows.append(["horizontal speed, mean / max [m/s]",
                         f"{_num(float(sp.mean()))} / {_num(float(sp.max()))}"])
        for what, cols, unit in (("position", ("sigma_E_m", "sigma_N_m", "sigma_U_m"), "m"),
                                 ("velocity", ("sigma_vE_mps", "sigma_vN_mps",
                                               "sigma_vU_mps"), "m/s"),
                                 ("attitude", ("sigma_pitch_deg", "sigma_roll_deg",
                                               "sigma_heading_deg"), "°")):
            if set(cols) <= set(df) and len(df):
                end = ", ".join(_num(float(df[c].iloc[-1])) for c in cols)
                med = ", ".join(_num(float(df[c].median())) for c in cols)
                axes = "pitch, roll, heading" if what == "attitude" else "E, N, U"
                rows.append([f"1-σ {what} {axes} [{unit}]",
                             f"median {med}; at the end {end}"])
        return name, rows
    return None


def render_process(folder: Path, s: dict) -> str:
    """The HTML text of the report on a ``fednav process`` output folder."""
    folder = Path(folder)
    body = []
    inputs = s.get("inputs") or {}
    body.append("<h2 id='h-inputs'>Inputs</h2>"
                + _dl({k.replace("_", " "): ("–" if v is None else v)
                       for k, v in inputs.items()}))
    warnings = s.get("warnings") or []
    body.append(f"<h2 id='h-warnings'>Warnings ({len(warnings)})</h2>")
    body.extend(f"<div class='warn'>{escape(str(w))}</div>" for w in warnings)
    if not warnings:
        body.append("<p class='note'>none</p>")
    sol = _solution_summary(folder)
    body.append("<h2 id='h-solution'>Solution</h2>")
    run = [["filter epochs", _val(s.get("epochs"))],
           ["filter run time [s]", _val(s.get("run_time_s"))]]
    if sol is not None:
        body.append(f"<p class='note'>{escape(sol[0])}</p>")
        run += sol[1]
    body.append(_simple_table("solution", ["", "value"], run))
    al = s.get("alignment") or {}
    if al:
        body.append("<h2 id='h-alignment'>Initial alignment</h2>")
        names = {"euler_deg": "pitch, roll, heading [°]",
                 "sigma_deg": "1-σ pitch, roll, heading [°]"}
        body.append(_simple_table("alignment", ["", "value"], [
            [escape(names.get(k, k.replace("_", " "))), _val(v)] for k, v in al.items()]))
    cons = s.get("consistency") or {}
    if cons:
        body.append("<h2 id='h-consistency'>Consistency of each local filter</h2>"
                    "<p class='note'>mean NIS per degree of freedom: 1 when the filter's "
                    "covariance matches its innovations; outside 0.5 … 2 (red) the noise "
                    "figures are off (<code>fednav tune</code>, docs/tuning.md)</p>")
        rows = []
        for name, c in cons.items():
            nis = c.get("nis_per_dof")
            bad = _present(nis) and not 0.5 <= nis <= 2.0
            rows.append([escape(name),
                         f"<span class='{'worse' if bad else ''}'>{_val(nis)}</span>"
                         + (" (outside 0.5 … 2)" if bad else ""),
                         _val(None if c.get("isolated_fraction") is None
                              else 100 * c["isolated_fraction"]),
                         _val(c.get("measurements"))])
        body.append(_simple_table("consistency", ["local filter", "NIS/dof",
                                                  "isolated [%]", "measurements"], rows))
    q = s.get("data_quality") or {}
    if q:
        body.append("<h2 id='h-data-quality'>Data quality</h2><p class='note'>"
                    "docs/reliability.md</p>")
        body.append(_simple_table("data-quality", ["", "value"], [
            [escape(explain.label(k)), _val(v)] for k, v in q.items()]))
    blocks = [("rmse", "RMSE against the reference", s.get("rmse")),
              ("rmse-smoothed", "RMSE of the smoothed solution against the reference",
               s.get("rmse_smoothed"))]
    for name, other in (s.get("against") or {}).items():
        src = other.get("source", name)
        blocks += [(f"rmse-{name}", f"RMSE against {src}", other.get("rmse")),
                   (f"rmse-smoothed-{name}", f"RMSE of the smoothed solution against {src}",
                    other.get("rmse_smoothed"))]
    for tid, title, block in blocks:
        if not block:
            continue
        body.append(f"<h2 id='h-{escape(tid)}'>{escape(title)}</h2>")
        body.append(_simple_table(tid, [explain.label(k) for k in block],
                                  [[_num(v, k) if isinstance(v, float | int) else _val(v)
                                    for k, v in block.items()]], text=()))
    known = {"inputs", "warnings", "epochs", "run_time_s", "alignment", "consistency",
             "data_quality", "rmse", "rmse_smoothed", "against"}
    rest = {k: v for k, v in s.items() if k not in known}
    if rest:
        body.append("<h2>Other results</h2>")
        body.extend(other_html(k, v, level=3) for k, v in rest.items())
    images = sorted(folder.glob("*.png"))
    if images:
        body.append("<h2>Plots</h2>")
        body.extend(_image(p) for p in images)
    written = datetime.fromtimestamp((folder / "summary.json").stat().st_mtime, UTC)
    body.insert(0, _dl({"folder": str(folder.resolve()),
                        "summary written": written.isoformat(timespec="seconds")}))
    return _page(f"process {folder.name}", "fednav processing run", body)


def write_report(folder: Path, titles: dict[str, str] | None = None) -> Path:
    """Write ``folder/report.html`` (atomically: :mod:`fednav.core.atomic`)."""
    from ..core.atomic import write_text

    return write_text(Path(folder) / "report.html", render(folder, titles))

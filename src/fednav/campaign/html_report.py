"""``report.html``: one self-contained page for a reproduction folder.

The page holds every table of ``summary.json`` beside the paper's values (the ratio
fednav / paper is coloured when it lies outside ×3 either way), the error plots of the
folder embedded as base64 PNG, and the run metadata (fednav version, scenario hash,
seeds, engine, times) from ``campaign.json`` and ``summary.json``. Nothing is fetched
from the network: the file can be mailed or archived as it is.  A design's folder
(``fednav run``: ``summary.json`` names a ``design``, not a paper) has no paper column:
its tables give each statistic's value ± 95 % CI, one column per statistic.
"""

from __future__ import annotations

import base64
import json
import math
from datetime import UTC, datetime
from html import escape
from pathlib import Path

from ..core.errors import FednavError

FAR = 3.0  # ratios outside [1/FAR, FAR] are flagged

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;
max-width:1100px;color:#222;line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.2em;margin-top:2em}
table{border-collapse:collapse;margin:.5em 0 1em 0;font-size:.92em}
th,td{border-bottom:1px solid #ddd;padding:.25em .7em;text-align:right}
th{background:#f3f3f3}td.l,th.l{text-align:left}
tr.first td{border-top:2px solid #bbb}
td.far{background:#fbd5d0;color:#8a1c10;font-weight:600}
td.near{color:#1d6b2f}
dl{display:grid;grid-template-columns:max-content auto;gap:.2em 1.2em}dt{font-weight:600}
img{max-width:100%;border:1px solid #ddd;margin:.5em 0}
.note{color:#666;font-size:.9em}pre{background:#f7f7f7;padding:.8em;overflow:auto}
"""


class ReportError(FednavError, ValueError):
    """A folder that holds no reproduction to report on."""


def _num(x) -> str:
    from .report import format_number

    if x is None or isinstance(x, bool) or not isinstance(x, int | float):
        return "–" if x is None else escape(str(x))
    return format_number(x)


def _leaves(cell: dict, prefix: str = ""):
    """(quantity, {ours, ci95, paper, ...}) for a table cell; nested cells (paper 003's
    column -> statistic -> value) are flattened to ``column / statistic``."""
    if "ours" in cell:
        yield prefix, cell
        return
    for k, v in cell.items():
        if isinstance(v, dict):
            yield from _leaves(v, f"{prefix} / {k}" if prefix else str(k))


def _ratio(ours, paper) -> tuple[str, str]:
    """(text, css class) of fednav / paper."""
    if not isinstance(ours, int | float) or not isinstance(paper, int | float) or not paper:
        return "–", ""
    if not (math.isfinite(ours) and math.isfinite(paper)):
        return "–", ""
    q = ours / paper
    text = f"×{q:.2f}" if abs(q) < 100 else f"×{q:.3g}"
    far = q <= 0 or q > FAR or q < 1.0 / FAR
    return text, "far" if far else "near"


def table_html(name: str, table: dict, title: str, runs, seed) -> str:
    """One summary table as HTML: row, quantity, fednav, ± 95 % CI, paper, ratio."""
    spread = any(v.get("ci95") is not None for cols in table["rows"].values()
                 for _, v in _leaves(cols))
    what = (f"mean ± 95 % CI over {table.get('runs', runs)} Monte Carlo runs (seed {seed})"
            if spread else "one computation, no Monte Carlo spread")
    head = (f"<h2>{escape(title)}</h2><p class='note'>fednav: {escape(what)}; ratio "
            f"fednav / paper coloured when outside ×{FAR:g}</p>")
    out = [head, f"<table id='table-{escape(name)}'><tr><th class='l'>row</th>"
                 "<th class='l'>quantity</th><th>fednav</th><th>± 95 % CI</th>"
                 "<th>paper</th><th>fednav / paper</th></tr>"]
    for row, cols in table["rows"].items():
        leaves = list(_leaves(cols))
        for i, (q, v) in enumerate(leaves):
            text, cls = _ratio(v.get("ours"), v.get("paper"))
            first = " class='first'" if i == 0 else ""
            out.append(f"<tr{first}><td class='l'>{escape(str(row)) if i == 0 else ''}</td>"
                       f"<td class='l'>{escape(q)}</td><td>{_num(v.get('ours'))}</td>"
                       f"<td>{_num(v.get('ci95'))}</td><td>{_num(v.get('paper'))}</td>"
                       f"<td class='{cls}'>{text}</td></tr>")
    out.append("</table>")
    return "\n".join(out)


def _image(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f"<figure><img alt='{escape(path.name)}' src='data:image/png;base64,{data}'>"
            f"<figcaption class='note'>{escape(path.name)}</figcaption></figure>")


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
           + "".join(f"<th>{escape(c)}</th>" for c in cols) + "</tr>"]
    for row, qs in table["rows"].items():
        for i, (q, stats) in enumerate(qs.items()):
            cells = []
            for c in cols:
                v = stats.get(c) or {}
                h = v.get("ci95")
                cells.append(f"<td>{_num(v.get('value'))}"
                             + ("" if h is None else f" ± {_num(h)}") + "</td>")
            first = " class='first'" if i == 0 else ""
            out.append(f"<tr{first}><td class='l'>{escape(str(row)) if i == 0 else ''}</td>"
                       f"<td class='l'>{escape(str(labels.get(q, q)))}</td>{''.join(cells)}</tr>")
    out.append("</table>")
    return "\n".join(out)


def render(folder: Path, titles: dict[str, str] | None = None) -> str:
    """The HTML text of the report on reproduction folder ``folder``; ``titles``: the
    heading of each table by its key (the paper module's ``TABLE_TITLES``)."""
    folder = Path(folder)
    sfile = folder / "summary.json"
    if not sfile.is_file():
        raise ReportError(f"{folder}: no summary.json (not a fednav reproduce folder, or "
                          "its run did not finish)")
    try:
        summary = json.loads(sfile.read_text())
        tables = summary["tables"]
    except (json.JSONDecodeError, KeyError, TypeError) as e:
        raise ReportError(f"{sfile}: not a fednav summary ({e})") from None
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
    parts = ["<!doctype html><html lang='en'><head><meta charset='utf-8'>",
             f"<title>fednav — {escape(what)}</title><style>{_CSS}</style></head><body>",
             f"<h1>{escape(head)}</h1>",
             "<dl>" + "".join(f"<dt>{escape(k)}</dt><dd>{escape(str(v))}</dd>"
                              for k, v in meta.items()) + "</dl>"]
    for name, t in tables.items():
        if not (isinstance(t, dict) and t.get("rows")):
            continue
        title = titles.get(name) or t.get("title") or name
        if design is not None:
            parts.append(design_table_html(name, t, title, seed, summary.get("quantities")))
        else:
            parts.append(table_html(name, t, title, runs, seed))
    images = sorted(folder.glob("*.png"))
    if images:
        parts.append("<h2>Plots</h2>")
        parts.extend(_image(p) for p in images)
    rest = {k: v for k, v in summary.items()
            if k not in ("paper", "design", "runs", "seed", "tables", "campaign")}
    if rest:
        parts.append("<h2>Other results in summary.json</h2><details><summary>show"
                     f"</summary><pre>{escape(json.dumps(rest, indent=1))}</pre></details>")
    parts.append("</body></html>")
    return "\n".join(parts)


def write_report(folder: Path, titles: dict[str, str] | None = None) -> Path:
    """Write ``folder/report.html`` (atomically: :mod:`fednav.core.atomic`)."""
    from ..core.atomic import write_text

    return write_text(Path(folder) / "report.html", render(folder, titles))

"""What a reproduction's numbers mean beside the paper's: human labels, which side of a
measure is better, and where the documentation explains each difference.

Used by the HTML report (:mod:`fednav.campaign.html_report`) and the terminal tables
(:func:`fednav.campaign.report.print_tables`), so both say the same thing:

* :func:`label` — a human name with its unit for a quantity key (``lon_std_m`` ->
  "east position std [m]");
* :func:`sense` — ``"lower"`` (an error: the smaller magnitude is better), ``"higher"``
  (an improvement, a detection rate), ``"timing"`` (wall-clock time on this machine: not
  judged against the paper's machine) or ``"neutral"`` (a property with no better side,
  e.g. an observability degree);
* :func:`compare` — the cell's verdict against the paper: the ratio text, and whether it
  is within ×3, better, worse, different or not judged;
* :func:`reason` — for a cell outside ×3, the section of ``docs/paperNNN.md`` that
  explains it (:data:`EXPLAINED`: paper -> [(table, row, quantity patterns, anchor,
  one-line reason)], first match wins; the anchors are ``<a id="..."></a>`` in the docs,
  checked by ``tests/test_html_report.py``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from fnmatch import fnmatchcase
from pathlib import Path

FAR = 3.0  # ratios outside [1/FAR, FAR] are flagged

#: Quantity keys (or their parts) -> human labels (units added from the key's suffix).
_WORDS = {
    "lon": "east position", "lat": "north position", "h": "height",
    "dlambda": "east position δλ", "dL": "north position δL",
    "dVx": "east velocity δVx", "dVy": "north velocity δVy",
    "vE": "east velocity", "vN": "north velocity", "vU": "up velocity",
    "phiE": "east tilt φE", "phiN": "north tilt φN", "phiU": "heading error φU",
    "roll": "roll", "pitch": "pitch", "yaw": "heading",
    "att": "attitude", "pos": "position", "vel": "velocity",
    "att_x": "attitude x", "att_y": "attitude y", "att_z": "attitude z",
    "pos_x": "position x", "pos_y": "position y", "pos_z": "position z",
    "vel_x": "velocity x", "vel_y": "velocity y", "vel_z": "velocity z",
    "pf": "PF", "ekf": "EKF",
    "north": "north position", "east": "east position", "down": "down position",
    "up": "up position", "vn": "north velocity", "ve": "east velocity",
    "vd": "down velocity", "vu": "up velocity",
}
#: Whole keys whose label is not made of the words above.
_LABELS = {
    "degree": "SVD degree, SI units (paper's measure)",
    "degree_filter_units": "SVD degree, filter units",
    "sigma_shrink": "σ(0)/σ(T) (covariance)",
    "improvement_pct": "improvement [%]",
    "ms_per_cycle": "time per filter cycle [ms]",
    "time_s": "wall time of one run [s]",
    "x_ins_increment": "time ÷ INS increment's time",
    "seconds_per_run": "time per run [s]",
    "detect_delay_s": "detection delay [s]",
    "detected_fraction": "fault window detected",
    "isolated_fraction": "fault window isolated",
    "hpl_median_m": "median HPL [m]",
    "vpl_median_m": "median VPL [m]",
    "misleading_epochs": "misleading epochs",
    "false_alarm_rate": "false alarms outside the window",
    "pos_err_rms_fault_window_m": "3-D position RMS in the window [m]",
    "position_std": "position std [m]", "velocity_std": "velocity std [m/s]",
    "attitude_std": "attitude std [°]",
    "lost_pf": "runs that lost track, PF", "lost_ekf": "runs that lost track, EKF",
    "max": "max", "min": "min", "std": "std", "mean": "mean", "rms": "RMS",
    "paper_table_same_rule": "the paper's own Table 1, same rule",
    "runs_total": "units of work", "runs_computed": "computed", "runs_reused": "reused",
    "engine": "engine",
}
_UNITS = {"m": "m", "mps": "m/s", "deg": "°", "arcsec": "″", "arcmin": "′", "s": "s",
          "pct": "%", "ms": "ms", "mps2": "m/s²", "radps": "rad/s"}
_STATS = ("mean", "std", "min", "max", "rms", "abs")


#: Reasons that several cells share.
_SWAPPED = ("SINS δVx/δVy and φE/φN look swapped in the paper: an east accelerometer "
            "error gives a large east velocity error and north tilt")
_STAR_AVERAGED = ("with a 1°/h-class gyro and a star fix every second the filter averages "
                  "the star noise strongly; the paper's attitude errors are close to the "
                  "star noise itself")


#: Error-state names (paper 002's observability tables) -> symbols.
STATES = {"phiE": "φE", "phiN": "φN", "phiU": "φU", "dVE": "δVE", "dVN": "δVN",
          "dVU": "δVU", "dlambda": "δλ (east)", "dL": "δL (north)", "dh": "δh",
          **{f"eps_c{a}": f"εc{a}" for a in "xyz"}, **{f"eps_r{a}": f"εr{a}" for a in "xyz"},
          **{f"nabla_c{a}": f"∇c{a}" for a in "xyz"}}


def label(key) -> str:
    """A human label with its unit for a summary key (unknown keys: underscores become
    spaces, a unit suffix becomes ``[unit]``)."""
    key = str(key)
    if key in _LABELS:
        return _LABELS[key]
    if key in STATES:
        return STATES[key]
    m = re.fullmatch(r"(.+)@(.+)", key)  # a sweep point: pos_std_m@1.5s
    if m:
        return f"{label(m.group(1))}, latency ≤ {m.group(2).replace('s', ' s')}"
    parts = key.split("_")
    unit = ""
    if len(parts) > 1 and parts[-1] in _UNITS:
        unit = _UNITS[parts.pop()]
    stats = [p for p in parts if p in _STATS]
    body = [p for p in parts if p not in _STATS]
    name = "_".join(body)
    words = _WORDS.get(name) or " ".join(_WORDS.get(p, p) for p in body)
    if stats:
        words += " " + " ".join("RMS" if s == "rms" else s for s in stats)
    return f"{words} [{unit}]" if unit else words


def row_label(key) -> str:
    """A table row's key as text (``curve_fit`` -> "curve fit", ``phiE`` -> "φE")."""
    return STATES.get(str(key)) or str(key).replace("_", " ")


def sense(quantity: str) -> str:
    """Which side of ``quantity`` is better: ``lower`` (magnitude), ``higher``,
    ``timing`` (not judged) or ``neutral`` (no better side)."""
    q = str(quantity).split(" / ")[0]
    if (q in ("ms_per_cycle", "time_s", "seconds_per_run", "x_ins_increment")
            or q.endswith("_per_cycle") or q.startswith("seconds")):
        return "timing"
    if q in ("degree", "degree_filter_units", "sigma_shrink"):
        return "neutral"
    if q in ("improvement_pct", "detected_fraction", "isolated_fraction"):
        return "higher"
    return "lower"


@dataclass(frozen=True)
class Verdict:
    """A cell against the paper: ``text`` (the ratio, or a difference in points),
    ``kind``: "" (nothing to compare), "near" (within ×3), "better", "worse", "differs"
    (outside ×3, no better side) or "timing" (not judged)."""

    text: str
    kind: str

    @property
    def flagged(self) -> bool:
        return self.kind in ("worse", "differs")


def ratio_text(q: float) -> str:
    """``×0.27``, ``×396``, ``×2.6e9``."""
    a = abs(q)
    if a >= 1e4:
        m, e = f"{q:.2g}".split("e")
        return f"×{m}e{int(e)}"
    if a >= 100:
        return f"×{q:.0f}"
    if a >= 0.1 or a == 0:
        return f"×{q:.2f}"
    return f"×{q:.2g}"


def compare(ours, paper, quantity: str) -> Verdict:
    """The verdict of fednav's ``ours`` against the paper's value of ``quantity``."""
    if (not isinstance(ours, int | float) or not isinstance(paper, int | float)
            or isinstance(ours, bool) or not paper
            or not (math.isfinite(ours) and math.isfinite(paper))):
        return Verdict("–", "")
    s = sense(quantity)
    q = ours / paper
    pct = str(quantity).split(" / ")[0].endswith("_pct")
    text = f"{ours - paper:+.1f} points" if pct else ratio_text(q)
    if s == "timing":
        return Verdict(text, "timing")
    m = abs(q)
    if s == "lower":
        if m < 1.0 / FAR:
            return Verdict(text, "better")
        if m > FAR:
            return Verdict(text, "worse")
        return Verdict(text + (" (opposite sign)" if q < 0 else ""), "near" if q >= 0
                       else "differs")
    if s == "higher":
        if q > FAR:
            return Verdict(text, "better")
        if q < 1.0 / FAR:
            return Verdict(text, "worse")
        return Verdict(text, "near")
    return Verdict(text, "differs" if q <= 0 or m > FAR or m < 1.0 / FAR else "near")


# ----------------------------------------------------------------- the explanations
#: The catch-all reason: no section explains the cell on its own.
GENERAL = ("not explained cell by cell: the results section compares fednav with each of "
           "the paper's claims")
#: paper -> [(table, row, quantity) glob patterns, anchor in docs/paperNNN.md, reason].
#: First match wins; every paper ends with a catch-all on its results section.
EXPLAINED: dict[str, list[tuple[str, str, str, str, str]]] = {
    "000": [
        ("T1", "CUKF/*", "vel_*", "beyond-x3",
         "our wind estimate is nearly exact (0.02 m/s), so the constrained filter's velocity "
         "is better than the paper's"),
        ("T1", "RAUKF/*", "*", "raukf",
         "with Gaussian sensor noise the robust weights have nothing to reject: the RAUKF "
         "is a UKF with adapted R, ≈ AEKF here"),
        ("T1", "*/wind", "*", "wind-harmless",
         "the simulated IMU measures the gust accelerations, so the wind changes nothing "
         "for any filter (the paper's degradation needs an IMU that misses them)"),
        ("T1", "*", "pos_*", "beyond-x3",
         "the SAR fix accuracy (decoded as 25 m) dominates the position figures; with 2.5 m "
         "every filter is below 1 m"),
        ("limitation", "*", "*", "limitation",
         "a hard constraint helps only while its error is below the filter's own velocity "
         "uncertainty (≈ 0.13 m/s)"),
        ("*", "*", "*", "results", GENERAL),
    ],
    "001": [
        ("T1", "EKF", "*", "consistent-ekf",
         "our federated EKF is consistent, with the same model and data as the PF: "
         "1.1–2.6× better than the paper's EKF"),
        ("*", "*", "*", "results", GENERAL),
    ],
    "002": [
        ("T1", "*", "*", "observability",
         "the SVD degree depends on the state units as much as on the system (SI here; "
         "the paper does not state its units); compare the covariance measure"),
        ("T2", "SINS", "dV*", "beyond-x3",
         _SWAPPED),
        ("T3", "SINS", "phiE_*", "beyond-x3",
         _SWAPPED),
        ("T3", "SINS", "phiN_*", "beyond-x3",
         _SWAPPED),
        ("T3", "SINS", "phiU_*", "beyond-x3",
         "a constant 0.01°/h z-gyro drift integrates to 12″ in 1200 s; the paper's value "
         "needs a smaller effective drift"),
        ("T*", "SINS/CNS", "*", "beyond-x3",
         "with the attitude held by the star sensor, velocity is barely observable: the "
         "drift from the initial velocity error (not given by the paper) dominates; the "
         "filter is consistent"),
        ("T4", "AASGHQF", "*", "table-4",
         "with Gaussian noise of the stated size, adapting R adds estimation noise and "
         "nothing to learn"),
        ("*", "*", "*", "results", GENERAL),
    ],
    "003": [
        ("T1", "*", "roll_deg*", "attitude-smaller",
         _STAR_AVERAGED),
        ("T1", "*", "pitch_deg*", "attitude-smaller",
         _STAR_AVERAGED),
        ("T1", "*", "yaw_deg*", "attitude-smaller",
         _STAR_AVERAGED),
        ("*", "*", "*", "ukf-advantage-absent",
         "with the same states and sensors the UKF and the linear KF agree to 4 digits: "
         "the errors are small enough for the error dynamics to be linear"),
    ],
    "004": [
        ("*", "uncompensated", "h_*", "beyond-x3",
         "the sign of the uncompensated height error depends on the order of climb and "
         "turn in the manoeuvre, which the paper does not give"),
        ("*", "*", "*", "beyond-x3",
         "the paper does not give its trajectory, filter period or image-matching error "
         "model in enough detail to find out which makes its errors larger"),
    ],
}


@dataclass(frozen=True)
class Reason:
    """Why a cell differs from the paper: the doc (``docs/paperNNN.md``), its anchor and
    a one-line reason."""

    doc: str
    anchor: str
    text: str

    @property
    def general(self) -> bool:
        """The catch-all (no section on this cell in particular)."""
        return self.text == GENERAL


def reason(paper: str, table: str, row: str, quantity: str) -> Reason | None:
    """The explanation of a flagged cell of ``paper``'s ``table`` (None: none given)."""
    for t, r, q, anchor, text in EXPLAINED.get(str(paper), ()):
        if fnmatchcase(str(table), t) and fnmatchcase(str(row), r) and fnmatchcase(
                str(quantity).split(" / ")[0], q):
            return Reason(f"docs/paper{paper}.md", anchor, text)
    return None


def docs_dir() -> Path | None:
    """The repository's ``docs/`` folder when fednav runs from a checkout (else None)."""
    d = Path(__file__).resolve().parents[3] / "docs"
    return d if d.is_dir() else None


def doc_excerpt(r: Reason, max_lines: int = 40) -> str | None:
    """The text of the doc section an explanation points at, from its anchor to the next
    heading or anchor (None when the docs are not at hand)."""
    d = docs_dir()
    if d is None:
        return None
    path = d / Path(r.doc).name
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError:
        return None
    mark = f'<a id="{r.anchor}"></a>'
    start = next((i for i, line in enumerate(lines) if mark in line), None)
    if start is None:
        return None
    first = lines[start].replace(mark, "").strip()
    out = [first] if first else []
    for line in lines[start + 1:]:
        if line.startswith("#") or '<a id="' in line or len(out) >= max_lines:
            break
        out.append(line)
    return "\n".join(out).strip() or None


# ------------------------------------------------------------- a table as a grid
_RANGE = re.compile(r"(.+)_(min|max)_([a-z0-9]+)")


def present(v) -> bool:
    """A finite number (not None, NaN or a bool)."""
    return isinstance(v, int | float) and not isinstance(v, bool) and v == v


def leaves(cell: dict, prefix: str = ""):
    """(quantity, {ours, ci95, paper, ...}) for a table cell; nested cells (paper 003's
    column -> statistic -> value) are flattened to ``column / statistic``."""
    if "ours" in cell:
        yield prefix, cell
        return
    for k, v in cell.items():
        if isinstance(v, dict):
            yield from leaves(v, f"{prefix} / {k}" if prefix else str(k))


@dataclass
class Grid:
    """A summary table laid out as a person reads it: ``cells[(row, statistic)][measure]``
    (statistic "" unless the table nests one, as paper 003's max/min/std, or names one in
    its keys, as paper 004's ``lon_min_m``), the measures ``shown`` (with a value in some
    row) and those ``left_out`` (none in any row)."""

    cells: dict
    shown: list
    left_out: list
    stats: list

    def values(self) -> list[dict]:
        return [v for r in self.cells.values() for v in r.values()]

    @property
    def has_paper(self) -> bool:
        return any(v.get("paper") is not None for v in self.values())

    @property
    def has_ci(self) -> bool:
        return any(present(v.get("ci95")) for v in self.values())


def grid(table: dict) -> Grid:
    """The :class:`Grid` of a summary table (``{"rows": row -> measure -> cell}``)."""
    rows = table["rows"]
    cells: dict[tuple[str, str], dict[str, dict]] = {}
    columns: list[str] = []
    stats: list[str] = []
    keys = {q for cols in rows.values() for q, _ in leaves(cols)}
    split = bool(keys) and all(_RANGE.fullmatch(q) for q in keys)  # lon_min_m: a statistic
    for row, cols in rows.items():
        for q, v in leaves(cols):
            if split:
                m = _RANGE.fullmatch(q)
                q = f"{m.group(1)}_{m.group(3)} / {m.group(2)}"
            col, _, stat = q.partition(" / ")
            cells.setdefault((str(row), stat), {})[col] = v
            columns += [col] if col not in columns else []
            stats += [stat] if stat and stat not in stats else []
    shown = [c for c in columns
             if any(present(cells[k].get(c, {}).get("ours")) for k in cells)] or columns
    return Grid(cells, shown, [c for c in columns if c not in shown], stats)


def extras(cell: dict) -> list[tuple[str, float]]:
    """A cell's further figures beside fednav's and the paper's (paper 003's improvement
    as its own Table 1 gives it), as (label, value)."""
    return [(label(k), v) for k, v in cell.items()
            if k not in ("ours", "ci95", "paper") and present(v)]


def what(table: dict, runs, seed, g: Grid) -> str:
    """What fednav's numbers in a table are (a CI is said only where there is one)."""
    n = table.get("runs", runs)
    if g.has_ci:
        return (f"fednav: mean ± 95 % confidence interval over {n} Monte Carlo runs "
                f"(seed {seed})")
    if n == 1:
        return (f"fednav: one Monte Carlo run (seed {seed}) — no confidence interval from a "
                "single run")
    return ("fednav: one computation (an analysis, not a Monte Carlo statistic) — no "
            "confidence interval")

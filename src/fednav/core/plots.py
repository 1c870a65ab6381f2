"""Plotting helpers shared by fednav's figures (the reproductions' ``errors.png``, the
``process`` plots, paper 001's ascent): figures without pyplot's global state, one legend
beside the axes, line styles that keep coinciding modes apart, Monte Carlo statistics
over runs and axis limits that a start-up transient or a diverging mode does not set.

Every ``*_figure`` function of fednav returns a :class:`matplotlib.figure.Figure` (a test
inspects its axes, labels, legend and lines); :func:`save` writes one atomically.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from .atomic import save_figure

#: Line styles given, in turn, to modes whose curves coincide (the first keeps "-").
LINESTYLES = ("-", (0, (5, 2)), (0, (1, 1.5)), "-.", (0, (8, 2, 1, 2)))
#: Widths that go with them: the first of a group widest, so that those drawn over it
#: leave it visible.
LINEWIDTHS = (2.6, 1.5, 1.2, 1.0, 0.9)
#: Relative difference under which two curves are "identical to plotting precision".
IDENTICAL_RTOL = 2e-3
#: Relative difference under which two curves coincide on the page (styled apart, noted).
COINCIDE_RTOL = 0.05


def new_figure(nrows: int = 1, ncols: int = 1, figsize=(10, 6), **subplots):
    """A :class:`~matplotlib.figure.Figure` and its (nrows, ncols) array of axes, outside
    pyplot (nothing to close, nothing shared between threads)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    axes = fig.subplots(nrows, ncols, squeeze=False, **subplots)
    return fig, axes


def save(fig, path) -> Path:
    """Write ``fig`` to ``path`` atomically (format from the suffix); returns the path."""
    return save_figure(fig, Path(path))


def colors() -> list[str]:
    """Matplotlib's default colour cycle."""
    import matplotlib as mpl

    return list(mpl.rcParams["axes.prop_cycle"].by_key()["color"])


def coinciding_groups(curves: dict[str, list[np.ndarray]],
                      rtol: float = COINCIDE_RTOL) -> list[list[str]]:
    """Groups (two or more names, in the given order) of the items whose arrays agree
    within ``rtol`` of the larger one's largest magnitude at 95 % of their samples (a
    start-up transient apart): curves that would hide each other on a plot."""
    names = list(curves)
    groups: list[list[str]] = []
    placed: set[str] = set()
    for i, a in enumerate(names):
        if a in placed:
            continue
        group = [a] + [b for b in names[i + 1:] if b not in placed
                       and relative_difference(curves[a], curves[b], 95.0) <= rtol]
        if len(group) > 1:
            groups.append(group)
            placed.update(group)
    return groups


def relative_difference(xs, ys, q: float = 100.0) -> float:
    """The ``q``-th percentile of the differences between paired arrays ``xs`` and ``ys``
    relative to their largest magnitude, the largest over the pairs (``q`` = 100: the
    largest difference; inf where shapes or missing values differ)."""
    if len(xs) != len(ys):
        return np.inf
    worst = 0.0
    for x, y in zip(xs, ys, strict=True):
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        if x.shape != y.shape:
            return np.inf
        fx, fy = np.isfinite(x), np.isfinite(y)
        if not np.array_equal(fx, fy):
            return np.inf
        if not fx.any():
            continue
        scale = max(np.abs(x[fx]).max(), np.abs(y[fy]).max())
        d = float(np.percentile(np.abs(x[fx] - y[fy]), q))
        worst = max(worst, d / scale if scale > 0 else 0.0)
    return worst


def mode_styles(names, groups: list[list[str]] | None = None) -> dict[str, dict]:
    """Line keyword arguments per name: a colour each, widths from wide to narrow (drawn in
    that order, lines that overlap stay visible); within a group of coinciding curves
    successive dash patterns over a wide first line."""
    cyc = colors()
    names = list(names)
    # widths from wide (the first) to narrow (the last): lines that overlap in one panel
    # stay visible as nested stripes
    widths = np.linspace(2.6, 1.1, len(names)) if len(names) > 1 else [1.3]
    styles = {n: {"color": cyc[i % len(cyc)], "ls": "-", "lw": float(widths[i])}
              for i, n in enumerate(names)}
    for g in groups or []:
        for k, n in enumerate(g):
            styles[n].update(ls=LINESTYLES[k % len(LINESTYLES)],
                             lw=LINEWIDTHS[min(k, len(LINEWIDTHS) - 1)])
    return styles


def identical_note(groups: list[list[str]], curves: dict[str, list[np.ndarray]],
                   samples: str = "epochs") -> str:
    """The figure note on groups of coinciding curves ("" without any): "A = B" where they
    are identical to plotting precision (:data:`IDENTICAL_RTOL` at every sample), "A ≈ B"
    with how close 95 % of the samples (named ``samples``) are otherwise."""
    parts = []
    for g in groups:
        d = max(relative_difference(curves[g[0]], curves[b]) for b in g[1:])
        d95 = max(relative_difference(curves[g[0]], curves[b], 95.0) for b in g[1:])
        parts.append(" = ".join(g) + " (identical to plotting precision)" if d <= IDENTICAL_RTOL
                     else " ≈ ".join(g) + f" (95 % of the {samples} within {100 * d95:.2g} %"
                     f" of the scale)")
    if not parts:
        return ""
    return "coinciding curves, drawn dashed over a wide solid line: " + "; ".join(parts)


def monte_carlo(errors: np.ndarray, sigma: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Statistics over the runs (axis 0) of signed errors ``errors`` (runs, K): ``rms``
    (K,) the root mean square over the runs, ``lo``/``hi`` their 5 and 95 % quantiles and,
    given the filter's 1-sigma ``sigma`` (runs, K), ``sigma`` its mean over the runs (NaN
    where no run has one)."""
    e = np.asarray(errors, dtype=float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns
        out = {"rms": np.sqrt(np.nanmean(e**2, axis=0)),
               "lo": np.nanpercentile(e, 5, axis=0), "hi": np.nanpercentile(e, 95, axis=0)}
        if sigma is not None:
            out["sigma"] = np.nanmean(np.asarray(sigma, dtype=float), axis=0)
    return out


def robust_scale(values, q: float = 99.0) -> float:
    """The ``q``-th percentile of ``|values|`` (finite ones; 0 without any): a scale that
    a start-up transient shorter than ``100 - q`` % of the samples does not set."""
    v = np.abs(np.asarray(values, dtype=float).ravel())
    v = v[np.isfinite(v)]
    return float(np.percentile(v, q)) if v.size else 0.0


def shared_limit(scales: dict[str, float], spread: float = 30.0) -> tuple[float, list[str]]:
    """A symmetric y-limit for curves of the given scales (name -> robust scale) and the
    names left off it: a curve more than ``spread`` times the median of the lower half
    of the scales (a free INS beside aided modes; with two modes, the smaller one) would
    flatten the others on a linear axis, so it runs off the axis and the figure says
    so."""
    s = {k: v for k, v in scales.items() if np.isfinite(v) and v > 0}
    if not s:
        return 1.0, []
    low = sorted(s.values())
    med = float(np.median(low[:max(1, (len(low) + 1) // 2)]))
    kept = {k: v for k, v in s.items() if v <= spread * med}
    off = [k for k in s if k not in kept]
    return 1.1 * max(kept.values()), off


def legend_outside(fig, handles, *, x: float = 0.805, y: float = 0.93, title: str | None = None,
                   fontsize: float = 8.5):
    """One legend for the whole figure, beside the axes (the axes end at ``x``)."""
    return fig.legend(handles=handles, loc="upper left", bbox_to_anchor=(x, y),
                      fontsize=fontsize, frameon=False, title=title,
                      title_fontsize=fontsize)


def note(fig, text: str, *, x: float = 0.01, y: float = 0.005, fontsize: float = 8.0):
    """A note along the figure's bottom edge (nothing for an empty text)."""
    if text:
        fig.text(x, y, text, fontsize=fontsize, ha="left", va="bottom", color="0.25",
                 wrap=True)


def shade_spans(ax, spans, **kw) -> None:
    """Grey vertical spans ``[(start, end), ...]`` (e.g. GNSS outages) behind the data."""
    style = {"facecolor": "0.5", "alpha": 0.15, "lw": 0, "zorder": 0} | kw
    for a, b in spans:
        ax.axvspan(a, b, **style)


def envelope(t, y, most: int = 500) -> tuple[np.ndarray, np.ndarray]:
    """At most ``most`` of the samples ``(t, y)`` (a 1-sigma, >= 0): the largest of each
    run of ``ceil(len / most)`` consecutive ones, at its own time.  A 1-sigma that zigzags
    from epoch to epoch (a 20 Hz filter whose velocity updates come at 6.7 Hz) drawn at
    every epoch over minutes fills a band; its upper envelope is the bound to read."""
    t, y = np.asarray(t), np.asarray(y)
    k = -(-len(t) // most) if len(t) > most else 1
    if k == 1:
        return t, y
    n = len(t) // k * k
    i = np.argmax(np.nan_to_num(y[:n], nan=-np.inf).reshape(-1, k), axis=1) + np.arange(0, n, k)
    if n < len(t):
        i = np.append(i, n + int(np.argmax(np.nan_to_num(y[n:], nan=-np.inf))))
    return t[i], y[i]


def gaps(t, factor: float = 3.0) -> list[tuple[float, float]]:
    """The gaps of time stamps ``t`` longer than ``factor`` times their median spacing
    (a sensor's outages)."""
    t = np.asarray(t, dtype=float)
    if len(t) < 2:
        return []
    d = np.diff(t)
    g = factor * float(np.median(d))
    i = np.flatnonzero(d > g)
    return [(float(t[k]), float(t[k + 1])) for k in i]

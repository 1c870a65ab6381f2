"""The Stanford diagram: each epoch's error against its protection level.

A point below the diagonal is an epoch the level bounded; above it, misleading
information (the error larger than the level said). With an alert limit ``AL`` the plane
splits into the regions integrity is certified on: normal operation (error ≤ PL < AL),
misleading information (PL < error, PL < AL, error < AL), hazardously misleading
information (PL < AL ≤ error), and the system unavailable (PL ≥ AL; misleading as well
when the error exceeds the level). Epochs with a fault detected and not excluded count
apart ("alerted"): the user was told. Counts are a two-dimensional histogram on
logarithmic axes, coloured by their logarithm, as in the field's own figures.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core import plots


def regions(err, pl, alert, limit: float | None) -> dict[str, int]:
    """The epochs in each region (module docstring) of errors ``err`` and levels ``pl``
    (same unit), ``alert`` per epoch (a fault detected and not excluded), alert limit
    ``limit`` (None: no limit: the
    regions above and below the diagonal only)."""
    err, pl = np.abs(np.asarray(err, dtype=float)), np.asarray(pl, dtype=float)
    alert = np.asarray(alert, dtype=bool)
    over = err > pl
    out = {"epochs": int(len(err)), "alerted": int(alert.sum())}
    quiet = ~alert
    if limit is None:
        out["bounded"] = int((quiet & ~over).sum())
        out["misleading"] = int((quiet & over).sum())
        return out
    avail = pl < limit
    out["normal"] = int((quiet & avail & ~over).sum())
    out["misleading"] = int((quiet & avail & over & (err < limit)).sum())
    out["hazardously_misleading"] = int((quiet & avail & over & (err >= limit)).sum())
    out["unavailable"] = int((quiet & ~avail & ~over).sum())
    out["unavailable_misleading"] = int((quiet & ~avail & over).sum())
    return out


def _panel(ax, err, pl, alert, limit, name: str, unit: str) -> None:
    err = np.abs(np.asarray(err, dtype=float))
    pl = np.asarray(pl, dtype=float)
    ok = np.isfinite(err) & np.isfinite(pl) & (pl > 0)
    e, p = np.maximum(err[ok], 1e-6), pl[ok]
    lo = 10 ** np.floor(np.log10(max(min(e.min(), p.min()), 1e-4)))
    hi = 10 ** np.ceil(np.log10(max(e.max(), p.max(), limit or 0.0) * 1.5))
    bins = np.logspace(np.log10(lo), np.log10(hi), 60)
    counts = np.histogram2d(e, p, bins=[bins, bins])[0]
    r = regions(err[ok], pl[ok], np.asarray(alert, dtype=bool)[ok], limit)
    counts_panel(ax, counts, bins, r, limit, name, unit)


def counts_panel(ax, counts, edges, region_counts: dict, limit, name: str, unit: str,
                 what: str = "epochs", title: str | None = None) -> None:
    """One panel of the diagram from a histogram ``counts`` (error bin, level bin) on
    ``edges`` (logarithmic, the same for both axes; empty rows and columns at the ends
    cut off) and the :func:`regions` counts ``region_counts``; ``name`` the axes' quantity,
    ``title`` the panel's (default ``name``)."""
    from matplotlib.colors import LogNorm

    counts = np.asarray(counts, dtype=float)
    used = np.flatnonzero(counts.sum(axis=0) + counts.sum(axis=1))
    lo_i = max(int(used[0]) - 1, 0) if len(used) else 0
    hi_i = min(int(used[-1]) + 2, len(edges) - 1) if len(used) else len(edges) - 1
    if limit is not None:
        hi_i = max(hi_i, min(int(np.searchsorted(edges, limit * 1.5)), len(edges) - 1))
    lo, hi = edges[lo_i], edges[hi_i]
    mesh = ax.pcolormesh(edges, edges, np.ma.masked_less(counts.T, 1), norm=LogNorm(),
                         cmap="viridis")
    ax.figure.colorbar(mesh, ax=ax, label=what)
    ax.plot([lo, hi], [lo, hi], color="k", lw=0.9)
    if limit is not None:
        ax.axhline(limit, color="tab:red", lw=0.9, ls="--")
        ax.axvline(limit, color="tab:red", lw=0.9, ls="--")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    text = "\n".join(f"{k.replace('_', ' ')}: {v}" for k, v in region_counts.items())
    ax.text(0.97, 0.03, text, transform=ax.transAxes, ha="right", va="bottom", fontsize=8,
            bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "0.7"})
    ax.set_xlabel(f"{name} error [{unit}]")
    ax.set_ylabel(f"{name} protection level [{unit}]")
    ax.set_title(f"{title or name}: {region_counts['epochs']} {what}", fontsize=10)
    ax.grid(alpha=0.3, which="both")


def stanford_figure(panels: list[tuple], title: str = ""):
    """The diagram, one panel per ``(name, unit, err, pl, alert, limit)`` (errors and
    levels per epoch, in ``unit``; ``limit`` the alert limit or None)."""
    fig, axes = plots.new_figure(1, len(panels), figsize=(6.2 * len(panels), 5.4))
    for ax, (name, unit, err, pl, alert, limit) in zip(np.ravel(axes), panels,
                                                       strict=True):
        _panel(ax, err, pl, alert, limit, name, unit)
    fig.suptitle("Stanford diagram: error against protection level"
                 + (f" ({title})" if title else ""), fontsize=11)
    fig.subplots_adjust(left=0.07, right=0.97, bottom=0.12, top=0.86, wspace=0.3)
    return fig


def plot_run(res, errors: dict, path: Path) -> Path:
    """``stanford.png`` of a processed run with integrity (``res.integrity``) against a
    reference's ``errors`` (:func:`fednav.process.evaluation.errors_against`): horizontal
    and vertical, the levels taken at the reference's times."""
    from ..navigator.integrity import IntegrityConfig

    ig = res.integrity
    cfg = ig.config or IntegrityConfig()
    t = errors["t"]
    i = ig.rows_at(t)
    panels = [("horizontal", "m", np.hypot(errors["east_m"], errors["north_m"]),
               np.interp(t, ig.t, ig.hpl), ig.detected[i], cfg.alert_limit_horizontal_m),
              ("vertical", "m", errors["up_m"], np.interp(t, ig.t, ig.vpl), ig.detected[i],
               cfg.alert_limit_vertical_m)]
    return plots.save(stanford_figure(panels), path)

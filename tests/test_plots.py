"""The figures' structure (issue 29): every axis labelled with its unit, one legend beside
the data, linear axes, the Monte Carlo spread and the filter's 3-sigma on the
reproductions' plots, sigma at the filter epochs on the ``process`` plots, coinciding
modes told apart, the track's start/end markers and zoom, the ascent's two y axes.

The plotting functions return :class:`matplotlib.figure.Figure` objects; these tests read
them (no PNG decoding)."""

import re

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from fednav import System
from fednav.campaign.report import errors_figure
from fednav.core import plots, units
from fednav.io.data import GnssData, ImuData, Reference
from fednav.process import output, process
from fednav.sensors import ImuErrors as SimImuErrors
from fednav.sensors import corrupt_imu
from fednav.sim.runs import RunResult
from fednav.sim.trajectory import Segment, generate

UNIT = re.compile(r"\[[^\]]+\]")


def _drawn(fig):
    FigureCanvasAgg(fig)
    fig.canvas.draw()
    return fig


def _data_axes(fig):
    return [a for a in fig.axes if a.get_visible()]


def _assert_report_figure(fig, n_axes):
    """Every axis: a y label with a unit, linear; the bottom row an x label with a unit;
    one figure legend, no legend inside any axes, right of every axes."""
    _drawn(fig)
    axes = _data_axes(fig)
    assert len(axes) == n_axes
    for ax in axes:
        assert UNIT.search(ax.get_ylabel()), ax.get_ylabel()
        assert ax.get_yscale() == "linear" and ax.get_xscale() == "linear"
        assert ax.get_legend() is None
    bottom = [ax for ax in axes if ax.get_subplotspec().is_last_row()]
    assert bottom and all(UNIT.search(ax.get_xlabel()) for ax in bottom)
    assert len(fig.legends) == 1
    r = fig.canvas.get_renderer()
    leg = fig.legends[0].get_window_extent(r)
    assert all(leg.x0 >= ax.get_window_extent(r).x1 for ax in axes)


# ------------------------------------------------------------------ reproductions
def _run(mode, t, err, sigma):
    z = np.zeros_like(err)
    return RunResult(mode, t, err, z + 0.1 * err, z + units.arcsec(1.0) * err / 5.0,
                     sigma)


def _runs_series(n_runs=5, K=200):
    """Modes A and B identical, C smaller, SINS a thousand times larger (a free INS)."""
    rng = np.random.default_rng(0)
    t = np.arange(1, K + 1, dtype=float)
    out = []
    for _ in range(n_runs):
        e = np.cumsum(rng.standard_normal((K, 3)), axis=0) * 0.2
        sig = np.full((K, 18), 2.0)
        free = np.full((K, 18), np.nan)
        out.append({"A": _run("A", t, e, sig), "B": _run("B", t, e.copy(), sig),
                    "C": _run("C", t, 0.3 * e + 0.05, sig),
                    "SINS": _run("SINS", t, 1000 * e + 5e3, free)})
    return out


def test_reproduction_errors_show_rms_spread_and_sigma_over_the_runs():
    runs = _runs_series()
    fig = errors_figure(runs, "Paper X")
    _assert_report_figure(fig, 9)
    assert fig._suptitle.get_text().startswith("Paper X: navigation errors")
    assert fig.axes[0].get_title() == "east position"
    assert fig.axes[6].get_title() == "φE (east) misalignment"
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[:4] == ["A", "B", "C", "SINS"]
    assert "RMS over 5 runs" in labels and "5–95 % of the runs" in labels
    assert any("±3σ" in lab for lab in labels)
    ax = fig.axes[0]  # east position
    assert ax.get_ylabel() == "position error [m]"
    assert len(ax.collections) == 4  # a 5-95 % band per mode
    e = np.stack([r["C"].pos[:, 0] for r in runs])
    rms = [ln for ln in ax.lines if ln.get_gid() != "sigma" and len(ln.get_xdata()) > 2]
    np.testing.assert_allclose(rms[2].get_ydata(), np.sqrt((e**2).mean(axis=0)))
    band = ax.collections[2].get_paths()[0].vertices[:, 1]
    lo, hi = np.percentile(e, [5, 95], axis=0)
    assert np.isclose(band.min(), lo.min()) and np.isclose(band.max(), hi.max())
    # the filter's 3 sigma of the modes that have one (not the free INS)
    sig = [ln for ln in ax.lines if ln.get_gid() == "sigma"]
    assert len(sig) == 6 and np.allclose(np.abs(sig[0].get_ydata()), 6.0)
    # A and B coincide: two line styles, a wide solid one under a dashed one; the note says
    st = {ln.get_label(): (ln.get_linestyle(), ln.get_linewidth())
          for ln in fig.legends[0].get_lines()}
    assert st["A"][0] == "-" and st["B"][0] != "-" and st["A"][1] > st["B"][1]
    text = " ".join(t.get_text() for t in fig.texts)
    assert "A = B (identical to plotting precision)" in text
    # the free INS runs off the linear axes, said in the note; the others set the scale
    assert "off the axes: SINS" in text
    assert ax.get_ylim()[1] < 100



def test_design_errors_are_linear_from_zero_with_units_and_one_legend_outside():
    """``fednav run``'s errors.png (it had log axes): linear axes from zero with units,
    one legend beside them; the free INS runs off the axes and the note says how far."""
    from dataclasses import replace

    from fednav.campaign.design import spread_figure

    runs = [{m: replace(r, euler=r.att) for m, r in rs.items()} for rs in _runs_series()]
    windows = [{"start_s": 50.0, "end_s": 80.0, "sensors": ["gnss"]}]
    fig = spread_figure(runs, windows, "my design")
    _assert_report_figure(fig, 3)
    assert [ax.get_ylabel() for ax in fig.axes] == [
        "horizontal position error [m]", "height error [m]", "heading error [deg]"]
    assert fig.axes[-1].get_xlabel() == "time [s]"
    assert all(ax.get_ylim()[0] == 0.0 for ax in fig.axes)
    assert fig.axes[0].get_ylim()[1] < 100 and fig.axes[1].get_ylim()[1] < 100  # (not SINS)
    text = " ".join(t.get_text() for t in fig.texts)
    assert "off the axes: SINS (median horizontal position up to" in text
    assert "A = B (identical to plotting precision)" in text  # B dashed over a wide A
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[:4] == ["A", "B", "C", "SINS"] and "outage: gnss" in labels
    # the median of mode C's horizontal error over the runs, as drawn
    h = np.stack([np.hypot(r["C"].pos[:, 0], r["C"].pos[:, 1]) for r in runs])
    med = [ln for ln in fig.axes[0].lines if ln.get_gid() != "sigma"][2]
    np.testing.assert_allclose(med.get_ydata(), np.median(h, axis=0))

def test_reproduction_errors_of_one_dict_are_one_run():
    fig = errors_figure(_runs_series(1)[0])
    assert "1 Monte Carlo run" in fig._suptitle.get_text()
    _assert_report_figure(fig, 9)


def test_sigma_envelope_keeps_the_largest_of_each_run_of_epochs():
    t = np.arange(1000) * 0.05
    y = np.where(np.arange(1000) % 3 == 0, 1.0, 2.0)  # a zigzag between updates
    ts, ys = plots.envelope(t, y, most=500)
    assert len(ts) == 500 and np.isin(ts, t).all() and (ys == 2.0).all()
    assert plots.envelope(t[:400], y[:400], most=500)[0] is not None
    np.testing.assert_array_equal(plots.envelope(t[:400], y[:400])[1], y[:400])


def test_coinciding_groups_and_their_note():
    a = [np.linspace(0, 1, 50)]
    c = a[0] * 1.02
    c[0] = 0.3  # (a start-up transient does not keep curves apart)
    curves = {"a": a, "b": [a[0] * (1 + 1e-4)], "c": [c], "d": [a[0] + 1]}
    groups = plots.coinciding_groups(curves)
    assert groups == [["a", "b", "c"]]
    note = plots.identical_note(groups, curves)
    assert "a ≈ b ≈ c (95 % of the epochs within 1.9 % of the scale)" in note
    assert plots.identical_note([["a", "b"]], curves).endswith(
        "a = b (identical to plotting precision)")
    assert plots.shared_limit({"x": 1.0, "y": 2.0, "free": 500.0}) == (2.2, ["free"])
    # two modes: the free INS still runs off (the median of both was half its scale)
    assert plots.shared_limit({"aided": 1.0, "free": 500.0}) == (1.1, ["free"])
    assert plots.shared_limit({"only": 500.0}) == (550.0, [])


def test_paper000_errors_figure_from_real_runs(tmp_path):
    """Two short Monte Carlo runs of paper 000: every panel has the filter's 3 sigma."""
    from fednav.scenarios import paper000

    scn = paper000.load_scenario()
    runs = [paper000.one_run((scn, seed, 20.0))[1] for seed in (1, 2)]
    runs = [{k: v for k, v in r.items() if "," not in k} for r in runs]
    fig = errors_figure(runs, "Paper 000")
    _assert_report_figure(fig, 9)
    for ax in fig.axes[:9]:
        sig = [ln for ln in ax.lines if ln.get_gid() == "sigma"]
        assert sig and all(np.isfinite(ln.get_ydata()).all() for ln in sig)
    assert "AEKF/none = AEKF/wind" in " ".join(t.get_text() for t in fig.texts)
    p = plots.save(fig, tmp_path / "errors.png")
    assert p.read_bytes()[:4] == b"\x89PNG"
    # the wind window over the runs: RMS and band per mode, one legend beside, noted
    fig = _drawn(paper000.window_figure(runs, window=(0.0, 20.0)))
    for ax in fig.axes:
        assert UNIT.search(ax.get_ylabel()) and ax.get_yscale() == "linear"
        assert ax.get_legend() is None and len(ax.collections) == 6
    assert fig.axes[-1].get_xlabel() == "time [s]" and len(fig.legends) == 1
    assert "3 Monte Carlo runs" not in fig._suptitle.get_text()  # (2 here)
    assert "2 Monte Carlo runs" in fig._suptitle.get_text()


def test_latency_sweep_and_fdi_figures():
    import pandas as pd

    from fednav.campaign.report import fdi_figure
    from fednav.scenarios import paper004

    rows = [{"mode": m, "max_latency_s": lat, "lon_std_m": v * lat, "lat_std_m": v * lat}
            for lat in (1.5, 3.0, 6.0) for m, v in (("none", 100.0), ("a", 1.0),
                                                     ("b", 1.01))]
    fig = _drawn(paper004.sweep_figure(rows))
    (ax,) = fig.axes
    assert UNIT.search(ax.get_xlabel()) and UNIT.search(ax.get_ylabel())
    assert ax.get_legend() is None and len(fig.legends) == 1
    assert [ln.get_linestyle() for ln in ax.lines][1:] != ["-", "-"]
    assert "a ≈ b (95 % of the latencies within 0.94 % of the scale)" in fig.texts[0].get_text()
    fdi = pd.DataFrame({"t": np.r_[1.0:11.0, 1.0:11.0], "local": ["gnss"] * 10 + ["star"] * 10,
                        "statistic": np.r_[np.ones(9), 50.0, np.ones(10)], "dof": 3,
                        "threshold": 11.3, "isolated": np.r_[[False] * 9, True,
                                                             [False] * 10]})
    fig = _drawn(fdi_figure(fdi, "t"))
    assert [a.get_title() for a in fig.axes] == ["local filter 'gnss' (1 of 10 isolated)",
                                                  "local filter 'star' (0 of 10 isolated)"]
    assert all(UNIT.search(a.get_ylabel()) for a in fig.axes)
    assert all(a.get_legend() is None for a in fig.axes) and len(fig.legends) == 1


def test_paper001_errors_over_runs_in_the_launch_frame():
    from types import SimpleNamespace

    from fednav.scenarios import paper001

    rng = np.random.default_rng(1)
    t = np.arange(1.0, 101.0)

    def res():
        e = np.cumsum(rng.standard_normal((100, 3)), axis=0)
        return SimpleNamespace(t=t, att=units.arcsec(e), pos=e, vel=0.01 * e,
                               sigma=np.tile(np.r_[units.arcsec([5.0] * 3), [3.0] * 3,
                                                   [0.1] * 3], (100, 1)))

    fig = paper001.errors_figure([{"pf": res(), "ekf": res()} for _ in range(3)])
    _assert_report_figure(fig, 9)
    assert [a.get_ylabel() for a in fig.axes[::3]] == [
        "attitude error [arcsec]", "position error [m]", "velocity error [m/s]"]
    assert fig.axes[0].get_title() == "LI x attitude"
    assert fig.axes[-1].get_xlabel() == "time since launch [s]"
    labels = [x.get_text() for x in fig.legends[0].get_texts()]
    assert labels[:2] == ["PF", "EKF"] and "RMS over 3 runs" in labels
    sig = [ln for ln in fig.axes[3].lines if ln.get_gid() == "sigma"]
    assert np.allclose(np.abs(sig[0].get_ydata()), 9.0)  # 3 x the position sigma


# ------------------------------------------------------------------ process
def _flight(T=120.0):
    """A drive with turns, 100 Hz IMU, 5 Hz GNSS with a 20 s outage."""
    segs = [Segment(15.0), Segment(10.0, accel=1.0), Segment(30.0, heading_rate=units.deg(3)),
            Segment(T - 55.0)]
    truth = generate(np.array([units.deg(45.0), units.deg(-75.0), 50.0]), 0.0,
                     [0.0, 0.0, units.deg(45.0)], segs, 0.01)
    from test_process import simulated_imu

    rng = np.random.default_rng(3)
    imu = simulated_imu(truth, rng)
    tg = np.arange(0.2, truth.t[-1], 0.2)
    tg = tg[(tg < 70.0) | (tg > 90.0)]
    tr = truth.at(tg)
    lla = tr["lla"] + np.column_stack([rng.standard_normal((len(tg), 2)) * 1e-7,
                                       rng.standard_normal(len(tg)) * 0.5])
    gnss = GnssData("sim-gnss", tg, lla, tr["vel"] + rng.standard_normal((len(tg), 3)) * 0.05,
                    np.full(3, 0.5), np.full(3, 0.05), np.zeros(3))
    ref = Reference("truth", truth.t, truth.lla, truth.vel, truth.euler)
    return imu, gnss, ref


@pytest.fixture(scope="module")
def processed():
    imu, gnss, ref = _flight()
    return process(imu, {"gnss": gnss}, System(), smooth=True), gnss, ref


def test_process_errors_have_human_titles_units_and_sigma_at_the_filter_epochs(processed):
    res, gnss, ref = processed
    fig = output.errors_figure(res, ref, gnss)
    _assert_report_figure(fig, 9)
    f = res.forward
    te = f.t[f.epoch_rows]
    assert len(te) < len(f.t) / 10  # (epochs, not IMU rows)
    for ax in fig.axes[:9]:
        assert "_" not in ax.get_title() and "_" not in ax.get_ylabel()
        assert "\nRMSE forward" in ax.get_title() and "smoothed" in ax.get_title()
        sig = [ln for ln in ax.lines if ln.get_gid() == "sigma"]
        assert len(sig) == 4  # forward and smoothed, +-
        for ln in sig:  # at epochs (their upper envelope over 500 of them: 600 here)
            assert np.isin(ln.get_xdata(), te).all() and len(ln.get_xdata()) == 300
    ax = fig.axes[0]
    assert ax.get_title().startswith("east position") and ax.get_ylabel() == (
        "east position error [m]")
    assert fig.axes[1].get_ylabel() == "north position error [m]"
    assert fig.axes[2].get_ylabel() == "up position error [m]"
    assert fig.axes[3].get_ylabel() == "east velocity error [m/s]"
    assert fig.axes[6].get_ylabel() == "pitch error [deg]"
    assert fig.axes[8].get_ylabel() == "yaw error [deg]"
    # the forward east sigma (column 6 of the ENU sigmas) at the epochs; the smoothed
    # one is smaller
    s = [ln for ln in ax.lines if ln.get_gid() == "sigma"]
    ts, sd = plots.envelope(te, f.sigma[f.epoch_rows, 6])
    np.testing.assert_array_equal(s[0].get_xdata(), ts)
    np.testing.assert_allclose(s[0].get_ydata(), 3 * sd)
    assert np.mean(s[2].get_ydata()) < np.mean(s[0].get_ydata())
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "smoothed ±3σ (at filter epochs)" in labels and "GNSS outage" in labels
    assert any(abs(p.get_x() - 70.0) < 0.5 for p in ax.patches)  # the outage, shaded


def test_track_has_start_end_outage_and_a_zoom(processed):
    res, gnss, ref = processed
    fig = _drawn(output.track_figure(res, gnss, ref))
    main, zoom = fig.axes
    for ax in (main, zoom):
        assert ax.get_xlabel() == "east [m]" and ax.get_ylabel() == "north [m]"
        assert ax.get_legend() is None
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    for want in ("start", "end", "forward in GNSS outage", "reference", "GNSS fixes",
                 "forward", "smoothed"):
        assert want in labels, labels
    assert zoom.get_title().startswith("zoom: longest GNSS outage, 69.8–90.0 s")
    # the zoom's frame drawn on the overview, smaller than it
    frame = [p for p in main.patches if p.get_edgecolor()[:3] != (1, 1, 1)][-1]
    x0, x1 = main.get_xlim()
    assert frame.get_width() < 0.5 * (x1 - x0)
    np.testing.assert_allclose(zoom.get_xlim(), (frame.get_x(), frame.get_x()
                                                 + frame.get_width()))


def test_track_marks_each_local_filters_isolated_measurements(processed):
    """The fault detection log's isolated measurements: one marker series per local
    filter, in the order they first appear, at the solution's rows of their times."""
    from dataclasses import replace

    res, gnss, ref = processed
    f = res.forward
    fdi = [(100.0, "gnss", 30.0, 3, 11.3, True), (100.2, "velocity", 1.0, 3, 11.3, False),
           (101.0, "velocity", 40.0, 3, 11.3, True), (102.0, "gnss", 25.0, 3, 11.3, True),
           (103.0, "gnss", 1.0, 3, 11.3, False)]
    fig = _drawn(output.track_figure(replace(res, forward=replace(f, fdi=fdi)), gnss, ref))
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert [s for s in labels if "isolated" in s] == ["gnss isolated (2)",
                                                      "velocity isolated (1)"]
    main = fig.axes[0]
    gn = next(ln for ln in main.lines if ln.get_label() == "gnss isolated (2)")
    assert gn.get_marker() == "x" and len(gn.get_xdata()) == 2


def test_ascent_puts_height_and_speed_on_two_axes():
    from fednav.scenarios import paper001

    fig = _drawn(paper001.ascent_figure(paper001.load_scenario(), 200.0))
    ylabels = [a.get_ylabel() for a in fig.axes]
    assert "height [km]" in ylabels and "LI speed [km/s]" in ylabels
    h = next(a for a in fig.axes if a.get_ylabel() == "height [km]")
    v = next(a for a in fig.axes if a.get_ylabel() == "LI speed [km/s]")
    assert h is not v and h.get_position().bounds == v.get_position().bounds
    assert all(UNIT.search(a.get_ylabel()) for a in fig.axes)
    assert all(a.get_yscale() == "linear" for a in fig.axes)


def test_allan_is_log_log_with_units_and_one_legend_outside():
    """``fednav allan``'s plot: log–log (right for an Allan deviation), units on every
    axis, one legend beside the panels naming the IMU axes, nothing inside the axes but
    the curves and the figures' note."""
    from fednav.process.allan import allan, allan_figure

    rng = np.random.default_rng(1)
    n, dt = 60_000, 0.01
    t = np.arange(n) * dt
    errors = SimImuErrors(gyro_arw=units.deg_per_sqrt_h(0.2), accel_vrw=units.micro_g(80.0))
    dth, dv, _ = corrupt_imu(np.zeros((n, 3)), np.tile([0.0, 0.0, 9.81 * dt], (n, 1)), dt,
                             errors, rng)
    fig = _drawn(allan_figure(allan(ImuData("static", t, dth / dt, dv / dt))))
    axes = _data_axes(fig)
    assert len(axes) == 2
    assert [ax.get_ylabel() for ax in axes] == ["σ(τ) [deg/h]", "σ(τ) [µg]"]
    for ax in axes:
        assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
        assert ax.get_xlabel() == "averaging time τ [s]" and ax.get_legend() is None
    assert len(fig.legends) == 1
    r = fig.canvas.get_renderer()
    leg = fig.legends[0].get_window_extent(r)
    assert all(leg.x0 >= ax.get_window_extent(r).x1 for ax in axes)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[:3] == ["x axis (right)", "y axis (forward)", "z axis (up)"]

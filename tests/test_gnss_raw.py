"""Raw GNSS (tightly coupled): the pseudorange and range-rate rows against finite
differences of the range model, the receiver clock's states, the simulated sky, and
the navigator flying satellites — fewer than four included — with one faulty satellite
excluded rather than the receiver."""

from pathlib import Path

import numpy as np
import pytest

from fednav.core import attitude as att
from fednav.core import earth, units
from fednav.core.config import ConfigError
from fednav.ins import error_model as em
from fednav.ins.states import N_CORE, StateLayout
from fednav.sensors.gnss_raw import (
    FIELDS,
    PR,
    PRN,
    RR,
    SLOTS,
    GnssRawConfig,
    SatelliteRanges,
    pack,
    walker,
)
from fednav.sensors.measurement import NavSnapshot
from fednav.sensors.satellites import GM, OMEGA_E

LLA = np.array([units.deg(47.4), units.deg(8.55), 480.0])
LEVER = np.array([0.4, -1.1, 1.3])
CLOCK = (3.0e5, 100.0)


def _layout():
    return StateLayout.of({"gyro_scale": (1e-3, np.inf),
                           "clock": (CLOCK, np.inf, (0.01, 0.04))})


def _sky(t=1000.0, nav=None):
    """The satellites above 10 deg at ``t`` as one measurement."""
    pos, vel = walker(t)
    pos, vel = pos[0], vel[0]
    r = earth.llh_to_ecef(*LLA)
    u = (pos - r) / np.linalg.norm(pos - r, axis=1)[:, None]
    up = u @ earth.enu_to_ecef(LLA[0], LLA[1])[:, 2]
    seen = np.flatnonzero(up > np.sin(units.deg(10.0)))
    rows = np.full((len(seen), len(FIELDS)), np.nan)
    rows[:, PRN] = seen + 1
    rows[:, 1:4], rows[:, 4:7] = pos[seen], vel[seen]
    # ranges from the antenna of ``nav`` (default: the IMU at LLA) with the clock 1234 m
    # and 3 m/s, less a few metres (the residual is what the tests read)
    from fednav.sensors.gnss_raw import _antenna

    rx, vx, _, _ = _antenna(nav or _nav(), LEVER if nav is not None else np.zeros(3))
    d = pos[seen] - rx
    rho = np.linalg.norm(d, axis=1)
    rows[:, PR] = rho + 1234.0 - 5.0 * np.sin(seen)
    rows[:, RR] = np.einsum("ij,ij->i", d / rho[:, None], vel[seen] - vx) + 3.0 \
        - 0.2 * np.cos(seen)
    return pack(rows), seen


def _nav(lla=LLA, vel=(12.0, -5.0, 0.3), euler=(0.05, -0.02, 1.1), omega=(0.01, -0.02, 0.2)):
    return NavSnapshot(np.asarray(lla, float), np.asarray(vel, float),
                       att.euler_to_dcm(np.asarray(euler, float)), np.asarray(omega, float))


def test_walker_sky_is_gps_like():
    """Radius and speed of GPS's orbits, velocity the derivative of position (in the
    Earth frame), and 6 to 12 satellites above 10 deg at mid-latitude all day (30 satellites,
    as GPS has 31)."""
    t = np.arange(0.0, 86400.0, 600.0)
    pos, vel = walker(t)
    np.testing.assert_allclose(np.linalg.norm(pos, axis=2), 26_559_700.0, rtol=1e-12)
    inertial = vel + OMEGA_E * np.stack([-pos[..., 1], pos[..., 0], 0 * pos[..., 0]], -1)
    np.testing.assert_allclose(np.linalg.norm(inertial, axis=2),
                               np.sqrt(GM / 26_559_700.0), rtol=1e-9)
    p1, _ = walker(t + 0.5)
    p0, _ = walker(t - 0.5)
    np.testing.assert_allclose(p1 - p0, vel, atol=1e-3)
    r = earth.llh_to_ecef(*LLA)
    up = earth.enu_to_ecef(LLA[0], LLA[1])[:, 2]
    n = (((pos - r) @ up) / np.linalg.norm(pos - r, axis=2) > np.sin(units.deg(10.0))).sum(1)
    assert 6 <= n.min() and n.max() <= 12


def test_the_walker_sky_as_broadcast_ephemerides_is_the_walker_sky():
    """walker_ephemerides: IS-GPS-200's orbit model of its records gives walker()'s
    positions to a millimetre and velocities to 1 mm/s, across records and a week's end."""
    from fednav.sensors.gnss_raw import START_GPS_S, walker_ephemerides
    from fednav.sensors.satellites import WEEK_S, nearest_ephemeris, satellite_states

    for start in (START_GPS_S, 2401 * WEEK_S - 5000.0):
        eph = walker_ephemerides(start, start + 20000.0)
        sv = np.array([f"G{i:02d}" for i in range(1, 31)])
        t = start + np.arange(0.0, 20000.0, 700.0)
        pos, vel, clk, _ = satellite_states(eph, nearest_ephemeris(eph, sv, t),
                                            np.broadcast_to(t[:, None], (len(t), 30)))
        p0, v0 = walker(t - start)
        assert np.abs(pos - p0).max() < 1e-3 and np.abs(vel - v0).max() < 1e-3
        assert np.all(clk == 0.0)


def test_the_simulated_pseudoranges_solve_the_light_time_equation():
    """A receiver at rest with no noise and no clock: its pseudoranges are the light
    time solved apart (tests/test_satellites.py) to a millimetre, its satellites where
    they transmitted, turned by the Earth's rotation; its range rates the satellites'
    velocities along the line of sight (the receiver still)."""
    from types import SimpleNamespace

    from test_satellites import _pseudoranges

    from fednav.sensors.gnss_raw import START_GPS_S, RawReceiver, walker_ephemerides

    lla = np.array([np.radians(35.0), np.radians(139.0), 50.0])
    truth = SimpleNamespace(t=np.array([0.0, 600.0]), at=lambda t: {
        "lla": np.tile(lla, (len(t), 1)), "vel": np.zeros((len(t), 3))})
    rx = RawReceiver(30.0, 1e-12, 1e-12, float(units.deg(5.0)), (0.0, 0.0, 0.0, 0.0))
    s = rx.simulate(truth, np.random.default_rng(0))
    z = s.z.reshape(len(s.t), SLOTS, len(FIELDS))
    eph = walker_ephemerides(START_GPS_S, START_GPS_S)  # (one record a satellite)
    r = earth.llh_to_ecef(*lla)
    pr = _pseudoranges(eph, r, s.t + START_GPS_S, 0.0)
    got = 0
    for i in range(len(s.t)):
        for j in np.flatnonzero(np.isfinite(z[i, :, PRN])):
            k = int(z[i, j, PRN]) - 1
            if np.isfinite(pr[i, k]):
                assert abs(z[i, j, PR] - pr[i, k]) < 1e-3
                got += 1
            d = z[i, j, 1:4] - r
            u = d / np.linalg.norm(d)
            assert abs(z[i, j, RR] - u @ z[i, j, 4:7]) < 1e-6
    assert got >= 5 * len(s.t)


def _perturbed(nav, dx):
    """The INS with error ``dx`` (filter units: the 18 states) added: position moved by
    dp (ENU m), velocity by dv, attitude exp(-[phi x]) C."""
    lla = earth.move_enu(nav.lla, dx[6:9])
    C = att.apply_misalignment(nav.C, dx[0:3] * em.SCALE[0:3])
    return NavSnapshot(lla, nav.vel + dx[3:6], C, nav.omega_b)


def test_rows_are_the_derivative_of_the_range_model():
    """H of the pseudorange and range-rate rows (lever arm, attitude, clock) against
    central differences of the residual."""
    model = SatelliteRanges()
    model.lever = LEVER
    z, seen = _sky(nav=_nav())
    lay = _layout()
    xa = np.zeros(lay.n)
    ic = lay.start("clock")
    xa[ic:ic + 2] = 1234.0, 3.0
    nav = _nav()
    b = model.bind(z, nav, lay, xa)
    assert b.dim == 2 * len(seen) and set(b.groups) == set(seen + 1)
    H = b.H(nav)
    steps = {0: 2.0, 1: 2.0, 2: 2.0, 3: 0.05, 4: 0.05, 5: 0.05, 6: 5.0, 7: 5.0, 8: 5.0}
    for j, h in steps.items():
        e = np.zeros(em.N_STATES)
        e[j] = h
        fd = (b.residual(_perturbed(nav, e)) - b.residual(_perturbed(nav, -e))) / (2 * h)
        np.testing.assert_allclose(H[:, j], fd, atol=2e-6, err_msg=f"column {j}")
    assert not H[:, 9:ic].any()
    # the clock: the residual is INS + estimate - measured; its error (true - estimated)
    # enters with -1
    assert (H[:len(seen), ic] == -1.0).all() and (H[len(seen):, ic + 1] == -1.0).all()
    xb = xa.copy()
    xb[ic] += 1.0
    xb[ic + 1] += 0.5
    d = model.bind(z, nav, lay, xb).residual(nav) - b.residual(nav)
    np.testing.assert_allclose(d, np.r_[np.ones(len(seen)), 0.5 * np.ones(len(seen))])
    np.testing.assert_allclose(b.h(np.eye(lay.n)[:3], nav), H[:, :3].T[:3].reshape(3, -1))
    # a measurement valid dt before the epoch sees the clock there: cb + dt cd, and its
    # error dcb + dt dcd
    m = len(seen)
    c = model.bind(z, nav, lay, xa, dt=-0.4)
    np.testing.assert_allclose(c.residual(nav) - b.residual(nav),
                               np.r_[np.full(m, -0.4 * 3.0), np.zeros(m)], atol=1e-9)
    np.testing.assert_allclose(c.H(nav)[:m, ic + 1], 0.4)
    np.testing.assert_array_equal(c.H(nav)[m:], H[m:])
    sub = c.subset(c.groups != c.groups[0])
    assert sub.dim == c.dim - 2 and sub.dt == c.dt
    np.testing.assert_allclose(sub.residual(nav), np.delete(c.residual(nav), [0, m]))


def test_the_mask_and_the_empty_slots_leave_rows_out():
    model = SatelliteRanges(mask=units.deg(30.0))
    z, seen = _sky()
    b = model.bind(z, _nav(), _layout(), np.zeros(_layout().n))
    assert 0 < len(b.sat) < len(seen)
    assert np.isnan(z.reshape(SLOTS, -1)[len(seen):]).all()
    # a satellite without Doppler has its pseudorange row only
    s = z.reshape(SLOTS, -1).copy()
    s[0, RR] = np.nan
    b = SatelliteRanges().bind(s.ravel(), _nav(), _layout(), np.zeros(_layout().n))
    assert b.dim == 2 * len(seen) - 1


def test_the_clock_block_integrates_its_drift():
    """cb' = cd: F couples them, Phi carries T, the totals follow cb += T cd, and the
    nonlinear propagation agrees with Phi."""
    lay = _layout()
    ic = lay.start("clock")
    assert lay.n == N_CORE + 5 and ic == 21 and lay.coupled
    np.testing.assert_allclose(lay.transition(2.0), [[1, 0, 0, 0, 0], [0, 1, 0, 0, 0],
                                                    [0, 0, 1, 0, 0], [0, 0, 0, 1, 2.0],
                                                    [0, 0, 0, 0, 1]], atol=1e-12)
    nom = em.Nominal(lat=LLA[0], h=LLA[2], vel=np.array([12.0, -5.0, 0.3]),
                     C=att.euler_to_dcm([0.05, -0.02, 1.1]), fn=np.array([0.2, 0.1, 9.8]))
    p = em.ErrorProcess(nom, 1.0, em.ImuNoiseModel(), nsub=10, layout=lay)
    assert p.Phi[ic, ic + 1] == pytest.approx(1.0, rel=1e-12)
    assert p.Phi[ic + 1, ic] == 0.0
    x = np.zeros(lay.n)
    x[ic:ic + 2] = 10.0, 2.0
    np.testing.assert_allclose(p.transition(x[None])[0][ic:ic + 2], [12.0, 2.0], rtol=1e-9)
    # white frequency and random-walk frequency noise (trapezoid: S_g T^3 / 2)
    np.testing.assert_allclose(p.Qd[ic:ic + 2, ic:ic + 2],
                               [[0.01 + 0.04 / 2, 0.02], [0.02, 0.04]], rtol=1e-9)


def test_clock_states_come_with_the_sensor():
    from fednav import load_system
    from fednav.navigator.system import state_layout

    s = load_system({"sensors": {"gnss_raw": {"clock": "ocxo"}}})
    lay = state_layout(s)
    assert lay.names == ("clock",)
    sf, sg = GnssRawConfig(clock="ocxo").block_figures()[2]
    assert lay.blocks[0][3] == (sf, sg) and sf < 1e-7
    with pytest.raises(ConfigError, match="clock is the state of a sensor"):
        state_layout(load_system({"filter": {"states": ["clock"]}}))
    with pytest.raises(ConfigError, match="curve_fit extrapolates"):
        load_system({"sensors": {"gnss_raw": {"timing": {
            "latency_s": 0.2, "delay_compensation": "curve_fit"}}}})


# ------------------------------------------------------------------ the navigator
DESIGN = """
name: tight-test
start: {lat_deg: 47.40, lon_deg: 8.55, h_m: 500.0, speed_mps: 15.0, heading_deg: 60.0}
imu_period_s: 0.02
segments:
  - {name: street, duration_s: 100}
  - {name: turn, duration_s: 10, heading_rate_deg_s: 9.0}
  - {name: street, duration_s: 190}
imu:
  random_bias: true
  gyro_bias_deg_h: 50.0
  gyro_markov_deg_h: 5.0
  gyro_markov_tau_s: 300.0
  gyro_arw_deg_sqrt_h: 0.3
  accel_bias_ug: 1000.0
  accel_markov_ug: 50.0
  accel_markov_tau_s: 300.0
  accel_vrw_ug_sqrt_hz: 100.0
sensors:
  gnss: {sigma_pos_enu_m: [2.0, 2.0, 4.0], sigma_vel_mps: 0.1, period_s: 1.0,
         outages_s: [[150.0, 300.0]]}
  gnss_raw: {period_s: 1.0, satellites_s: [[150.0, 300.0, 2]]}
filter: {type: kf, period_s: 1.0, fdi_alpha: 0.001}
initial_errors: {attitude_arcsec: [300.0, 300.0, 1800.0], velocity_mps: 0.1, position_m: 3.0}
modes:
  - {name: loose, aiding: [gnss]}
  - {name: tight, aiding: [gnss_raw]}
"""


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    from fednav.sim.runs import make_run_data, run_mode
    from fednav.sim.scenario import load_scenario

    path = tmp_path_factory.mktemp("tight") / "design.yaml"
    path.write_text(DESIGN)
    scn = load_scenario(path)
    data = make_run_data(scn, 4)
    out = {m: run_mode(scn, [m], data, m) for m in ("gnss", "gnss_raw")}
    return scn, data, out


def test_a_particle_filter_flies_the_fixes_and_the_satellites(tmp_path):
    """``filter.type: pf`` flies loose and raw GNSS.  Before, every particle filter of a
    system degenerated at its first fixes (one effective particle of 1000 with raw GNSS,
    17.8 with loose): a system could not set its progressive correction, now on by
    default (``filter.pf``).  Its draws follow the run's seed."""
    import dataclasses

    from fednav.filters.base import FilterError
    from fednav.sim.runs import make_run_data, run_mode
    from fednav.sim.scenario import load_scenario

    path = tmp_path / "design.yaml"
    path.write_text(DESIGN.replace("filter: {type: kf,", "filter: {type: pf,"))
    scn = load_scenario(path)
    data = make_run_data(scn, 4)
    for m in ("gnss", "gnss_raw"):
        res = run_mode(scn, [m], data, m)
        # (the Kalman filter's: 0.8 m and 1.0 m; the particle filter's 1.0 m and 1.3 m)
        assert _horizontal(res, 10.0, 150.0) < 2.0, m
        window = _horizontal(res, 150.0, 300.0)  # the outage / two satellites
        assert np.isfinite(window) and window < 1000.0, m
        assert np.isfinite(res.sigma).all()
    again = run_mode(scn, ["gnss"], data, "gnss")
    other = run_mode(scn, ["gnss"], dataclasses.replace(data, seed=5), "gnss")
    assert np.array_equal(again.pos, run_mode(scn, ["gnss"], data, "gnss").pos)
    assert not np.array_equal(again.pos, other.pos)
    path.write_text(DESIGN.replace("filter: {type: kf,", "filter: {type: pf, pf: "
                                   "{progressive_correction: false},"))
    with pytest.raises(FilterError, match="effective sample"):
        run_mode(load_scenario(path), ["gnss_raw"], data, "gnss_raw")


def _horizontal(res, a, b):
    k = (res.t >= a) & (res.t < b)
    return float(np.sqrt(np.mean(np.sum(res.pos[k, :2] ** 2, axis=1))))


def test_two_satellites_beat_none_and_the_full_sky_agrees(flown):
    scn, data, out = flown
    loose, tight = out["gnss"], out["gnss_raw"]
    # 150-300 s: the loose filter has no fix, the tight one two satellites
    n = np.isfinite(data.series["gnss_raw"].z.reshape(-1, SLOTS, len(FIELDS))[:, :, 0]).sum(1)
    t = data.series["gnss_raw"].t
    assert (n[(t >= 150) & (t < 300)] == 2).all() and n[t < 150].min() >= 5
    assert _horizontal(tight, 150, 300) < 0.75 * _horizontal(loose, 150, 300)
    # before the outage both see the whole sky: the same answer within their sigma
    k = (tight.t > 30) & (tight.t < 150)
    d = np.abs(tight.pos[k] - loose.pos[k])
    assert (d < 3 * np.hypot(tight.sigma[k, 6:9], loose.sigma[k, 6:9])).mean() > 0.95
    # consistent: the rows' NIS per degree of freedom in its band
    f = tight.fdi[tight.fdi.local == "gnss_raw"]
    assert 0.7 < f.statistic.sum() / f.dof.sum() < 1.4


@pytest.mark.parametrize("aiding", [["gnss_raw"], ["gnss_raw", "gnss"]],
                         ids=["alone", "federated"])
def test_a_faulty_satellite_is_excluded_not_the_receiver(flown, aiding):
    """A 60 m step on one satellite for a minute: that satellite is left out of its
    epochs (alone, and as one local filter of a federation with the receiver's fixes),
    the others used, no epoch isolated, the position as good as without the fault."""
    from dataclasses import replace

    from fednav.sim.runs import run_mode

    scn, data, out = flown
    s = data.series["gnss_raw"]
    z = s.z.reshape(len(s.t), SLOTS, len(FIELDS)).copy()
    bad = int(z[0, 2, PRN])
    hit = (s.t >= 60) & (s.t < 120) & (z[:, :, PRN] == bad).any(axis=1)
    for i in np.flatnonzero(hit):
        j = int(np.flatnonzero(z[i, :, PRN] == bad)[0])
        z[i, j, PR] += 60.0  # a 60 m step on one satellite (20 sigma)
    series = dict(data.series, gnss_raw=replace(s, z=z.reshape(len(s.t), -1)))
    res = run_mode(scn, aiding, replace(data, series=series), "fault", innovations=True)
    assert 0.5 < res.nis["gnss_raw"] < 1.5  # (recorded with the rows kept)
    excluded = [e for e in res.excluded if e[1] == "gnss_raw"]
    assert {e[2] for e in excluded} == {bad}
    assert len(excluded) >= 0.9 * hit.sum()
    clean = out["gnss_raw"] if len(aiding) == 1 else run_mode(scn, aiding, data, "clean")
    k = (res.t >= 60) & (res.t < 120)
    assert _horizontal(res, 60, 120) < 1.5 * _horizontal(clean, 60, 120) + 0.5
    assert np.isfinite(res.pos[k]).all() and not res.fdi.isolated.any()


# ------------------------------------------------------------- a receiver's files
def test_observations_give_rows_that_vanish_at_the_receiver():
    """Light-time pseudoranges and their Dopplers of a synthetic broadcast constellation
    (tests/test_satellites.py's): the rows at the true position, the true clock in the
    totals, are zero to a centimetre and 3 mm/s (3 % of a Doppler's 1-sigma)."""
    from test_satellites import _constellation, _pseudoranges

    from fednav.sensors.gnss_raw import from_observations
    from fednav.sensors.satellites import F_L1, C

    t = 2.0e9 + np.arange(0.0, 300.0, 30.0)
    eph = _constellation(float(t[0]))
    lla = np.array([np.radians(35.0), np.radians(139.0), 50.0])
    rx = earth.llh_to_ecef(*lla)
    pr = _pseudoranges(eph, rx, t, 1234.5)
    dop = -(_pseudoranges(eph, rx, t + 0.5, 1234.5)
            - _pseudoranges(eph, rx, t - 0.5, 1234.5)) / (C / F_L1)
    tt, z, used = from_observations(t, pr, dop, eph.sv, eph, iono=False, tropo=False,
                                    mask_deg=0.0)
    assert len(tt) == len(t) and (used == np.isfinite(pr).sum(axis=1)).all()
    lay = _layout()
    xa = np.zeros(lay.n)
    xa[lay.start("clock")] = 1234.5
    nav = NavSnapshot(lla, np.zeros(3), np.eye(3))
    for zi, n in zip(z, used, strict=True):
        y = SatelliteRanges(mask=0.0).bind(zi, nav, lay, xa).residual(nav)
        assert len(y) == 2 * n
        assert np.abs(y[:n]).max() < 0.01 and np.abs(y[n:]).max() < 3e-3


STATIC = Path(__file__).resolve().parents[2] / "shared" / "data" / "rinex-static"


@pytest.mark.skipif(not STATIC.is_dir(), reason="needs ../shared/data")
@pytest.mark.parametrize("station", ["0759", "3040"])
def test_real_pseudoranges_at_the_station(station):
    """A real receiver's files (GSI station, 1 h at 30 s): at the station's surveyed
    position, with each epoch's clock taken out (the median), the corrected pseudoranges
    agree to about a metre (0.85 and 1.06 m RMS)."""
    from fednav.io.rinex import read_raw_gnss, read_rinex_obs

    obs = read_rinex_obs(STATIC / f"{station}0920.05o")
    s = read_raw_gnss(STATIC / f"{station}0920.05o", STATIC / f"{station}0920.05n")
    assert s.name == "gnss_raw" and len(s.t) == 120
    assert s.quality["gnss_raw_satellites_mean"] > 5 and not s.quality["gnss_raw_doppler"]
    nav = NavSnapshot(earth.ecef_to_llh(obs.approx_xyz), np.zeros(3), np.eye(3))
    lay = _layout()
    res = []
    for z in s.z:
        b = SatelliteRanges().bind(z, nav, lay, np.zeros(lay.n))
        y = b.residual(nav)
        assert len(y) == len(b.sat)  # (no Doppler in these files: pseudoranges only)
        res.append(y - np.median(y))
    rms = float(np.sqrt(np.mean(np.concatenate(res) ** 2)))
    assert 0.3 < rms < 1.5


def test_the_contested_sky_example_flies_two_satellites():
    """examples/contested-sky.yaml: loose against tight through the jamming, then star and
    SAR beside the tight GNSS (its tables: docs/data-formats.md)."""
    from fednav.sim.scenario import load_scenario

    path = Path(__file__).resolve().parents[1] / "examples" / "contested-sky.yaml"
    scn = load_scenario(path)
    raw = scn.sensors["gnss_raw"]
    assert raw.satellites_s == [(600.0, 1200.0, 2)]
    assert scn.sensors["gnss"].outages_s == [(600.0, 1200.0)]
    assert {a for m in scn.modes for a in m.aiding} == {"gnss", "gnss_raw", "star", "sar"}


def test_rinex_written_by_fednav_reads_back(tmp_path):
    """fednav's RINEX 2.11 writer and georinex's reader: the same epochs (GPS time, a
    week rollover's week 2048 included), satellites and values to the format's
    millimetre; an existing file is never overwritten."""
    pytest.importorskip("georinex")
    from fednav.io.data import DataError
    from fednav.io.rinex import WEEK_S, read_rinex_obs, write_rinex_obs

    rng = np.random.default_rng(3)
    t = 2048 * WEEK_S - 60.0 + np.arange(0.0, 120.0, 30.0)  # across the 2019 rollover
    sv = np.array([f"G{i:02d}" for i in (2, 5, 13, 24, 31)])
    pr = 2.1e7 + rng.uniform(0.0, 4e6, (len(t), len(sv)))
    pr[1, 2] = np.nan
    dop = np.where(np.isfinite(pr), rng.normal(0.0, 2000.0, pr.shape), np.nan)
    path = write_rinex_obs(tmp_path / "x.19o", t, sv, {"C1": pr, "D1": dop},
                           approx_xyz=[-3976219.5, 3382372.6, 3652513.0])
    o = read_rinex_obs(path)
    np.testing.assert_array_equal(o.t, t)
    assert list(o.sv) == list(sv)
    np.testing.assert_allclose(o.obs["C1"], pr, atol=6e-4)
    np.testing.assert_allclose(o.obs["D1"], dop, atol=6e-4)
    assert np.isnan(o.obs["C1"][1, 2])
    np.testing.assert_allclose(o.approx_xyz, [-3976219.5, 3382372.6, 3652513.0])
    with pytest.raises(DataError, match="does not overwrite"):
        write_rinex_obs(path, t, sv, {"C1": pr})


def test_rinex_navigation_written_by_fednav_reads_back(tmp_path):
    """fednav's RINEX 2.11 navigation writer and georinex's reader: the Walker sky's
    ephemerides (and, where ../shared has them, a real station's, with its Klobuchar
    coefficients) give the same satellite positions and clocks to 0.1 mm / 1e-15 s."""
    pytest.importorskip("georinex")
    from fednav.io.data import DataError
    from fednav.io.rinex import read_rinex_nav, write_rinex_nav
    from fednav.sensors.gnss_raw import START_GPS_S, walker_ephemerides
    from fednav.sensors.satellites import nearest_ephemeris, satellite_states

    skies = [(walker_ephemerides(START_GPS_S, START_GPS_S + 10000.0), START_GPS_S)]
    if STATIC.is_dir():
        real = read_rinex_nav(STATIC / "07590920.05n")
        skies.append((real, float(np.median(real.toe))))
    for k, (eph, t0) in enumerate(skies):
        back = read_rinex_nav(write_rinex_nav(tmp_path / f"{k}.nav", eph))
        assert len(back.sv) == len(eph.sv)
        assert (back.iono is None) == (eph.iono is None)
        if eph.iono is not None:
            np.testing.assert_allclose(back.iono, eph.iono, rtol=1e-4)
        sv = np.unique(eph.sv)
        t = t0 + np.arange(-3000.0, 3000.0, 600.0)
        T = np.broadcast_to(t[:, None], (len(t), len(sv)))
        a = satellite_states(eph, nearest_ephemeris(eph, sv, t), T)
        b = satellite_states(back, nearest_ephemeris(back, sv, t), T)
        ok = np.isfinite(a[0][..., 0])
        assert ok.sum() > 10 and np.array_equal(ok, np.isfinite(b[0][..., 0]))
        assert np.abs(a[0][ok] - b[0][ok]).max() < 1e-4
        assert np.abs(a[2][ok] - b[2][ok]).max() < 1e-15
    with pytest.raises(DataError, match="does not overwrite"):
        write_rinex_nav(tmp_path / "0.nav", skies[0][0])


def test_a_simulated_receiver_as_rinex_reads_back_to_its_measurements(tmp_path, flown):
    """fednav simulate's RINEX of a raw receiver (the satellite clock, troposphere and
    ionosphere put back into C1, the Doppler in Hz) read by the RINEX route (transit
    time from the pseudorange, the corrections at the single-point position) gives the
    simulated rows: the same satellites, positions within 0.3 m, pseudoranges 5 cm,
    range rates 1 mm/s, times back on the simulation's clock (time_offset_s)."""
    pytest.importorskip("georinex")
    from fednav.io.data import SensorData
    from fednav.io.rinex import read_raw_gnss_file, write_raw_receiver

    scn, data, _ = flown
    s = data.series["gnss_raw"]
    section = scn.system_for(scn.modes[1]).sensors["gnss_raw"]
    files, name, keys = write_raw_receiver(tmp_path, s, scn.trajectory(), section)
    assert [f.name for f in files] == ["gnss_raw.obs", "gnss_raw.nav"] and name == files[0].name
    got = read_raw_gnss_file(tmp_path / name)
    got = SensorData.adjusted(got, section.model_copy(update=keys))
    np.testing.assert_allclose(got.t, s.t, atol=1e-6)
    a = s.z.reshape(len(s.t), SLOTS, len(FIELDS))
    b = got.z.reshape(len(got.t), SLOTS, len(FIELDS))
    for i in range(len(s.t)):
        ka = {int(p): j for j, p in enumerate(a[i, :, PRN]) if np.isfinite(p)}
        kb = {int(p): j for j, p in enumerate(b[i, :, PRN]) if np.isfinite(p)}
        assert ka.keys() == kb.keys()
        for prn, j in ka.items():
            u, v = a[i, j], b[i, kb[prn]]
            assert np.abs(u[1:4] - v[1:4]).max() < 0.3
            assert abs(u[PR] - v[PR]) < 0.05 and abs(u[RR] - v[RR]) < 1e-3


def _sky_design(tmp_path, lla_deg, raw: str, last_s: float = 190.0) -> Path:
    """DESIGN's drive at ``lla_deg`` (slow; its last street ``last_s`` long), its raw
    receiver's section ``raw``."""
    text = DESIGN.replace("{name: street, duration_s: 190}",
                          f"{{name: street, duration_s: {last_s}}}")
    text = text.replace("lat_deg: 47.40, lon_deg: 8.55, h_m: 500.0, speed_mps: 15.0",
                        f"lat_deg: {lla_deg[0]}, lon_deg: {lla_deg[1]}, h_m: "
                        f"{lla_deg[2]}, speed_mps: 1.0")
    text = text.replace("gnss_raw: {period_s: 1.0, satellites_s: [[150.0, 300.0, 2]]}",
                        f"gnss_raw: {raw}")
    path = tmp_path / "design.yaml"
    path.write_text(text)
    return path


def test_a_navigation_file_of_the_walker_sky_flies_the_walker_sky(tmp_path):
    """navigation_file (relative to the design): the Walker sky written as a RINEX
    navigation file and flown from it gives the Walker sky's rows (to the file's 12
    digits); a missing file is one line when the simulation reads it."""
    pytest.importorskip("georinex")
    from fednav.io.rinex import write_rinex_nav
    from fednav.sensors.gnss_raw import START_GPS_S, walker_ephemerides
    from fednav.sim.runs import make_run_data
    from fednav.sim.scenario import load_scenario

    write_rinex_nav(tmp_path / "walker.26n", walker_ephemerides(START_GPS_S,
                                                                START_GPS_S + 400.0))
    runs = {}
    for name, raw in (("walker", "{period_s: 1.0}"),
                      ("file", "{period_s: 1.0, navigation_file: walker.26n}")):
        (tmp_path / name).mkdir()
        scn = load_scenario(_sky_design(tmp_path / name, (47.4, 8.55, 500.0), raw)
                            if name == "walker" else
                            _sky_design(tmp_path, (47.4, 8.55, 500.0), raw))
        runs[name] = make_run_data(scn, 2, 200.0).series["gnss_raw"]
    a, b = runs["walker"], runs["file"]
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(np.isnan(a.z), np.isnan(b.z))
    np.testing.assert_allclose(a.z, b.z, rtol=0, atol=2e-4, equal_nan=True)
    from fednav.io.data import DataError

    scn = load_scenario(_sky_design(tmp_path, (47.4, 8.55, 500.0),
                                    "{period_s: 1.0, navigation_file: missing.26n}"))
    with pytest.raises(DataError, match=r"missing.26n: no such file") as e:
        make_run_data(scn, 2, 20.0)
    assert "\n" not in str(e.value) and str(tmp_path / "missing.26n") in str(e.value)


@pytest.mark.skipif(not STATIC.is_dir(), reason="needs ../shared/data")
def test_a_sky_from_a_real_navigation_file_is_the_real_sky(tmp_path):
    """A receiver simulated at station 0759 from its own broadcast navigation file sees
    the satellites the station saw: above 10 deg, epoch by epoch over its hour, the same
    ones but for those crossing the mask (at most one), and where they are the same the
    same PDOP (the real sky's geometry)."""
    from fednav.io.rinex import read_raw_gnss, read_rinex_obs
    from fednav.sensors.gnss_raw import geometry
    from fednav.sim.runs import make_run_data
    from fednav.sim.scenario import load_scenario

    obs = read_rinex_obs(STATIC / "07590920.05o")
    lla = earth.ecef_to_llh(obs.approx_xyz)
    nav = STATIC / "07590920.05n"
    start = float(obs.t[0])
    scn = load_scenario(_sky_design(tmp_path, (float(np.degrees(lla[0])),
                                               float(np.degrees(lla[1])), float(lla[2])),
                                    f"{{period_s: 30.0, navigation_file: {nav}, "
                                    f"start_gps_s: {start}}}", 3370.0))
    s = make_run_data(scn, 1).series["gnss_raw"]
    assert len(s.t) >= 110
    real = read_raw_gnss(STATIC / "07590920.05o", nav)
    k = np.searchsorted(real.t, s.t + start)
    assert np.allclose(real.t[k], s.t + start)
    here = np.tile(lla, (len(s.t), 1))
    _, pdop_sim, _, _ = geometry(s.z, here)
    _, pdop_real, _, _ = geometry(real.z[k], here)

    def prns(z):
        z = z.reshape(len(z), SLOTS, len(FIELDS))
        return [{int(p) for p in row[:, PRN] if np.isfinite(p)} for row in z]

    sim, seen = prns(s.z), prns(real.z[k])
    assert all(len(a ^ b) <= 1 for a, b in zip(sim, seen, strict=True))
    same = np.array([a == b for a, b in zip(sim, seen, strict=True)])
    assert same.mean() > 0.5
    np.testing.assert_allclose(pdop_sim[same], pdop_real[same], rtol=1e-4)


def test_bad_satellites_drop_out_and_the_file_round_trips(tmp_path, flown):
    """A satellite with a NaN velocity or a non-positive 1-sigma gives no row (never a
    NaN residual); the sensor's CSV file (NaN in its empty slots) reads back to the same
    measurements."""
    from fednav.io.sensorfile import read_sensor_csv, write_sensor_csv

    z, seen = _sky()
    s = z.reshape(SLOTS, -1).copy()
    s[0, 4] = np.nan       # velocity
    s[1, 9] = -1.0         # pseudorange 1-sigma
    s[2, 10] = 0.0         # range-rate 1-sigma: pseudorange row only
    b = SatelliteRanges().bind(s.ravel(), _nav(), _layout(), np.zeros(_layout().n))
    assert b.dim == 2 * (len(seen) - 2) - 1 and np.isfinite(b.residual(_nav())).all()
    assert not np.isnan(z.reshape(SLOTS, -1)[0, 4])  # (the caller's z untouched)
    series = flown[1].series["gnss_raw"]
    path = write_sensor_csv(tmp_path / "gnss_raw.csv", series, sigma=True)
    back = read_sensor_csv("gnss_raw", path)
    np.testing.assert_array_equal(back.t, series.t)
    np.testing.assert_array_equal(np.isnan(back.z), np.isnan(series.z))
    np.testing.assert_allclose(back.z, series.z, rtol=1e-15)


@pytest.mark.parametrize("ftype", ["aekf", "raukf"])
def test_adaptive_filters_keep_r_per_satellite(flown, ftype):
    """Sage–Husa R adapted per satellite and row kind: the satellites change (8 to 2 and
    back) without a shape error, and the tight run stays near the KF's."""
    from fednav.sim.runs import run_mode

    scn, data, out = flown
    res = run_mode(scn, ["gnss_raw"], data, ftype, filter_type=ftype)
    assert np.isfinite(res.pos).all()
    assert _horizontal(res, 30, 150) < 3 * _horizontal(out["gnss_raw"], 30, 150) + 1.0


def test_a_receivers_file_is_read_by_its_name(tmp_path):
    """fednav process --gnss_raw FILE: fednav's CSV, a RINEX observation file with its
    navigation file beside it (found by name; refused in one line naming those tried when
    none is), a u-blox log by its suffix."""
    from fednav.io.data import DataError
    from fednav.io.rinex import is_observation_file, navigation_beside, write_rinex_obs
    from fednav.io.sensorfile import read_sensor_file

    assert is_observation_file("0759.05o") and is_observation_file("X.OBS")
    assert is_observation_file("ABMF00GLP_R_20220010000_01D_30S_MO.rnx")
    assert not is_observation_file("0759.05n") and not is_observation_file("raw.csv")
    obs = write_rinex_obs(tmp_path / "site0920.05o", np.array([1.1e9]), ["G01"],
                          {"C1": np.array([[2.2e7]])})
    with pytest.raises(DataError, match=r"no navigation file beside it \(tried "
                                        r"site0920.05n, site0920.05N"):
        read_sensor_file("gnss_raw", obs)
    (tmp_path / "site0920.05N").write_text("")
    assert navigation_beside(obs).name == "site0920.05N"
    with pytest.raises(DataError, match="no RXM-RAWX"):
        (tmp_path / "raw.ubx").write_bytes(b"")
        read_sensor_file("gnss_raw", tmp_path / "raw.ubx")
    if STATIC.is_dir():
        s = read_sensor_file("gnss_raw", STATIC / "07590920.05o")
        assert s.name == "gnss_raw" and len(s.t) == 120
        assert s.t[0] == 1316 * 604800.0 + 518400.0  # (GPS week 1316, Saturday 00:00)


def test_a_millisecond_clock_jump_moves_the_clock_not_the_position(flown):
    """Receivers that keep their clock within a millisecond jump by 1 ms (300 km on every
    pseudorange at once): the clock's total takes it, the position does not."""
    from dataclasses import replace

    from fednav.navigator.system import sensor_model  # noqa: F401  (the model's counter)
    from fednav.sim.runs import run_mode

    scn, data, out = flown
    s = data.series["gnss_raw"]
    z = s.z.reshape(len(s.t), SLOTS, len(FIELDS)).copy()
    z[s.t >= 100.0, :, PR] += 299792.458  # (NaN slots stay NaN)
    series = dict(data.series, gnss_raw=replace(s, z=z.reshape(len(s.t), -1)))
    res = run_mode(scn, ["gnss_raw"], replace(data, series=series), "jump")
    clean = out["gnss_raw"]
    assert _horizontal(res, 100, 150) < 1.5 * _horizontal(clean, 100, 150) + 0.5
    k = (res.t >= 100) & (res.t < 150)
    assert np.abs(res.pos[k, 2]).max() < 3 * np.abs(clean.pos[k, 2]).max() + 1.0
    assert not res.fdi.isolated.any()


def test_fednav_process_flies_a_simulated_raw_receiver(tmp_path):
    """fednav simulate writes a design's raw GNSS as a receiver's RINEX observation and
    navigation files (named in system.yaml's files:, with the time offset back onto the
    IMU's clock); fednav process reads them back and reports the satellites, the DOP and
    the clock (summary.json, gnss_raw.png), its NIS in band."""
    import json

    from typer.testing import CliRunner

    from fednav.cli import app

    design = Path(__file__).resolve().parents[1] / "examples" / "contested-sky.yaml"
    out = tmp_path / "sim"
    r = CliRunner().invoke(app, ["simulate", str(design), "--mode", "INS/GNSS (tight)",
                                 "--max-time", "200", "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert (out / "gnss_raw.obs").is_file() and (out / "gnss_raw.nav").is_file()
    assert not (out / "gnss_raw.csv").exists()
    r = CliRunner().invoke(app, ["simulate", str(design), "--mode", "INS/GNSS (tight)",
                                 "--max-time", "200", "--out", str(out)])
    assert r.exit_code == 0, r.output  # (again into its own folder: its files replaced)
    r = CliRunner().invoke(app, ["process", "csv", "--config", str(out / "system.yaml"),
                                 "--out", str(out / "processed")])
    assert r.exit_code == 0, r.output
    s = json.loads((out / "processed" / "summary.json").read_text())
    geo = s["data_quality"]["gnss_raw_geometry"]
    assert geo["epochs"] >= 199 and 6 <= geo["satellites_mean"] <= 12
    assert geo["epochs_below_four"] == 0 and 1.0 < geo["pdop_median"] < 4.0
    assert geo["clock_resets"] == 1  # (the first epoch's bias, 10 km in the simulation)
    assert 0.7 < s["consistency"]["gnss_raw"]["nis_per_dof"] < 1.4
    assert s["error_states"]["clock_m_mps"]["estimate"][1] != 0.0
    assert (out / "processed" / "gnss_raw.png").stat().st_size > 10_000
    # without initial: the run starts from the receiver's own single-point solutions
    import yaml

    desc = yaml.safe_load((out / "system.yaml").read_text())
    desc.pop("initial")
    (out / "no-initial.yaml").write_text(yaml.safe_dump(desc))
    r = CliRunner().invoke(app, ["process", "csv", "--config", str(out / "no-initial.yaml"),
                                 "--out", str(out / "from-spp")])
    assert r.exit_code == 0, r.output
    s2 = json.loads((out / "from-spp" / "summary.json").read_text())
    assert s2["alignment"]["heading"].startswith("GNSS course")
    r1, r2 = s["rmse"], s2["rmse"]
    assert r2["east_m"] < 2 * r1["east_m"] + 1.0 and r2["north_m"] < 2 * r1["north_m"] + 1.0


def test_single_point_fixes_from_the_receivers_own_rows(flown):
    """The single-point solutions a recording without fixes or initial: starts from: every
    epoch with four satellites (none in the two-satellite window), scattered about the
    truth by their stated 1-sigma (position 3.0/3.6/6.4 m RMS against 3.2/3.6/6.8 m,
    velocity 0.12/0.12/0.22 m/s against 0.11/0.12/0.23)."""
    from fednav.sensors.gnss_raw import single_point_fixes

    scn, data, _ = flown
    s = data.series["gnss_raw"]
    section = scn.system_for(scn.modes[1]).sensors["gnss_raw"]
    t, lla, vel, s_pos, s_vel = single_point_fixes(s, section)
    n = np.isfinite(s.z.reshape(len(s.t), SLOTS, len(FIELDS))[:, :, PRN]).sum(axis=1)
    np.testing.assert_array_equal(t, s.t[n >= 4])
    tr = scn.trajectory().at(t)
    e = np.asarray(earth.llh_difference_enu(*lla.T, *tr["lla"].T))
    e = e if e.shape[-1] == 3 else e.T
    # (their 1-sigma what they scatter by: the rows' 1-sigma through the DOP)
    np.testing.assert_allclose(np.sqrt(np.mean(e**2, axis=0)), s_pos, rtol=0.3)
    np.testing.assert_allclose(np.sqrt(np.mean((vel - tr["vel"]) ** 2, axis=0)), s_vel,
                               rtol=0.3)
    assert 1.0 < s_pos[0] < 6.0 and s_pos[2] > s_pos[0] and 0.02 < s_vel[0] < 0.5


def test_without_doppler_the_start_takes_the_positions_alone(flown):
    """A receiver file without Doppler (range rates NaN): single-point positions, no
    velocity (the start then takes it from their differences)."""
    from dataclasses import replace

    from fednav.sensors.gnss_raw import single_point_fixes

    scn, data, _ = flown
    s = data.series["gnss_raw"]
    z = s.z.reshape(len(s.t), SLOTS, len(FIELDS)).copy()
    z[:, :, RR] = np.nan
    t, lla, vel, s_pos, s_vel = single_point_fixes(
        replace(s, z=z.reshape(len(s.t), -1)), scn.system_for(scn.modes[1]).sensors["gnss_raw"])
    n = np.isfinite(z[:, :, PRN]).sum(axis=1)
    np.testing.assert_array_equal(t, s.t[n >= 4])
    assert vel is None and np.isnan(s_vel).all() and 1.0 < s_pos[0] < 6.0


def test_outages_are_on_the_imus_clock_for_a_file_in_gps_time(flown):
    """outages_s of a raw receiver whose file is in GPS time (time_offset_s): the
    measurements inside the window on the IMU's clock are withheld, not those of GPS
    time 10-30 s."""
    from fednav.io.data import SensorData
    from fednav.process.run import withheld_inputs

    scn, data, _ = flown
    s = data.series["gnss_raw"]
    system = scn.system_for(scn.modes[1])
    off = -1.0e9
    gps = SensorData("gnss_raw", "rover.obs", s.t - off, s.z)
    cfg = system.model_copy(update={"sensors": system.sensors.replace(
        gnss_raw=system.sensors["gnss_raw"].model_copy(
            update={"time_offset_s": off, "outages_s": [(10.0, 30.0)]}))})
    got = withheld_inputs(cfg, {"gnss_raw": gps})["gnss_raw"]
    kept = got.adjusted(cfg.sensors["gnss_raw"]).t
    assert not np.any((kept >= 10.0) & (kept < 30.0))
    assert len(s.t) - len(kept) == np.sum((s.t >= 10.0) & (s.t < 30.0)) > 0


def test_a_start_from_fewer_than_four_satellites_is_one_line(flown):
    """No epoch with four satellites and no initial: a one-line DataError saying so."""
    from types import SimpleNamespace

    from fednav.io.data import DataError
    from fednav.process.run import _start_fixes

    scn, data, _ = flown
    s = data.series["gnss_raw"]
    z = s.z.reshape(len(s.t), SLOTS, len(FIELDS)).copy()
    z[:, 3:] = np.nan  # (three satellites at most)
    few = SimpleNamespace(t=s.t, z=z.reshape(len(s.t), -1), source="rover.obs")
    with pytest.raises(DataError, match="rover.obs: no epoch with four satellites") as e:
        _start_fixes("gnss_raw", few, scn.system_for(scn.modes[1]))
    assert "\n" not in str(e.value) and "initial:" in str(e.value)


def test_the_figure_shows_satellites_dop_and_exclusions(flown):
    """gnss_raw.png: the satellites above the mask per epoch (those fault detection
    excluded marked, with their ids), the epochs below four shaded, PDOP and HDOP."""
    from types import SimpleNamespace

    from fednav.sensors.gnss_raw import figure, geometry

    scn, data, _ = flown
    s = data.series["gnss_raw"]
    tr = scn.trajectory().at(s.t)
    sol = SimpleNamespace(t=s.t, lla=tr["lla"])
    fig = figure(s, sol, [(50.0, "gnss_raw", 7, 99.0), (80.0, "gnss_raw", 3, 50.0)])
    a, b = fig.axes
    n, pdop, hdop, _ = geometry(s.z, tr["lla"])
    line = a.get_lines()[0]
    np.testing.assert_array_equal(line.get_ydata(), n)
    marks = [ln for ln in a.get_lines() if ln.get_marker() == "x"]
    assert len(marks) == 1 and list(marks[0].get_xdata()) == [50.0, 80.0]
    assert [t.get_text() for t in a.texts] == ["7", "3"]
    assert len(a.patches) == 1  # (the two-satellite window shaded)
    assert a.patches[0].get_x() == pytest.approx(150.0, abs=1.0)
    np.testing.assert_array_equal(b.get_lines()[0].get_ydata(), pdop)
    np.testing.assert_array_equal(b.get_lines()[1].get_ydata(), hdop)
    assert np.isnan(pdop[(s.t > 151) & (s.t < 299)]).all()


def test_the_clock_tests_median_is_numpys():
    from fednav.sensors.gnss_raw import _median

    rng = np.random.default_rng(3)
    for n in range(1, 30):
        v = rng.normal(size=n) * 1e3
        assert _median(v) == float(np.median(v))
    assert np.isnan(_median(np.array([1.0, np.nan, 2.0])))


def _faulty(data, step_m=60.0):
    """``data`` with a ``step_m`` step on one satellite's pseudoranges from 60 to 120 s, a
    millisecond clock jump at 200 s, and three epochs (41-43 s) whose one satellite is
    below the horizon (no row: nothing updated or logged)."""
    from dataclasses import replace

    s = data.series["gnss_raw"]
    z = s.z.reshape(len(s.t), SLOTS, len(FIELDS)).copy()
    bad = int(z[0, 2, PRN])
    hit = ((s.t >= 60) & (s.t < 120))[:, None] & (z[:, :, PRN] == bad)
    z[:, :, PR] += np.where(hit, step_m, 0.0)
    z[s.t >= 200.0, :, PR] += 299792.458  # (and a millisecond clock jump)
    z[40:43, 1:] = np.nan
    z[40:43, 0, 1:4] *= -1.0
    return replace(data, series=dict(data.series, gnss_raw=replace(s, z=z.reshape(
        len(s.t), -1))))


def _fly(scn, aiding, data, engine_name):
    """(navigator, result) of ``aiding`` flown on ``data`` by engine ``engine_name``, the
    innovations recorded (what :func:`fednav.sim.runs.run_mode` flies)."""
    from fednav.navigator.navigator import Navigator
    from fednav.sim import runs
    from fednav.sim.scenario import ModeConfig

    truth = scn.trajectory(None)
    nav = Navigator(scn.system_for(ModeConfig(name="m", aiding=aiding)),
                    runs._initial_state(scn, truth, data), truth.dt, record_rows=False,
                    record_covariance=False, innovations=True, engine=engine_name)
    for a in runs.feed_order(aiding, nav.system):
        nav.add_series(data.series[a])
    m = len(truth.t) - 1
    nav.add_imu(truth.t[:-1], dtheta=data.dtheta[:m], dv=data.dv[:m])
    return nav, nav.result()


@pytest.mark.parametrize("case", ["kf", "ukf", "sukf", "square_root", "interpolate",
                                  "federated", "guarded", "adapted"])
def test_both_engines_fly_the_satellites_alike(flown, tmp_path, case):
    """The compiled engine flies raw GNSS with the Python loop's operations, bit for bit:
    the satellites' rows and the receiver clock's jump test
    (:mod:`fednav.sensors.satellite_rows`, one source), a faulty satellite left out
    (:func:`fednav.filters.policy.leave_one_out`), two satellites, Kalman, unscented (its
    default alpha) and square-root local filters, a measurement used at its time of
    validity, a federation with the receiver's fixes, a receiver the lockout guard
    re-admits (``guarded``), the process noise adapted (``adapted``); the log,
    the exclusions, the innovations (rows, H, R), the clock's jumps and the re-admissions
    alike."""
    from dataclasses import replace

    from fednav.navigator import engine
    from fednav.navigator.system import QAdaptationConfig
    from fednav.sensors.registry import SENSORS
    from fednav.sim.runs import make_run_data
    from fednav.sim.scenario import ModeConfig, load_scenario

    scn, data, _ = flown
    aiding = ["gnss_raw", "gnss"] if case == "federated" else ["gnss_raw"]
    more = {"interpolate": "timing: {latency_s: 0.3, delay_compensation: "
                           "interpolate},"}.get(case)
    if more:
        path = tmp_path / "design.yaml"
        path.write_text(DESIGN.replace("gnss_raw: {period_s: 1.0,",
                                       "gnss_raw: {period_s: 1.0, " + more))
        scn = load_scenario(path)
        data = make_run_data(scn, 4)
    filt = {"ukf": {"type": "ukf"}, "sukf": {"type": "sukf", "alpha": 0.5},
            "square_root": {"form": "square_root"},
            "adapted": {"q_adaptation": QAdaptationConfig(time_constant_s=5.0)}}.get(case,
                                                                                   {})
    scn = scn.model_copy(update={"filter": scn.filter.model_copy(update=filt)})
    data = _faulty(data)
    if case == "guarded":  # no satellite above the horizon for 100 s, a filter far too sure
        # of its IMU: its epochs fail their test, and the lockout guard re-admits them
        s = data.series["gnss_raw"]
        z = s.z.reshape(len(s.t), SLOTS, len(FIELDS)).copy()
        gap = (s.t >= 150.0) & (s.t < 250.0)
        z[gap, 1:] = np.nan
        z[gap, 0, 1:4] *= -1.0
        # (and a filter far too sure of its IMU: the drift it finds after the gap fails
        # the test — the rover's case, tests/test_readmission.py)
        scn = scn.model_copy(update={"imu": scn.imu.model_copy(update={
            k: getattr(scn.imu, k) / 30.0 for k in (
                "gyro_bias_deg_h", "gyro_markov_deg_h", "gyro_arw_deg_sqrt_h",
                "accel_bias_ug", "accel_markov_ug", "accel_vrw_ug_sqrt_hz")})})
        data = replace(data, series=dict(data.series, gnss_raw=replace(
            s, z=z.reshape(len(s.t), -1))))
    assert engine.why_not_compiled(scn.system_for(ModeConfig(name="m", aiding=aiding)),
                                   aiding, SENSORS) is None
    (na, a), (nb, b) = (_fly(scn, aiding, data, e) for e in ("compiled", "python"))
    assert (na.engine, nb.engine) == ("compiled", "python")
    np.testing.assert_array_equal(a.states, b.states)
    np.testing.assert_array_equal(a.P, b.P)
    assert a.fdi == b.fdi and len(a.fdi) > 150
    assert a.excluded == b.excluded and len(a.excluded) > 30
    assert len(a.innovations) == len(b.innovations)
    for x, y in zip(a.innovations, b.innovations, strict=True):
        assert (x.local, x.t, x.accepted, x.epoch) == (y.local, y.t, y.accepted, y.epoch)
        for k in ("r", "S", "R", "H"):
            np.testing.assert_array_equal(getattr(x, k), getattr(y, k), err_msg=k)
    model = [m.model for m in na.loop.meas if m.name == "gnss_raw"][0]
    assert model.clock_resets == [m.model for m in nb.loop.meas
                                  if m.name == "gnss_raw"][0].clock_resets >= 2
    assert na.loop.fed.readmissions == nb.loop.fed.readmissions
    if case == "guarded":
        assert sum(e[5] for e in a.fdi) > 10  # (isolated, then re-admitted)
        assert len(na.loop.fed.readmissions) >= 1
    if case == "adapted":
        assert max(na.loop.q_scales().values()) > 1.0
        assert na.loop.q_scales() == nb.loop.q_scales()
    t = np.array([e[0] for e in a.fdi if e[1] == "gnss_raw"])
    assert not np.isin(data.series["gnss_raw"].t[40:43], t).any()


def test_the_compiled_satellites_fed_in_blocks_are_the_batch(flown):
    """The stream: the IMU in blocks of 137 samples (the engine's runs then end anywhere,
    epochs with no satellite above the horizon among them) gives the batch's solution,
    log and exclusions, bit for bit."""
    from fednav.navigator.navigator import Navigator
    from fednav.sim import runs
    from fednav.sim.scenario import ModeConfig

    scn, data, _ = flown
    data = _faulty(data)
    system = scn.system_for(ModeConfig(name="tight", aiding=["gnss_raw"]))
    truth = scn.trajectory(None)
    s = data.series["gnss_raw"]
    out = []
    for block in (None, 137):
        nav = Navigator(system, runs._initial_state(scn, truth, data), truth.dt,
                        record_rows=False, record_covariance=False)
        assert nav.engine == "compiled"
        nav.add_series(s)
        m = len(truth.t) - 1
        step = block or m
        for a in range(0, m, step):
            b = min(a + step, m)
            nav.add_imu(truth.t[a:b], dtheta=data.dtheta[a:b], dv=data.dv[a:b])
        out.append(nav.result())
    a, b = out
    np.testing.assert_array_equal(a.states, b.states)
    assert a.fdi == b.fdi and a.excluded == b.excluded and len(a.excluded) > 30
    t = np.array([e[0] for e in a.fdi])
    assert not np.isin(s.t[40:43], t).any() and len(t) > 250  # (no row: nothing logged)

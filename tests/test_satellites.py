"""Raw GPS (issue 41, items 1 and 2): RINEX observations and broadcast ephemerides read
through georinex, satellite states from the ephemerides, the ionosphere and troposphere,
and single-point positioning — on two real static stations against their surveyed
positions, and on pseudoranges made here by solving the light-time equation apart."""

from pathlib import Path

import numpy as np
import pytest

from fednav.core import earth
from fednav.io.data import DataError
from fednav.io.rinex import Ephemerides, read_rinex_nav, read_rinex_obs
from fednav.sensors.satellites import (
    OMEGA_E,
    C,
    iono_free,
    saastamoinen,
    satellite_states,
    single_point,
)

STATIC = Path(__file__).resolve().parents[2] / "shared" / "data" / "rinex-static"
needs_data = pytest.mark.skipif(not STATIC.is_dir(), reason="needs ../shared/data")


def _constellation(toe: float) -> Ephemerides:
    """24 satellites on 6 circular planes at 55 deg (no perturbation terms), clocks
    offset by a few hundred microseconds with a drift."""
    n = 24
    plane, slot = np.divmod(np.arange(n), 4)
    z = np.zeros(n)
    el = {"sqrt_a": np.full(n, np.sqrt(26_560e3)), "e": z.copy(), "i0": np.full(n, 0.96),
          "omega0": plane * np.pi / 3, "omega": z.copy(), "m0": slot * np.pi / 2 + plane * 0.3,
          "delta_n": z.copy(), "omega_dot": z.copy(), "idot": z.copy(), "cuc": z.copy(),
          "cus": z.copy(), "cic": z.copy(), "cis": z.copy(), "crc": z.copy(), "crs": z.copy(),
          "af0": 1e-4 * np.sin(np.arange(n)), "af1": np.full(n, 1e-11), "af2": z.copy(),
          "tgd": z.copy(), "health": z.copy()}
    sv = np.array([f"G{i + 1:02d}" for i in range(n)])
    return Ephemerides("synthetic", sv, np.full(n, toe), np.full(n, toe), el)


def _pseudoranges(eph, rx, t, clock_m):
    """Pseudoranges [m] time-tagged ``t`` by a receiver at ECEF ``rx`` whose clock runs
    ``clock_m`` ahead (its tags ``clock_m / c`` late): the light-time equation solved by
    fixed-point iteration, the satellite seen in the Earth-fixed frame of the true
    receive time."""
    idx = np.broadcast_to(np.arange(len(eph.sv)), (len(t), len(eph.sv)))
    tau = np.full(idx.shape, 0.07)
    t_true = t - clock_m / C
    for _ in range(10):
        pos, _, clk, _ = satellite_states(eph, idx, t_true[:, None] - tau, l1_only=False)
        a = OMEGA_E * tau
        x = np.cos(a) * pos[..., 0] + np.sin(a) * pos[..., 1]
        y = -np.sin(a) * pos[..., 0] + np.cos(a) * pos[..., 1]
        tau = np.linalg.norm(np.stack([x, y, pos[..., 2]], axis=-1) - rx, axis=-1) / C
    up = (np.stack([x, y, pos[..., 2]], axis=-1) - rx) @ (rx / np.linalg.norm(rx))
    pr = C * tau + clock_m - C * clk
    return np.where(up > 0.2 * C * tau, pr, np.nan)  # (above ~12 deg)


def test_single_point_recovers_a_position_from_light_time_pseudoranges():
    t = 2.0e9 + np.arange(0.0, 600.0, 30.0)
    eph = _constellation(float(t[0]))
    rx = earth.llh_to_ecef(np.radians(35.0), np.radians(139.0), 50.0)
    pr = _pseudoranges(eph, rx, t, 1234.5)
    assert (np.isfinite(pr).sum(axis=1) >= 5).all()
    s = single_point(t, pr, eph.sv, eph, l1_only=False, iono=False, tropo=False)
    assert np.abs(s.xyz - rx).max() < 1e-3
    assert np.abs(s.clock_m - 1234.5).max() < 1e-3
    assert np.nanmax(np.abs(s.residuals)) < 1e-3
    assert (s.dop[:, 1] > 1.0).all() and (s.dop[:, 0] >= s.dop[:, 1]).all()


def test_fewer_than_four_satellites_give_nan():
    t = 2.0e9 + np.arange(3) * 30.0
    eph = _constellation(float(t[0]))
    rx = earth.llh_to_ecef(np.radians(35.0), np.radians(139.0), 50.0)
    pr = _pseudoranges(eph, rx, t, 0.0)
    keep = np.flatnonzero(np.isfinite(pr[1]))[:3]
    pr[1] = np.nan
    pr[1, keep] = _pseudoranges(eph, rx, t, 0.0)[1, keep]
    s = single_point(t, pr, eph.sv, eph, l1_only=False, iono=False, tropo=False)
    assert np.isnan(s.xyz[1]).all() and np.isfinite(s.xyz[[0, 2]]).all()


def test_a_satellite_without_a_usable_ephemeris_drops_out():
    t = 2.0e9 + np.arange(0.0, 300.0, 30.0)
    eph = _constellation(float(t[0]))
    rx = earth.llh_to_ecef(np.radians(35.0), np.radians(139.0), 50.0)
    pr = _pseudoranges(eph, rx, t, 0.0)
    seen = int(np.flatnonzero(np.isfinite(pr[0]))[0])
    eph.elements["health"][seen] = 1.0  # (unhealthy: its record is not used)
    s = single_point(t, pr, eph.sv, eph, l1_only=False, iono=False, tropo=False)
    assert np.abs(s.xyz - rx).max() < 1e-3 and np.isnan(s.residuals[:, seen]).all()


def test_the_troposphere_grows_toward_the_horizon():
    el = np.radians([90.0, 30.0, 10.0])
    d = saastamoinen(np.radians(35.0), 50.0, el)
    assert 2.2 < d[0] < 2.6 and d[0] < d[1] < d[2] and d[1] == pytest.approx(2 * d[0], 0.01)


@needs_data
@pytest.mark.parametrize("station", ["0759", "3040"])
def test_single_point_on_a_static_station(station):
    obs = read_rinex_obs(STATIC / f"{station}0920.05o")
    nav = read_rinex_nav(STATIC / f"{station}0920.05n")
    assert len(obs.t) == 120 and obs.t[1] - obs.t[0] == 30.0 and nav.iono is not None
    truth = earth.ecef_to_llh(obs.approx_xyz)

    def errors(s):
        e = np.asarray(earth.llh_difference_enu(s.lla[:, 0], s.lla[:, 1], s.lla[:, 2],
                                                *truth))
        return e if e.shape[-1] == 3 else e.T

    l1 = single_point(obs.t, obs.code("C1"), obs.sv, nav)
    e = errors(l1)
    rms = np.sqrt((e**2).mean(axis=0))
    assert np.hypot(rms[0], rms[1]) < 1.5 and rms[2] < 3.0, rms
    assert (l1.used >= 5).all() and np.nanmedian(l1.dop[:, 1]) < 4.0
    # the ionosphere model matters, and acts in the right direction
    e_no = errors(single_point(obs.t, obs.code("C1"), obs.sv, nav, iono=False))
    assert np.sqrt((e_no[:, 2] ** 2).mean()) > rms[2]
    e_no = errors(single_point(obs.t, obs.code("C1"), obs.sv, nav, tropo=False))
    assert np.sqrt((e_no[:, 2] ** 2).mean()) > 2.0 * rms[2]
    # dual frequency: no ionosphere model, no TGD
    ifree = errors(single_point(obs.t, iono_free(obs.code("C1"), obs.code("P2")), obs.sv,
                                nav, l1_only=False))
    assert np.sqrt((ifree**2).sum(axis=1).mean()) < 5.0


@needs_data
def test_satellites_of_the_broadcast_ephemerides():
    obs = read_rinex_obs(STATIC / "07590920.05o")
    nav = read_rinex_nav(STATIC / "07590920.05n")
    from fednav.sensors.satellites import nearest_ephemeris

    idx = nearest_ephemeris(nav, obs.sv, obs.t)
    pos, vel, clk, drift = satellite_states(nav, idx, obs.t[:, None] - 0.075)
    r = np.linalg.norm(pos, axis=-1)
    assert np.nanmin(r) > 25.8e6 and np.nanmax(r) < 27.4e6
    v = np.linalg.norm(vel, axis=-1)
    assert np.nanmin(v) > 2.5e3 and np.nanmax(v) < 4.0e3  # (m/s, Earth-fixed)
    assert np.nanmax(np.abs(clk)) < 1e-3 and np.nanmax(np.abs(drift)) < 1e-9


def test_bad_rinex_is_one_line(tmp_path):
    p = tmp_path / "x.05o"
    p.write_text("not rinex\n")
    with pytest.raises(DataError) as e:
        read_rinex_obs(p)
    assert "\n" not in str(e.value) and "x.05o" in str(e.value)
    with pytest.raises(DataError, match="no such file"):
        read_rinex_nav(tmp_path / "missing.05n")

"""RTKLIB .pos solutions read as the GNSS's series: every time and position layout RTKLIB
writes, checked against values written by hand, and the real drive's file."""

from pathlib import Path

import numpy as np
import pytest

from fednav.core import earth
from fednav.io import DataError, read_rtklib_pos
from fednav.io.data import Series

DRIVE = Path(__file__).resolve().parents[3] / "shared" / "data" / "rtklibexplorer-drive"

HEAD = ("% program   : RTKPOST ver.demo5\n"
        "% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp)\n")
COLS = ("%  GPST                  latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   "
        "sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio    vn(m/s)    ve(m/s)    "
        "vu(m/s)      sdvn     sdve     sdvu    sdvne    sdveu    sdvun\n")
ROWS = ("2025/07/08 23:59:59.750   40.096626800 -105.147448300  1601.4740   1  21   0.0099   "
        "0.0098   0.0100   0.0000   0.0000   0.0000   0.00    0.0    0.0100   -0.0020    "
        "0.0090    0.0587   0.0586   0.0590   0.0000   0.0000   0.0000\n"
        "2025/07/09 00:00:00.000   40.096627000 -105.147448000  1601.4800   2  20   0.2000   "
        "0.3000   0.5000   0.0000   0.0000   0.0000   0.00    0.0    1.0000    2.0000    "
        "0.5000    0.1000   0.2000   0.3000   0.0000   0.0000   0.0000\n"
        "2025/07/09 00:00:00.250   40.096627100 -105.147447900  1601.4810   1  20   0.0100   "
        "0.0100   0.0100   0.0000   0.0000   0.0000   0.00    0.0    1.0000    2.0000    "
        "0.5000    0.0600   0.0600   0.0600   0.0000   0.0000   0.0000\n")


def _file(tmp_path, text, name="sol.pos"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_date_time_layout_with_velocity_and_sigmas(tmp_path):
    g = read_rtklib_pos(_file(tmp_path, HEAD + COLS + ROWS))
    assert isinstance(g, Series) and g.name == "gnss"
    # 2025-07-08 23:59:59.75 GPST: seconds since 1970 on the GPS clock, then the day turns
    assert g.t[0] == 1752019199.75 and g.t[1] - g.t[0] == pytest.approx(0.25, abs=1e-9)
    np.testing.assert_allclose(np.degrees(g.lla[1, :2]), [40.096627, -105.147448],
                               rtol=0, atol=1e-12)
    assert g.lla[1, 2] == 1601.48
    np.testing.assert_array_equal(g.vel[1], [2.0, 1.0, 0.5])  # ENU from vn, ve, vu
    # sigma rows in the series' order: north, east, up [m], vE, vN, vU [m/s]
    np.testing.assert_array_equal(g.sigma_rows[1], [0.2, 0.3, 0.5, 0.2, 0.1, 0.3])
    assert g.quality["gnss_rtklib_q"] == {"fixed": 2, "float": 1}
    fixed = read_rtklib_pos(_file(tmp_path, HEAD + COLS + ROWS), quality=(1,))
    assert len(fixed.t) == 2 and fixed.quality["gnss_rows_of_other_quality"] == 1
    week = read_rtklib_pos(_file(tmp_path, HEAD + COLS + ROWS), time="week")
    # Tuesday 23:59:59.75 of the GPS week (weeks start on Sunday 00:00 GPST)
    assert week.t[0] == 2 * 86400 + 86399.75 and week.t[1] == 3 * 86400.0


def test_week_tow_and_ecef_layouts(tmp_path):
    lla = np.array([np.radians(45.5), np.radians(-73.6), 120.0])
    x, y, z = earth.llh_to_ecef(*lla)
    text = ("%  GPST          x-ecef(m)      y-ecef(m)      z-ecef(m)   Q  ns   sdx(m)   "
            "sdy(m)   sdz(m)  sdxy(m)  sdyz(m)  sdzx(m) age(s)  ratio\n"
            f"2374 243258.500 {x:.4f} {y:.4f} {z:.4f} 5 9 2.0 2.0 3.0 0 0 0 0.0 0.0\n"
            f"2374 243259.500 {x:.4f} {y:.4f} {z:.4f} 5 9 2.0 2.0 3.0 0 0 0 0.0 0.0\n")
    g = read_rtklib_pos(_file(tmp_path, text), time="week", sigma_pos_enu=(2.0, 2.0, 4.0))
    assert g.t[0] == 243258.5 and g.vel is None and g.sigma_rows is None  # (no sdn/sde/sdu)
    np.testing.assert_allclose(g.lla[0, :2], lla[:2], atol=1e-10)
    assert g.lla[0, 2] == pytest.approx(120.0, abs=1e-3)
    np.testing.assert_array_equal(g.sigma_pos_enu, [2.0, 2.0, 4.0])
    full = read_rtklib_pos(_file(tmp_path, text))
    assert full.t[0] == 315964800.0 + 2374 * 604800.0 + 243258.5


def test_degrees_minutes_seconds_layout(tmp_path):
    text = ("%  GPST                  latitude(d'\")   longitude(d'\")  height(m)   Q  ns   "
            "sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio\n"
            "2025/07/08 19:34:18.499  40 05 47.85648 -105 08 50.81388  1601.4740   1  21   "
            "0.0099   0.0099   0.0100   0.0000   0.0000   0.0000   0.00    0.0\n"
            "2025/07/08 19:34:18.749  40 05 47.85648 -105 08 50.81388  1601.4740   1  21   "
            "0.0099   0.0099   0.0100   0.0000   0.0000   0.0000   0.00    0.0\n")
    g = read_rtklib_pos(_file(tmp_path, text))
    np.testing.assert_allclose(np.degrees(g.lla[0, :2]), [40.0966268, -105.1474483],
                               atol=1e-9)


def test_what_it_refuses_is_one_line(tmp_path):
    base = ("%  GPST   e-baseline(m)  n-baseline(m)  u-baseline(m)  Q  ns\n"
            "2025/07/08 19:34:18.499  1.0 2.0 3.0 1 9\n")
    for text, match in [(base, "a baseline solution"),
                        ("2025/07/08 19:34:18.499 1 2\n", "not an RTKLIB solution"),
                        (HEAD + COLS + ROWS.replace("   1  21", "   1  21 7", 1),
                         r"solution row 1 has 25 values, the others 24"),
                        (HEAD + COLS.replace("GPST", "UTC "), None)]:
        p = _file(tmp_path, text)
        if match is None:  # (a UTC file's seconds of the GPS week: not defined)
            with pytest.raises(DataError, match="time='week' needs a GPST solution; this "
                                                "one is in UTC"):
                read_rtklib_pos(_file(tmp_path, HEAD + COLS.replace("GPST", "UTC ") + ROWS),
                                time="week")
            continue
        with pytest.raises(DataError, match=match) as e:
            read_rtklib_pos(p)
        assert "\n" not in str(e.value)
    with pytest.raises(DataError, match=r"no solution of quality \[6\]"):
        read_rtklib_pos(_file(tmp_path, HEAD + COLS + ROWS), quality=(6,))


@pytest.mark.skipif(not DRIVE.exists(), reason="needs ../shared/data")
def test_the_real_drives_solution():
    g = read_rtklib_pos(DRIVE / "gnss_1934_sf.pos", time="week")
    assert len(g.t) == 2197 and g.quality["gnss_rtklib_q"] == {"fixed": 2189, "float": 8}
    assert g.t[0] == 243258.499 and g.t[-1] - g.t[0] == pytest.approx(549.0)
    assert np.all(np.diff(g.t) > 0) and np.median(np.diff(g.t)) == pytest.approx(0.25)
    np.testing.assert_allclose(np.degrees(g.lla[0, :2]), [40.0966268, -105.1474483])
    assert g.vel is not None and np.all(g.sigma_rows > 0)


def test_zero_or_missing_sigmas_take_the_figures(tmp_path):
    """A 1-sigma of 0 (RTKLIB writes 0.0000 where it has none) or a column the solution
    lacks: the figures given, per component, counted; the rows the quality filter drops
    play no part."""
    rows = ROWS.replace("   0.0099   0.0098", "   0.0000   0.0098", 1)  # (row 1: sdn 0)
    rows = rows.replace("0.0587   0.0586   0.0590", "0.0000   0.0000   0.0000", 1)
    g = read_rtklib_pos(_file(tmp_path, HEAD + COLS + rows), sigma_pos_enu=(2.0, 3.0, 4.0),
                        sigma_vel=0.7)
    np.testing.assert_allclose(g.sigma_rows[0], [3.0, 0.0098, 0.01, 0.7, 0.7, 0.7])
    np.testing.assert_allclose(g.sigma_rows[1], [0.2, 0.3, 0.5, 0.2, 0.1, 0.3])
    assert g.quality["gnss_sigma_zero_replaced"] == 1
    fixed = rows.replace("   2  20   0.2000", "   1  20   0.2000", 1)
    assert read_rtklib_pos(_file(tmp_path, HEAD + COLS + fixed.replace(
        "   1  21   0.0000", "   2  21   0.0000", 1)), quality=(1,)).quality[
        "gnss_sigma_zero_replaced"] == 0  # (row 1, float, dropped by the filter)
    no_sdv = COLS.split("sdvn")[0] + "\n"
    short = "\n".join(" ".join(r.split()[:18]) for r in ROWS.strip().splitlines()) + "\n"
    g = read_rtklib_pos(_file(tmp_path, HEAD + no_sdv + short), sigma_vel=0.4)
    np.testing.assert_allclose(g.sigma_rows[:, 3:], 0.4)

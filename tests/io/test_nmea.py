"""NMEA 0183 logs read as the GNSS's series: sentences written by pynmea2's own generator
from known fixes, read back to the same positions, times and sigmas."""

import datetime as dt

import numpy as np
import pytest

pynmea2 = pytest.importorskip("pynmea2")

from fednav.io import DataError, read_nmea  # noqa: E402
from fednav.io.nmea import NO_VERTICAL_SIGMA, NmeaDateWarning  # noqa: E402


def _dm(x: float, pos: str, neg: str, width: int) -> tuple[str, str]:
    """Degrees as NMEA's (d)ddmm.mmmmmm and hemisphere."""
    a = abs(x)
    d = int(a)
    return f"{d:0{width}d}{(a - d) * 60.0:09.6f}", pos if x >= 0 else neg


def _log(lat, lon, h_msl, sep, tod, date=None, speed_kn=None, course=None, gst=None,
         quality="4", talker="GN"):
    """One epoch's sentences."""
    hh = f"{int(tod // 3600):02d}{int(tod % 3600 // 60):02d}{tod % 60:05.2f}"
    la, ns = _dm(lat, "N", "S", 2)
    lo, ew = _dm(lon, "E", "W", 3)
    out = [pynmea2.GGA(talker, "GGA", (hh, la, ns, lo, ew, quality, "12", "0.8",
                                       f"{h_msl:.3f}", "M", f"{sep:.3f}", "M", "", ""))]
    if date is not None or speed_kn is not None:
        out.append(pynmea2.RMC(talker, "RMC", (
            hh, "A", la, ns, lo, ew, f"{speed_kn or 0:.3f}", f"{course or 0:.2f}",
            date.strftime("%d%m%y") if date else "", "", "", "D")))
    if gst is not None:
        out.append(pynmea2.GST(talker, "GST", (hh, "0.5", f"{gst[0]:.3f}", f"{gst[1]:.3f}",
                                               "0", f"{gst[0]:.3f}", f"{gst[1]:.3f}",
                                               f"{gst[2]:.3f}")))
    return [str(m) for m in out]


def test_positions_times_and_gst_sigmas_round_trip(tmp_path):
    day = dt.date(2025, 7, 8)
    lines = []
    for i in range(4):  # across midnight: the day rolls over
        tod = (86399.0 + 0.5 * i) % 86400.0
        lines += _log(40.1 + 1e-5 * i, -105.2 - 1e-5 * i, 1600.0 + i, -17.5, tod,
                      date=day if i == 0 else None, gst=(0.02, 0.03, 0.05))
    lines.insert(2, "$GNGGA,garbage*00")  # (a bad checksum: skipped, counted)
    p = tmp_path / "log.nmea"
    p.write_text("\n".join(lines) + "\n")
    g = read_nmea(p)
    t0 = dt.datetime(2025, 7, 8, 23, 59, 59, tzinfo=dt.UTC).timestamp()
    np.testing.assert_allclose(g.t - t0, [0.0, 0.5, 1.0, 1.5], atol=1e-9)
    np.testing.assert_allclose(np.degrees(g.lla[:, 0]), 40.1 + 1e-5 * np.arange(4),
                               atol=1e-9)
    np.testing.assert_allclose(np.degrees(g.lla[:, 1]), -105.2 - 1e-5 * np.arange(4),
                               atol=1e-9)
    np.testing.assert_allclose(g.lla[:, 2], 1600.0 + np.arange(4) - 17.5)  # ellipsoidal
    np.testing.assert_allclose(g.sigma_rows[0, :3], [0.02, 0.03, 0.05])  # north, east, up
    assert g.vel is None
    assert g.quality["gnss_nmea_fix"] == {"rtk_fixed": 4}
    assert g.quality["gnss_nmea_lines_skipped"] == 1


def test_speed_and_course_as_a_horizontal_velocity(tmp_path):
    lines = []
    for i in range(3):
        lines += _log(45.0, 7.0, 300.0, 48.0, 36000.0 + i, date=dt.date(2024, 1, 2),
                      speed_kn=10.0, course=30.0)
    p = tmp_path / "v.nmea"
    p.write_text("\n".join(lines))
    g = read_nmea(p, velocity=True, sigma_vel=0.2)
    s = 10.0 * 1852.0 / 3600.0
    np.testing.assert_allclose(g.vel[0], [s * np.sin(np.radians(30.0)),
                                          s * np.cos(np.radians(30.0)), 0.0], atol=1e-6)
    np.testing.assert_allclose(g.sigma_rows[0, 3:], [0.2, 0.2, NO_VERTICAL_SIGMA])
    assert read_nmea(p).vel is None  # (positions only by default)


def test_no_date_no_fix_and_bad_files(tmp_path):
    p = tmp_path / "nodate.nmea"
    p.write_text("\n".join(_log(1.0, 2.0, 3.0, 0.0, 100.0) + _log(1.0, 2.0, 3.0, 0.0, 101.0)))
    with pytest.warns(NmeaDateWarning, match="no date in the log"):
        g = read_nmea(p)
    np.testing.assert_array_equal(g.t, [100.0, 101.0])
    g = read_nmea(p, date="2020-02-29")
    assert g.t[0] == dt.datetime(2020, 2, 29, 0, 1, 40, tzinfo=dt.UTC).timestamp()
    nofix = tmp_path / "nofix.nmea"
    nofix.write_text("\n".join(_log(1.0, 2.0, 3.0, 0.0, 5.0, quality="0")))
    with pytest.raises(DataError, match="no GGA sentence with a fix"):
        read_nmea(nofix)
    with pytest.raises(DataError, match="no such file|not found|does not exist"):
        read_nmea(tmp_path / "missing.nmea")

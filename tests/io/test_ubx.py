"""u-blox UBX logs: NAV-PVT messages written by pyubx2's own generator (with other
messages, a 2-D fix and garbage between them) read back as the GNSS's fixes."""

import calendar

import numpy as np
import pytest

pyubx2 = pytest.importorskip("pyubx2")

from fednav.io import DataError, read_ubx  # noqa: E402


def _pvt(i: int, fix: int = 3, carr: int = 2) -> bytes:
    s = 18.5 + 0.25 * i  # [s] of the minute
    return pyubx2.UBXMessage(
        "NAV", "NAV-PVT", pyubx2.GET, iTOW=243258500 + 250 * i, year=2025, month=7, day=8,
        hour=19, min=34, second=int(s), validDate=1, validTime=1, fullyResolved=1,
        nano=int(round((s - int(s)) * 1e9)),
        fixType=fix, gnssFixOk=1, carrSoln=carr, numSV=20, lon=-105.1474483 + 1e-6 * i,
        lat=40.0966268, height=1601474 + i, hMSL=1618000, hAcc=14, vAcc=10, velN=1000,
        velE=-2000, velD=-900, gSpeed=10, headMot=0, sAcc=58, headAcc=0, pDOP=1.2
    ).serialize()


def test_nav_pvt_fixes_round_trip(tmp_path):
    status = pyubx2.UBXMessage("NAV", "NAV-STATUS", pyubx2.GET, iTOW=1, gpsFix=3)
    data = b"".join(_pvt(i) for i in range(6)) + status.serialize() + b"\x00garbage" \
        + _pvt(6, fix=2) + _pvt(7, carr=1)
    p = tmp_path / "log.ubx"
    p.write_bytes(data)
    g = read_ubx(p)
    assert len(g.t) == 7  # (the 2-D fix left out)
    t0 = calendar.timegm((2025, 7, 8, 19, 34, 18)) + 0.5
    np.testing.assert_allclose(g.t[:4] - t0, [0.0, 0.25, 0.5, 0.75], atol=1e-6)
    np.testing.assert_allclose(np.degrees(g.lla[1, :2]), [40.0966268, -105.1474473],
                               atol=1e-9)
    assert g.lla[1, 2] == pytest.approx(1601.475)  # (height above the ellipsoid, mm)
    np.testing.assert_allclose(g.vel[0], [-2.0, 1.0, 0.9])  # ENU from NED
    np.testing.assert_allclose(g.sigma_rows[0], [0.014, 0.014, 0.010, 0.058, 0.058, 0.058])
    assert g.quality["gnss_ubx_fixes"] == {"3d/fixed": 6, "3d/float": 1}
    assert g.quality["gnss_ubx_left_out"]["not_3d_or_no_fix_ok"] == 1
    assert g.quality["gnss_ubx_left_out"]["other_messages"] >= 1
    week = read_ubx(p, time="week")
    assert week.t[0] == pytest.approx(243258.5)


def test_a_log_without_fixes_is_one_line(tmp_path):
    p = tmp_path / "none.ubx"
    p.write_bytes(_pvt(0, fix=2) + b"not ubx")
    with pytest.raises(DataError, match=r"no NAV-PVT message with a 3-D fix") as e:
        read_ubx(p)
    assert "\n" not in str(e.value)
    with pytest.raises(DataError, match="time must be 'utc' or 'week'"):
        read_ubx(p, time="gps")

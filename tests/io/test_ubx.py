"""u-blox UBX logs: NAV-PVT messages written by pyubx2's own generator (with other
messages, a 2-D fix and garbage between them) read back as the GNSS's fixes; a
dead-reckoning module's ESF-RAW / ESF-MEAS (IMU, speed, wheel ticks) with NAV-STATUS and
NAV-TIMEGPS read back as the IMU and the odometer on GPS time."""

import calendar
from pathlib import Path

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


# --------------------------------------------------------------- ESF: IMU, odometer, time
# A u-blox dead-reckoning log written with pyubx2's generator from a fednav-simulated drive
# (examples/car-drive.yaml: levelled start, pull-away, right turn; 200 Hz): ESF-RAW (the IMU,
# FRD, ten samples a message), ESF-MEAS (speed, with the receiver's time tag), NAV-STATUS
# (receiver time and GPS time of week), NAV-TIMEGPS (week, leap seconds), NAV-PVT.

import struct  # noqa: E402

from fednav.core import attitude as att  # noqa: E402
from fednav.io.navego import FRD_TO_RFU  # noqa: E402
from fednav.io.ubx import read_ubx_imu, read_ubx_odometer  # noqa: E402

WEEK, LEAP = 2374, 18
MSSS0 = 130_000          # receiver time at the drive's start [ms since start-up]
ITOW0 = 243_258_000      # GPS time of week then [ms]
GPS_TO_UTC = 315964800 + WEEK * 604800 - LEAP  # UTC = this + time of week [s]


@pytest.fixture(scope="module")
def drive():
    from fednav.sim.dataset import load_dataset_config, simulate_dataset

    cfg = load_dataset_config(Path(__file__).resolve().parents[2] / "examples"
                              / "car-drive.yaml")
    seg = [cfg.segments[0].model_copy(update={"duration_s": 2.0}), cfg.segments[1],
           cfg.segments[3].model_copy(update={"duration_s": 4.0})]
    d = simulate_dataset(cfg.model_copy(update={"segments": seg}))
    t = d.t - d.t[0]
    v_body = np.einsum("nji,nj->ni", att.euler_to_dcm(d.ref_euler), d.ref_vel)
    return t, d.gyro, d.accel, v_body[:, 1]  # (forward speed)


def _pack24(v) -> int:
    return int(v) & 0xFFFFFF


def _esf_raw(tags, gyro_frd, accel_frd, temp_c=31.5) -> bytes:
    """ESF-RAW messages of 10 samples each (pyubx2 builds a variable group from a payload)."""
    out = b""
    for s in range(0, len(tags), 10):
        pl = struct.pack("<I", 0)
        for k in range(s, min(s + 10, len(tags))):
            g = np.rint(np.degrees(gyro_frd[k]) / 2**-12)
            a = np.rint(accel_frd[k] / 2**-10)
            for typ, val in ((14, g[0]), (13, g[1]), (5, g[2]), (16, a[0]), (17, a[1]),
                             (18, a[2]), (12, round(temp_c * 100))):
                pl += struct.pack("<II", (typ << 24) | _pack24(val), int(tags[k]))
        out += pyubx2.UBXMessage("ESF", "ESF-RAW", pyubx2.GET, payload=pl).serialize()
    return out


def _esf_meas(tag, calib, fields) -> bytes:
    """One ESF-MEAS (as the receiver outputs it: calibTtag after the data)."""
    kw = {f"dataField_{i + 1:02d}": _pack24(v) for i, (_, v) in enumerate(fields)}
    kw.update({f"dataType_{i + 1:02d}": k for i, (k, _) in enumerate(fields)})
    n = len(fields)
    kw.update({f"dataField_{n + 1:02d}": calib & 0xFFFFFF, f"dataType_{n + 1:02d}": calib >> 24})
    return pyubx2.UBXMessage("ESF", "ESF-MEAS", pyubx2.SET, timeTag=int(tag), calibTtagValid=1,
                             numMeas=n, id=0, **kw).serialize()


def _nav(t_s: float, leap=True) -> bytes:
    """NAV-STATUS (receiver time, GPS time of week) and NAV-TIMEGPS at drive time ``t_s``."""
    msss = MSSS0 + int(round(t_s * 1000))
    itow = ITOW0 + int(round(t_s * 1000))
    out = pyubx2.UBXMessage("NAV", "NAV-STATUS", pyubx2.GET, iTOW=itow, gpsFix=3, gpsFixOk=1,
                            wknSet=1, towSet=1, ttff=30_000, msss=msss).serialize()
    if leap:
        out += pyubx2.UBXMessage("NAV", "NAV-TIMEGPS", pyubx2.GET, iTOW=itow, fTOW=0,
                                 week=WEEK, leapS=LEAP, towValid=1, weekValid=1, leapSValid=1,
                                 tAcc=20).serialize()
    return out


def _pvt_at(t_s: float, valid_utc=True) -> bytes:
    itow = ITOW0 + int(round(t_s * 1000))
    utc = GPS_TO_UTC + itow / 1000
    y, mo, d, h, mi, s = __import__("time").gmtime(int(utc))[:6]
    return pyubx2.UBXMessage(
        "NAV", "NAV-PVT", pyubx2.GET, iTOW=itow, year=y, month=mo, day=d, hour=h, min=mi,
        second=s, validDate=int(valid_utc), validTime=int(valid_utc), fullyResolved=1,
        nano=int(round((utc - int(utc)) * 1e9)), fixType=3, gnssFixOk=1, numSV=12,
        lon=-114.07, lat=51.05, height=1050000, hMSL=1067000, hAcc=1500, vAcc=2500, velN=0,
        velE=0, velD=0, sAcc=100, pDOP=1.5).serialize()


def _drive_log(drive, tick_ms=1.0, tag0_ms=MSSS0, with_meas=True, with_status=True,
               speed=True, ticks_m=None) -> bytes:
    """The drive as a u-blox log: sensor time tags of ``tick_ms`` ms (24-bit) from
    ``tag0_ms`` at the start (by default the receiver's clock, as a ZED-F9R's)."""
    t, gyro, accel, v = drive
    tags = np.rint((tag0_ms + 1000 * t) / tick_ms).astype(np.int64) & 0xFFFFFF
    frd = FRD_TO_RFU  # (RFU -> FRD: the same matrix)
    data = _esf_raw(tags, gyro @ frd.T, accel @ frd.T)
    out = b""
    dist = 0.0
    for i in range(0, len(t), 20):  # 10 Hz: the navigation messages, speed, wheel ticks
        out += _nav(t[i]) if with_status else b""
        if i % 200 == 0:
            out += _pvt_at(t[i], valid_utc=i != 200)
        if with_meas:
            fields = [(11, round(v[i] * 1000))] if speed else []
            if ticks_m is not None:
                count = int(dist / ticks_m) & 0x7FFFFF
                fields += [(8, count), (9, count)]
            out += _esf_meas(tags[i], MSSS0 + int(round(1000 * t[i])), fields)
        dist += v[i] * 0.1
    # (the raw IMU in bursts between the navigation messages, as a receiver sends it)
    n = len(data) // 2
    return out[: len(out) // 2] + data[:n] + out[len(out) // 2:] + data[n:]


def test_esf_raw_imu_round_trips_within_the_quantisation(tmp_path, drive):
    t, gyro, accel, _ = drive
    p = tmp_path / "drive.ubx"
    p.write_bytes(_drive_log(drive))
    imu = read_ubx_imu(p)
    assert len(imu.t) == len(t)
    np.testing.assert_allclose(imu.t, ITOW0 / 1000 + t, atol=1e-6)  # GPS time of week
    np.testing.assert_allclose(imu.gyro, gyro, atol=0.5 * np.radians(2**-12) + 1e-12)
    np.testing.assert_allclose(imu.accel, accel, atol=0.5 * 2**-10 + 1e-12)
    assert np.mean(imu.accel[:100, 2]) == pytest.approx(9.81, abs=0.05)  # (at rest: up)
    q = imu.quality
    assert q["imu_time_base"] == "gps" and "NAV-STATUS msss/iTOW" in q["imu_time_mapping"]
    assert q["imu_rate_hz"] == pytest.approx(200.0)
    assert q["leap_seconds"] == LEAP and q["gps_week"] == WEEK
    assert q["imu_temperature_c"] == pytest.approx(31.5)
    assert imu.mounting_name == "FRD"
    # the UTC time base: the week's seconds moved by the week and the leap seconds
    utc = read_ubx_imu(p, time="utc")
    np.testing.assert_allclose(utc.t - imu.t, GPS_TO_UTC, atol=1e-6)
    # the module mounted otherwise: its axes taken as the body's
    rfu = read_ubx_imu(p, mounting="RFU")
    np.testing.assert_allclose(rfu.gyro, gyro @ FRD_TO_RFU.T, atol=3e-6)


def test_sensor_time_tags_in_their_own_unit_are_mapped_through_esf_meas(tmp_path, drive):
    """A sensor clock of its own, 39.0625 us ticks (24 bits: wrapping 5 s into the log),
    counted from elsewhere: its unit and origin come from ESF-MEAS timeTag against
    calibTtag [ms]."""
    t = drive[0]
    p = tmp_path / "ticks.ubx"
    p.write_bytes(_drive_log(drive, tick_ms=0.0390625, tag0_ms=655_360 - 5_000))
    imu = read_ubx_imu(p)
    np.testing.assert_allclose(imu.t, ITOW0 / 1000 + t, atol=1e-4)
    assert "0.0390625 ms per tick" in imu.quality["imu_time_mapping"]


def test_without_the_clock_messages_the_sensor_time_is_kept_with_a_warning(tmp_path, drive):
    t = drive[0]
    p = tmp_path / "raw.ubx"
    p.write_bytes(_drive_log(drive, with_meas=False, with_status=False))
    with pytest.warns(UserWarning, match=r"times are the sensor's time tags x 0.001 s "
                                         r"\(assumed: ttag_s\), not GPS time: no NAV-STATUS"):
        imu = read_ubx_imu(p)
    assert imu.quality["imu_time_base"] == "sensor"
    np.testing.assert_allclose(imu.t, MSSS0 / 1000 + t, atol=1e-6)
    p2 = tmp_path / "noleap.ubx"
    p2.write_bytes(_esf_raw([1, 2, 3], np.zeros((3, 3)), np.zeros((3, 3))))
    with pytest.raises(DataError, match=r"time='utc' needs NAV-TIMEGPS") as e:
        read_ubx_imu(p2, time="utc")
    assert "\n" not in str(e.value)


def test_a_log_without_esf_raw_is_one_line_naming_the_message_class(tmp_path):
    p = tmp_path / "pvt.ubx"
    p.write_bytes(_pvt(0) + _pvt(1))
    with pytest.raises(DataError, match=r"no ESF-RAW message \(UBX class ESF 0x10, id 0x03") \
            as e:
        read_ubx_imu(p)
    assert "\n" not in str(e.value)
    with pytest.raises(DataError, match=r"no ESF-MEAS speed or wheel ticks \(data types 6-11\)"):
        read_ubx_odometer(p)


def test_nav_timegps_leap_seconds_make_utc_and_week_agree(tmp_path, drive):
    p = tmp_path / "drive.ubx"
    p.write_bytes(_drive_log(drive))
    utc, week = read_ubx(p), read_ubx(p, time="week")
    assert utc.quality["leap_seconds"] == LEAP and utc.quality["gps_week"] == WEEK
    assert len(utc.t) == len(week.t) == 12  # (1 Hz over the 12 s drive)
    np.testing.assert_allclose(utc.t - week.t, GPS_TO_UTC, atol=1e-6)
    assert utc.quality["utc_from_week"] == 1  # (the fix without a valid date: from its week)
    imu = read_ubx_imu(p, time="utc")  # the IMU on the fixes' time base
    assert imu.t[0] == pytest.approx(utc.t[0], abs=1e-6)


def test_esf_meas_speed_is_the_odometer_and_ticks_need_their_scale(tmp_path, drive):
    t, _, _, v = drive
    p = tmp_path / "drive.ubx"
    p.write_bytes(_drive_log(drive))
    odo = read_ubx_odometer(p)
    assert odo.name == "odometer" and odo.quality["odometer_source"] == "speed"
    np.testing.assert_allclose(odo.t, ITOW0 / 1000 + t[::20], atol=1e-6)
    np.testing.assert_allclose(odo.z[:, 0], v[::20], atol=0.5e-3 + 1e-9)
    assert odo.quality["odometer_time_base"] == "gps"
    p = tmp_path / "ticks.ubx"
    p.write_bytes(_drive_log(drive, speed=False, ticks_m=0.01))
    with pytest.raises(DataError, match=r"wheel ticks \(rear-left, rear-right\) but no speed: "
                                        r"give tick_m"):
        read_ubx_odometer(p)
    odo = read_ubx_odometer(p, tick_m=0.01)
    assert odo.quality["odometer_source"] == "rear-left + rear-right ticks"
    mid = 0.5 * (t[20::20] + t[:-20:20])
    np.testing.assert_allclose(odo.t, ITOW0 / 1000 + mid, atol=1e-6)
    # each interval's mean speed, within a tick over its 0.1 s
    np.testing.assert_allclose(odo.z[:, 0], v[:-20:20], atol=0.01 / 0.1 + 1e-9)

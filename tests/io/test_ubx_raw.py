"""u-blox raw logs: LNAV subframes written by the test (IS-GPS-200's layout) and RXM-RAWX
/ RXM-SFRBX messages written by pyubx2 from simulated observations, read back to the
same ephemerides and measurements; the 10-bit week resolved across a rollover; a log
without an ephemeris refused by name."""

import sys
from pathlib import Path

import numpy as np
import pytest

pyubx2 = pytest.importorskip("pyubx2")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from test_satellites import _constellation, _pseudoranges  # noqa: E402

from fednav.core import earth  # noqa: E402
from fednav.io.data import DataError  # noqa: E402
from fednav.io.rinex import WEEK_S  # noqa: E402
from fednav.io.ubx_raw import (  # noqa: E402
    LNAV_FIELDS,
    decode_fields,
    decode_lnav,
    lnav_subframes,
    read_ubx_raw_gnss,
    subframe_id,
)
from fednav.sensors.gnss_raw import FIELDS, SLOTS, from_observations  # noqa: E402
from fednav.sensors.satellites import F_L1, C, satellite_states  # noqa: E402


def _words(values: dict, which: int, tow: float, week: int, toc: float, toe: float):
    """Subframe ``which`` of the ephemeris ``values`` as ten u-blox words (data bits
    29..6, parity zero): the test's own LNAV writer, the reader's inverse."""
    v = dict(values, week=week % 1024, iodc_hi=0, iodc_lo=7, iode=7, toc=toc, toe=toe)
    bits = 0x8B << 216  # TLM preamble
    bits |= (int(tow // 6) & 0x1FFFF) << (240 - 24 - 17)
    bits |= which << (240 - 43 - 3)
    for name, first, width, _, scale in LNAV_FIELDS[which]:
        n = int(round(v[name] / scale))
        assert -(1 << (width - 1)) <= n < (1 << width), (name, n)
        bits |= (n & ((1 << width) - 1)) << (240 - first - width)
    return [((bits >> (240 - 24 * (i + 1))) & 0xFFFFFF) << 6 for i in range(10)]


def _elements(eph, k):
    el = {n: float(a[k]) for n, a in eph.elements.items()}
    # (perturbations of a real orbit, so every field is exercised)
    el.update(cuc=1.2e-6, cus=-3.4e-6, crc=210.5, crs=-45.3, cic=5.6e-8, cis=-7.1e-8,
              e=0.0123, delta_n=4.5e-9, omega_dot=-8.1e-9, idot=3.0e-10, tgd=-4.7e-9,
              af2=0.0, omega=(1.1 - 0.2 * k + np.pi) % (2 * np.pi) - np.pi)
    el["m0"] = (el["m0"] + np.pi) % (2 * np.pi) - np.pi
    el["omega0"] = (el["omega0"] + np.pi) % (2 * np.pi) - np.pi
    return el


def test_subframes_decode_to_the_ephemeris():
    t0 = 2053 * WEEK_S + 345600.0
    eph = _constellation(t0)
    el = _elements(eph, 3)
    toc = toe = 345600.0
    sf = {w: lnav_subframes(_words(el, w, 345606.0, 2053, toc, toe)) for w in (1, 2, 3)}
    assert [subframe_id(sf[w]) for w in (1, 2, 3)] == [1, 2, 3]
    out = decode_lnav(sf[1], sf[2], sf[3], 2053)
    assert out["toe"] == out["toc"] == t0
    for name, *_, scale in LNAV_FIELDS[1] + LNAV_FIELDS[2] + LNAV_FIELDS[3]:
        if name in out and name not in ("toc", "toe"):
            assert out[name] == pytest.approx(el[name], abs=scale), name
    # another issue of data in subframe 3: no ephemeris
    bad = _words(el, 3, 345612.0, 2053, toc, toe)
    bits = lnav_subframes(bad) ^ (1 << (240 - 216 - 8))  # (IODE's last bit)
    assert decode_fields(bits, 3)["iode"] != 7 and decode_lnav(sf[1], sf[2], bits, 2053) \
        is None


@pytest.mark.parametrize("sf_week, rawx_week, want", [(5, 2053, 2053), (1023, 2048, 2047),
                                                      (0, 2047, 2048), (1000, 1000, 1000)])
def test_the_ten_bit_week_is_resolved_by_the_rawx_week(sf_week, rawx_week, want):
    eph = _constellation(0.0)
    el = _elements(eph, 0)
    sf = [lnav_subframes(_words(el, w, 6.0, sf_week, 0.0, 0.0)) for w in (1, 2, 3)]
    assert decode_lnav(*sf, rawx_week)["toe"] == want * WEEK_S


def test_an_ephemeris_for_next_week_sent_on_saturday_takes_next_week():
    """Subframes sent 6 s before the week's end whose toe and toc are the next week's
    start (0 s of week): toe and toc land in the next week (RTKLIB's handover rule)."""
    el = _elements(_constellation(0.0), 1)
    sf = [lnav_subframes(_words(el, w, WEEK_S - 6.0, 2100, 0.0, 0.0)) for w in (1, 2, 3)]
    out = decode_lnav(*sf, 2100)
    assert out["toe"] == out["toc"] == 2101 * WEEK_S


def _log(path, t, pr, dop, eph, with_sfrbx=True):
    """RXM-SFRBX subframes 1-3 of every satellite, then one RXM-RAWX per epoch."""
    week = int(t[0] // WEEK_S)
    msgs = []
    if with_sfrbx:
        for k, sv in enumerate(eph.sv):
            el = _elements(eph, k)
            for w in (1, 2, 3):
                words = _words(el, w, (t[0] % WEEK_S) + 6 * w, week, eph.toc[k] % WEEK_S,
                               eph.toe[k] % WEEK_S)
                msgs.append(pyubx2.UBXMessage(
                    "RXM", "RXM-SFRBX", pyubx2.GET, gnssId=0, svId=int(sv[1:]), sigId=0,
                    freqId=0, numWords=10, chn=k, version=2,
                    **{f"dwrd_{i + 1:02d}": words[i] for i in range(10)}))
    for i, ti in enumerate(t):
        seen = np.flatnonzero(np.isfinite(pr[i]))
        f = {"rcvTow": ti % WEEK_S, "week": week, "leapS": 18, "numMeas": len(seen)}
        for n, j in enumerate(seen, start=1):
            f.update({f"prMes_{n:02d}": pr[i, j], f"cpMes_{n:02d}": 0.0,
                      f"doMes_{n:02d}": dop[i, j], f"gnssId_{n:02d}": 0,
                      f"svId_{n:02d}": int(eph.sv[j][1:]), f"sigId_{n:02d}": 0,
                      f"cno_{n:02d}": 44, f"prValid_{n:02d}": 1})
        msgs.append(pyubx2.UBXMessage("RXM", "RXM-RAWX", pyubx2.GET, **f))
    path.write_bytes(b"".join(m.serialize() for m in msgs))


def test_a_pyubx2_log_reads_back_to_the_same_measurements(tmp_path):
    """Light-time pseudoranges and Dopplers of a synthetic constellation, written as a UBX
    log: read back, the rows are those of the same observations with the ephemerides the
    log's subframes carry (to the ephemeris fields' quantization), and they vanish at the
    receiver with its clock."""
    t = 2053 * WEEK_S + 345600.0 + np.arange(0.0, 120.0, 1.0)
    eph = _constellation(float(t[0]))
    # the perturbed elements: what the subframes carry and the observations come from
    for k in range(len(eph.sv)):
        for n, v in _elements(eph, k).items():
            eph.elements[n][k] = v
    lla = np.array([np.radians(35.0), np.radians(139.0), 50.0])
    rx = earth.llh_to_ecef(*lla)
    pr = _pseudoranges(eph, rx, t, 1234.5)
    dop = -(_pseudoranges(eph, rx, t + 0.5, 1234.5)
            - _pseudoranges(eph, rx, t - 0.5, 1234.5)) / (C / F_L1)
    log = tmp_path / "raw.ubx"
    _log(log, t, pr, dop, eph)
    s = read_ubx_raw_gnss(log, mask_deg=0.0)
    assert s.name == "gnss_raw" and len(s.t) == len(t)
    assert s.quality["ubx_ephemerides"] == len(eph.sv) and s.quality["gnss_raw_doppler"]
    tt, z, used = from_observations(t, pr, dop, eph.sv, eph, mask_deg=0.0, iono=False,
                                    cn0=np.full(pr.shape, 44.0))
    a = s.z.reshape(len(t), SLOTS, len(FIELDS))
    b = z.reshape(len(t), SLOTS, len(FIELDS))
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
    np.testing.assert_array_equal(a[..., 0], b[..., 0])
    np.testing.assert_allclose(a[..., 1:4], b[..., 1:4], atol=0.05)  # satellite [m]
    np.testing.assert_allclose(a[..., 7], b[..., 7], atol=0.05)  # pseudorange [m]
    np.testing.assert_allclose(a[..., 8], b[..., 8], atol=1e-3)  # range rate [m/s]
    # the decoded satellites are the broadcast ones
    idx = np.broadcast_to(np.arange(len(eph.sv)), (1, len(eph.sv)))
    p0, _, _, _ = satellite_states(eph, idx, np.full(idx.shape, t[0]))
    assert np.isfinite(p0).all()


def test_a_log_without_ephemerides_is_refused_by_name(tmp_path):
    t = 2053 * WEEK_S + 345600.0 + np.arange(0.0, 5.0, 1.0)
    eph = _constellation(float(t[0]))
    rx = earth.llh_to_ecef(np.radians(35.0), np.radians(139.0), 50.0)
    pr = _pseudoranges(eph, rx, t, 0.0)
    log = tmp_path / "rawx-only.ubx"
    _log(log, t, pr, np.zeros_like(pr), eph, with_sfrbx=False)
    with pytest.raises(DataError, match="no GPS ephemeris decodable from RXM-SFRBX.*nav="):
        read_ubx_raw_gnss(log)
    with pytest.raises(DataError, match="no RXM-RAWX"):
        (tmp_path / "empty.ubx").write_bytes(b"")
        read_ubx_raw_gnss(tmp_path / "empty.ubx")

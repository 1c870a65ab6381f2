"""u-blox raw measurement logs (``RXM-RAWX``, ``RXM-SFRBX``) as the raw GNSS sensor's
series, read with ``pyubx2``.

``RXM-RAWX`` gives each epoch's receiver time of week ``rcvTow`` [s], the full GPS week and,
per signal, the pseudorange ``prMes`` [m], the carrier phase ``cpMes`` [cycles], the
Doppler ``doMes`` [Hz] (positive approaching), C/N0 ``cno`` [dB-Hz] and the tracking
status (``prValid``).  GPS L1 C/A (``gnssId`` 0, ``sigId`` 0) is used; other systems and
signals are counted in ``quality`` (Galileo, BeiDou, GLONASS need their own navigation
messages: not decoded here).

``RXM-SFRBX`` gives each broadcast subframe as ten 32-bit words, the 30-bit GPS word in
bits 29..0 (24 data bits, then 6 parity; the data bits as transmitted, not inverted).
:func:`lnav_subframes` unpacks the data bits and :func:`decode_lnav` turns subframes 1, 2
and 3 of one issue of data into an ephemeris (IS-GPS-200 20.3.3.3 and 20.3.3.4: the scale
factors below, semicircles times ``GPS_PI`` in radians; the 10-bit week resolved with the
RAWX week, which does not roll over; toe and toc a week on when more than half a week
from the subframe's time of week).  Parity is not checked (the receiver decodes the words
it outputs).  Only L1 C/A subframes are read (``sigId`` 0: an F9's L2C CNAV messages are
skipped).  A log from which no measured satellite's ephemeris can be decoded is refused
in one line, unless a RINEX navigation file is given beside it; satellites without one
drop out (``quality["ubx_satellites_without_ephemeris"]``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .data import DataError, import_for, require_file
from .rinex import WEEK_S, Ephemerides, raw_series, read_rinex_nav

#: The value of pi that IS-GPS-200 fixes for semicircles.
GPS_PI = 3.1415926535898

#: (name, first bit, width, signed, scale) of the LNAV fields, bit 0 the first data bit of
#: word 1 (TLM) in the 24-data-bits-per-word packing; semicircle fields carry GPS_PI.
_SF1 = (("week", 48, 10, False, 1.0), ("health", 64, 6, False, 1.0),
        ("iodc_hi", 70, 2, False, 1.0), ("tgd", 160, 8, True, 2.0**-31),
        ("iodc_lo", 168, 8, False, 1.0), ("toc", 176, 16, False, 16.0),
        ("af2", 192, 8, True, 2.0**-55), ("af1", 200, 16, True, 2.0**-43),
        ("af0", 216, 22, True, 2.0**-31))
_SF2 = (("iode", 48, 8, False, 1.0), ("crs", 56, 16, True, 2.0**-5),
        ("delta_n", 72, 16, True, 2.0**-43 * GPS_PI), ("m0", 88, 32, True, 2.0**-31 * GPS_PI),
        ("cuc", 120, 16, True, 2.0**-29), ("e", 136, 32, False, 2.0**-33),
        ("cus", 168, 16, True, 2.0**-29), ("sqrt_a", 184, 32, False, 2.0**-19),
        ("toe", 216, 16, False, 16.0))
_SF3 = (("cic", 48, 16, True, 2.0**-29), ("omega0", 64, 32, True, 2.0**-31 * GPS_PI),
        ("cis", 96, 16, True, 2.0**-29), ("i0", 112, 32, True, 2.0**-31 * GPS_PI),
        ("crc", 144, 16, True, 2.0**-5), ("omega", 160, 32, True, 2.0**-31 * GPS_PI),
        ("omega_dot", 192, 24, True, 2.0**-43 * GPS_PI), ("iode", 216, 8, False, 1.0),
        ("idot", 224, 14, True, 2.0**-43 * GPS_PI))
LNAV_FIELDS = {1: _SF1, 2: _SF2, 3: _SF3}


def lnav_subframes(words) -> int:
    """The 240 data bits of a subframe (as one integer, bit 239 the first transmitted)
    from its ten words (each the 30-bit word right-aligned: data bits 29..6)."""
    out = 0
    for w in words:
        out = (out << 24) | ((int(w) >> 6) & 0xFFFFFF)
    return out


def _field(bits: int, first: int, width: int, signed: bool) -> int:
    v = (bits >> (240 - first - width)) & ((1 << width) - 1)
    return v - (1 << width) if signed and v >> (width - 1) else v


def subframe_id(bits: int) -> int:
    """The subframe's id (the HOW word's bits 20-22)."""
    return _field(bits, 24 + 19, 3, False)


def decode_fields(bits: int, which: int) -> dict[str, float]:
    """The fields of LNAV subframe ``which`` (1, 2 or 3) in SI (s, m, rad, rad/s)."""
    return {name: _field(bits, first, width, signed) * scale
            for name, first, width, signed, scale in LNAV_FIELDS[which]}


def decode_lnav(sf1: int, sf2: int, sf3: int, week: int) -> dict[str, float] | None:
    """One satellite's ephemeris from its subframes 1-3 (their data bits, one issue of
    data: IODC's low 8 bits = IODE of 2 = IODE of 3; None otherwise) and the full GPS
    ``week`` of a time near it (the 10-bit week resolved): the elements as
    :class:`~fednav.io.rinex.Ephemerides` holds them, with ``toc`` and ``toe`` in GPS
    time [s]."""
    a, b, c = decode_fields(sf1, 1), decode_fields(sf2, 2), decode_fields(sf3, 3)
    if not (int(a["iodc_lo"]) == int(b["iode"]) == int(c["iode"])):
        return None
    wk = int(a["week"]) + 1024 * round((week - int(a["week"])) / 1024)
    el = {k: v for d in (a, b, c) for k, v in d.items()
          if k not in ("week", "iodc_hi", "iodc_lo", "iode", "toc", "toe")}
    # toe and toc in the week of transmission, moved a week when more than half a week
    # from the subframe's time of week (an ephemeris sent late on Saturday for the next
    # week's start; RTKLIB's handover rule)
    tow = _field(sf1, 24, 17, False) * 6.0
    for key, v in (("toc", a["toc"]), ("toe", b["toe"])):
        shift = WEEK_S if v - tow < -WEEK_S / 2 else -WEEK_S if v - tow > WEEK_S / 2 else 0
        el[key] = wk * WEEK_S + v + shift
    return el


def _read(path: Path):
    pyubx2 = import_for(path, "pyubx2", "UBX")
    epochs: dict[float, dict[int, tuple]] = {}
    frames: dict[int, dict[int, int]] = {}  # sv -> {subframe id: bits} (latest)
    eph: dict[tuple[int, float], dict] = {}
    sets: list[tuple] = []  # (sv, subframe 1, 2, 3 bits) of each complete set
    counts = {"RXM-RAWX": 0, "RXM-SFRBX": 0, "other_signals": 0, "other_messages": 0,
              "errors": 0}
    week = None

    def err(e):
        counts["errors"] += 1

    with path.open("rb") as f:
        for _, m in pyubx2.UBXReader(f, protfilter=pyubx2.UBX_PROTOCOL, quitonerror=1,
                                     errorhandler=err):
            name = getattr(m, "identity", "")
            if name == "RXM-RAWX":
                counts[name] += 1
                week = int(m.week)
                t = round(week * WEEK_S + float(m.rcvTow), 6)
                ep = epochs.setdefault(t, {})
                for i in range(1, int(m.numMeas) + 1):
                    g = getattr(m, f"gnssId_{i:02d}")
                    if g != 0 or getattr(m, f"sigId_{i:02d}", 0) != 0:
                        counts["other_signals"] += 1
                        continue
                    if not getattr(m, f"prValid_{i:02d}", 1):
                        continue
                    ep[int(getattr(m, f"svId_{i:02d}"))] = (
                        float(getattr(m, f"prMes_{i:02d}")),
                        float(getattr(m, f"doMes_{i:02d}")),
                        float(getattr(m, f"cno_{i:02d}")))
            elif name == "RXM-SFRBX":
                counts[name] += 1
                # (GPS L1 C/A LNAV only: an F9's L2C CNAV messages are GPS too)
                if int(m.gnssId) != 0 or int(getattr(m, "sigId", 0)) != 0 or \
                        int(m.numWords) != 10:
                    continue
                sv = int(m.svId)
                bits = lnav_subframes([getattr(m, f"dwrd_{i:02d}") for i in range(1, 11)])
                sid = subframe_id(bits)
                if sid not in (1, 2, 3):
                    continue
                fr = frames.setdefault(sv, {})
                fr[sid] = bits
                if sid == 3 and 1 in fr and 2 in fr:
                    sets.append((sv, fr[1], fr[2], fr[3]))
            else:
                counts["other_messages"] += 1
    if week is not None:  # (decoded once the log's week is known: a log may start with them)
        for sv, a, b, c in sets:
            el = decode_lnav(a, b, c, week)
            if el is not None:
                eph[(sv, el["toe"])] = el
    return epochs, eph, counts


def _ephemerides(source: str, eph: dict) -> Ephemerides:
    keys = sorted(eph)
    el = {k: np.array([eph[i][k] for i in keys]) for k in eph[keys[0]]}
    toc, toe = el.pop("toc"), el.pop("toe")
    return Ephemerides(source, np.array([f"G{sv:02d}" for sv, _ in keys]), toc, toe, el)


def read_ubx_raw_gnss(path, *, nav=None, mask_deg: float = 10.0, t0: float | None = None):
    """A u-blox raw log's GPS L1 C/A measurements as the ``gnss_raw`` series (see the
    module docstring): pseudoranges, Dopplers and C/N0 of ``RXM-RAWX``, satellites from
    the LNAV ephemerides of the log's ``RXM-SFRBX`` — or of the RINEX navigation file
    ``nav`` when given (the log's own are then not needed).  Times are GPS time [s] less
    ``t0``.  No Klobuchar coefficients are decoded (subframe 4, page 18): without
    ``nav`` the ionosphere is left in the pseudoranges (metres; say so in the noise).

    Raises
    ------
    DataError
        One line: no file, no RXM-RAWX, or satellites measured without an ephemeris
        (naming them) and no ``nav``.
    """
    path = Path(path)
    require_file(path, "UBX log")
    epochs, eph, counts = _read(path)
    if not epochs:
        raise DataError(f"{path}: no RXM-RAWX message (enable the receiver's raw "
                        f"measurements: CFG-MSGOUT-UBX_RXM_RAWX)")
    t = np.array(sorted(epochs))
    svs = sorted({sv for ep in epochs.values() for sv in ep})
    if nav is not None:
        ephem = read_rinex_nav(nav)
    else:
        have = {sv for sv, _ in eph}
        missing = [sv for sv in svs if sv not in have]
        if not eph or len(missing) == len(svs):
            raise DataError(f"{path}: no GPS ephemeris decodable from RXM-SFRBX (subframes "
                            f"1-3 of one issue of data) for any satellite measured; enable "
                            f"CFG-MSGOUT-UBX_RXM_SFRBX or give a RINEX navigation file "
                            f"(nav=...)")
        ephem = _ephemerides(str(path), eph)
    pr = np.full((len(t), len(svs)), np.nan)
    dop, cn0 = pr.copy(), pr.copy()
    col = {sv: j for j, sv in enumerate(svs)}
    for i, ti in enumerate(t):
        for sv, (p, d, c) in epochs[ti].items():
            pr[i, col[sv]], dop[i, col[sv]], cn0[i, col[sv]] = p, d, c
    out = raw_series(str(path), t, pr, dop, cn0, np.array([f"G{sv:02d}" for sv in svs]),
                     ephem, mask_deg=mask_deg, t0=t0)
    out.quality.update({f"ubx_{k.lower().replace('-', '_')}": v for k, v in counts.items()})
    out.quality["ubx_ephemerides"] = len(eph)
    if nav is None:
        out.quality["ubx_satellites_without_ephemeris"] = [f"G{sv:02d}" for sv in missing]
    return out


__all__ = ["GPS_PI", "LNAV_FIELDS", "decode_fields", "decode_lnav", "lnav_subframes",
           "read_ubx_raw_gnss", "subframe_id"]

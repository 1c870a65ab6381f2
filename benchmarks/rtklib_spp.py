"""fednav's single-point positioning against RTKLIB's on the static GSI stations (issue
41's target: within 1.5x RTKLIB's own RMSE on the same files).

RTKLIB builds from its public source (github.com/tomojitakasu/RTKLIB; 2.4.2 p13, commit
71db0ffa: ``cd app/rnx2rtkp/gcc && make``).  Give its ``rnx2rtkp``; this script writes
the configuration both tools share — single point, GPS L1, 10 deg mask, broadcast
ephemeris, Klobuchar ionosphere, Saastamoinen troposphere (RTKLIB's single mode applies
neither model without it) — runs RTKLIB on each station, runs
``fednav.sensors.satellites.single_point`` on the same files, and prints the RMS of the
east, north and up errors against each file's header position (its quality is the
station header's: RTKLIB's own test places 3040 2.2 m from it).

    python benchmarks/rtklib_spp.py --rnx2rtkp PATH/rnx2rtkp [--data DIR]
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
from pathlib import Path

import numpy as np

CONF = """pos1-posmode=single
pos1-frequency=l1
pos1-navsys=1
pos1-elmask=10
pos1-ionoopt=brdc
pos1-tropopt=saas
pos1-sateph=brdc
out-outopt=on
"""


def _enu_rms(xyz, ref) -> np.ndarray:
    from fednav.core import earth

    lat, lon, _ = earth.ecef_to_llh(np.asarray(ref, dtype=float))
    R = earth.enu_to_ecef(lat, lon)  # columns: east, north, up in ECEF
    enu = (np.asarray(xyz) - ref) @ R
    return np.sqrt(np.nanmean(enu**2, axis=0))


def _rtklib(exe: str, obs: Path, nav: Path, folder: Path) -> np.ndarray:
    conf = folder / "spp.conf"
    conf.write_text(CONF)
    out = folder / f"{obs.stem}.pos"
    subprocess.run([exe, "-k", str(conf), "-p", "0", "-f", "1", "-m", "10", "-e", "-o",
                    str(out), str(obs), str(nav)], check=True, capture_output=True)
    rows = [line.split() for line in out.read_text().splitlines()
            if line.strip() and not line.startswith("%")]
    return np.array([[float(r[2]), float(r[3]), float(r[4])] for r in rows])


def main() -> None:
    from fednav.io import read_rinex_nav, read_rinex_obs
    from fednav.sensors.satellites import single_point

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rnx2rtkp", required=True)
    ap.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[2]
                    / "shared" / "data" / "rinex-static")
    args = ap.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="fednav-rtklib-"))
    print(f"{'station':>7} {'RTKLIB E/N/U [m]':>22} {'fednav E/N/U [m]':>22} "
          f"{'ratio horizontal':>17} {'ratio up':>9} {'ratio 3-D':>9}")
    for station in ("0759", "3040"):
        obs_p, nav_p = args.data / f"{station}0920.05o", args.data / f"{station}0920.05n"
        obs, nav = read_rinex_obs(obs_p), read_rinex_nav(nav_p)
        a = _enu_rms(_rtklib(args.rnx2rtkp, obs_p, nav_p, folder), obs.approx_xyz)
        b = _enu_rms(single_point(obs.t, obs.code("C1"), obs.sv, nav).xyz, obs.approx_xyz)
        print(f"{station:>7} {'/'.join(f'{v:.2f}' for v in a):>22} "
              f"{'/'.join(f'{v:.2f}' for v in b):>22} "
              f"{np.hypot(*b[:2]) / np.hypot(*a[:2]):>17.2f} {b[2] / a[2]:>9.2f} "
              f"{np.linalg.norm(b) / np.linalg.norm(a):>9.2f}")


if __name__ == "__main__":
    main()

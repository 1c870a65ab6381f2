"""Near the poles and across +-180 deg: the mechanization and INS/GNSS against a truth
generated in ECEF (:func:`fednav.sim.great_circle.great_circle`), which owes nothing to
the ENU mechanization.

Run by hand: ``python benchmarks/polar.py`` (pure INS, ~10 s) and
``python benchmarks/polar.py --process`` (INS/GNSS through ``fednav.process.process``,
~1 min per case; ``--only 89.9`` picks cases by name).  Errors are frame-free: position
and velocity as ECEF vectors, attitude as the angle between the ``C_b^e`` of solution and
truth.  Flights: 600 s great circles at 250 m/s and 1 km height whose midpoint is the
track's highest latitude; ideal IMU for the mechanization; for INS/GNSS a 1 deg/h,
0.1 mg IMU (seeded) and 1 Hz fixes with 1 m / 0.05 m/s noise.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from fednav import System
from fednav.core import attitude as att
from fednav.core import earth, units
from fednav.ins.strapdown import Strapdown
from fednav.process import process
from fednav.sim.great_circle import great_circle, recorded

#: name, midpoint latitude, longitude [deg], course [deg], GNSS longitudes in 0..360
CASES = [("lat 45 (control)", 45.0, 10.0, 90.0, False),
         ("lat 60 across 180", 60.0, 180.0, 90.0, False),
         ("lat -60 across 180 westward", -60.0, 180.0, 270.0, False),
         ("lat 60 GNSS in 0..360", 60.0, -170.0, 90.0, True),
         ("lat 89.0 across 180", 89.0, 180.0, 90.0, False),
         ("lat 89.9 lon 0", 89.9, 0.0, 90.0, False),
         ("lat 89.9 across 180", 89.9, 180.0, 90.0, False),
         ("lat -89.9 across 180 westward", -89.9, 180.0, 270.0, False),
         ("lat 89.9 GNSS in 0..360", 89.9, 0.0, 90.0, True),
         ("lat 89.99 across 180", 89.99, 180.0, 90.0, False),
         ("over the north pole", 90.0 - 1e-7, 0.0, 0.0, False)]


def errors(lla, vel, C, tr, k):
    """Position [m], velocity [m/s] and attitude [arcsec] errors against the truth rows
    ``k``, frame-free (ECEF)."""
    lt = tr.lla[k]
    dp = earth.llh_to_ecef(*lla.T) - earth.llh_to_ecef(*lt.T)
    Cn, Ct = earth.enu_to_ecef(lla[:, 0], lla[:, 1]), earth.enu_to_ecef(lt[:, 0], lt[:, 1])
    dv = np.einsum("kij,kj->ki", Cn, vel) - np.einsum("kij,kj->ki", Ct, tr.vel[k])
    E = (Cn @ C) @ np.swapaxes(Ct @ tr.dcm[k], -1, -2)
    ang = np.arccos(np.clip((np.trace(E, axis1=1, axis2=2) - 1) / 2, -1, 1))
    return np.linalg.norm(dp, axis=1), np.linalg.norm(dv, axis=1), units.to_arcsec(ang)


def flight(lat, lon, hdg, duration=600.0):
    return great_circle(np.array([units.deg(lat), units.deg(lon), 1000.0]), units.deg(hdg),
                        250.0, duration, 0.01)


def mechanization(tr) -> str:
    out = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt).run(tr.dtheta, tr.dv)
    dp, dv, da = errors(out["lla"], out["vel"], att.quat_to_dcm(out["q"]), tr,
                        np.arange(1, len(tr.t)))
    lat, lon = np.degrees(out["lla"][:, 0]), np.degrees(out["lla"][:, 1])
    return (f"pos {dp.max():9.3f} m  vel {dv.max():8.4f} m/s  att {da.max():8.2f} arcsec  "
            f"lon [{lon.min():.1f}, {lon.max():.1f}]  max lat {lat.max():.4f}")


def ins_gnss(tr, lon360: bool, seed: int = 3) -> str:
    imu, gnss = recorded(tr, np.random.default_rng(seed), lon_0_360=lon360)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = process(imu, {"gnss": gnss}, System(), force=True)
    sol = res.forward
    k = np.rint(sol.t / tr.dt).astype(int)
    later = sol.t > 60.0
    dp, _, da = errors(sol.lla[later], sol.vel[later], att.euler_to_dcm(sol.euler[later]),
                       tr, k[later])
    nis = [w.split(" times")[0].split("are ")[-1] for w in res.warnings if "mean NIS" in w]
    return (f"after 60 s: pos max {dp.max():10.2f} m rms {np.sqrt(np.mean(dp**2)):9.2f} m  "
            f"att max {da.max() / 60:8.2f} arcmin  mean NIS/dof warning: {nis or 'none'}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--process", action="store_true", help="INS/GNSS instead of pure INS")
    ap.add_argument("--only", default="", help="cases whose name contains this")
    a = ap.parse_args()
    for name, lat, lon, hdg, lon360 in CASES:
        if a.only not in name or (lon360 and not a.process):
            continue
        tr = flight(lat, lon, hdg)
        print(f"{name:32s}", ins_gnss(tr, lon360) if a.process else mechanization(tr),
              flush=True)


if __name__ == "__main__":
    main()

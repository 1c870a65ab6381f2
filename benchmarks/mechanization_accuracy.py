"""Ideal-IMU mechanization accuracy on the paper-002 flight and the Schuler period.

Run by hand: ``python benchmarks/mechanization_accuracy.py``.
"""

import numpy as np

from fednav.core import attitude as att
from fednav.core import earth, units
from fednav.ins.strapdown import BaroLoop, Strapdown
from fednav.scenarios import paper002
from fednav.sim.trajectory import Segment, generate


def paper002_flight():
    tr = paper002.load_scenario().trajectory()
    out = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt).run(tr.dtheta, tr.dv)
    lla = out["lla"]
    dp = earth.llh_difference_enu(lla[:, 0], lla[:, 1], lla[:, 2], *tr.lla[1:].T)
    dv = out["vel"] - tr.vel[1:]
    phi = att.misalignment(tr.dcm[1:], att.quat_to_dcm(out["q"]))
    print(f"paper-002 flight, {tr.t[-1]:.0f} s, ideal IMU, free vertical channel: max |error| "
          f"position {np.abs(dp).max():.4f} m, velocity {np.abs(dv).max():.2e} m/s, "
          f"attitude {units.to_arcsec(np.abs(phi).max()):.2e} arcsec")


def schuler():
    lat = units.deg(39.0)
    tr = generate([lat, units.deg(117.0), 0.0], 0.0, [0, 0, 0], [Segment(6000.0)], 0.1)
    ins = Strapdown(tr.lla[0], [0.0, 0.1, 0.0], tr.euler[0], 0.1, baro=BaroLoop(10.0, 3))
    vn = ins.run(tr.dtheta, tr.dv, h_ref=tr.lla[:-1, 2])["vel"][:, 1]
    zc = tr.t[1:][np.flatnonzero(np.sign(vn[1:]) != np.sign(vn[:-1]))]
    print(f"Schuler: velocity-error period {2 * (zc[1] - zc[0]) / 60:.2f} min "
          f"(theory 2*pi*sqrt(R/g) = 84.4 min)")


if __name__ == "__main__":
    paper002_flight()
    schuler()

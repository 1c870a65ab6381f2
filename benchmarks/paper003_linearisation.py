"""How nonlinear is paper 003's time update?  Covariance through the total-state UKF vs
the linear error model (Phi P Phi') at the flight's largest uncertainty (the initial
0.5 deg attitude error), during a manoeuvre.

Run by hand: ``python benchmarks/paper003_linearisation.py``.
"""

import numpy as np

from fednav.core import attitude as att
from fednav.ins import error_model as em
from fednav.ins.strapdown import Strapdown
from fednav.ins.total_state import TotalStateUKF
from fednav.sim.trajectory import Segment, generate


def main():
    tr = generate([0.5, 2.0, 1000.0], 150.0, [0.05, 0.4, 1.0],
                  [Segment(1.0, accel=1.0, pitch_rate=0.01, heading_rate=0.03)], 0.02)
    C = att.euler_to_dcm(tr.euler[25])
    nom = em.Nominal(lat=tr.lla[25, 0], h=tr.lla[25, 2], vel=tr.vel[25], C=C,
                     fn=C @ tr.dv.sum(axis=0))
    Phi = em.ErrorProcess(nom, 1.0, em.ImuNoiseModel()).Phi[:9, :9]
    for att_sd_arcmin in (30.0, 1.0):
        sd = np.array([att_sd_arcmin] * 3 + [0.1] * 3 + [5.0] * 3)
        P0 = np.diag(sd**2)
        lin = Phi @ P0 @ Phi.T
        # the filter carries the 6 IMU-error states too (15 states): a negligible bias
        # variance (it must be positive definite); the navigation block is compared
        P15 = np.zeros((15, 15))
        P15[:9, :9] = P0
        P15[9:, 9:] = 1e-12 * np.eye(6)
        for alpha in (1e-3, 1.0):
            f = TotalStateUKF(Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt), P15,
                              np.zeros((6, 6)), alpha=alpha)
            f.predict(tr.dtheta, tr.dv)
            rel = np.abs(f.P[:9, :9] - lin).max() / np.abs(lin).max()
            print(f"attitude sigma {att_sd_arcmin:5.1f} arcmin, alpha {alpha:g}: "
                  f"max |P_ukf - Phi P Phi'| / max |P| = {rel:.2e}")


if __name__ == "__main__":
    main()

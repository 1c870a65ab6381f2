"""A 24-hour SINS/CNS/SAR flight (run by hand: ``python benchmarks/day_flight.py [--hours H]``).

``--forms``: the 24-hour star-sensor mission instead, standard vs square-root filters
side by side (``python benchmarks/day_flight.py --forms [--hours H]``): a 3 arcsec star
sensor every 1 s, SAR every 5 s, P0 (and the drawn initial error) with a 1 deg attitude
sigma, UKF local filters and master (``filter.form: standard`` / ``square_root``).  Per
hour and form: the fused covariance's condition number and smallest eigenvalue (filter
units), each local filter's mean NIS/dof; at the end the attitude and position errors.

Paper 002's system (federated UKF, star sensor and SAR every 5 s, baro loop) on a cruise
of ``--hours`` hours (the paper's climb, then level cruise east at 400 m/s, 100 Hz IMU:
once around the Earth along 39 deg N).
Reports whether the numerics stay steady: the filter's 1-sigma in filter units
(largest/smallest ratio over the states; its square bounds the condition of the
diagonal) and the navigation errors in the first and the last hour. (The INS quaternion
is renormalised every IMU sample and after every feedback, so its norm is 1 to rounding
by construction.)
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd


def _day_scenario(hours: float):
    """Paper 002's scenario flown east for ``hours`` (climb, then level cruise in one-hour
    pieces)."""
    from fednav.scenarios import paper002

    scn = paper002.load_scenario()
    segs = list(scn.segments[:3])
    # one-hour pieces: the truth integrator works segment by segment
    total = hours * 3600.0 - 60.0
    pieces = [min(3600.0, total - k * 3600.0) for k in range(int(np.ceil(total / 3600.0)))]
    cruise = [scn.segments[3].model_copy(update={"duration_s": d, "name": f"cruise {k}"})
              for k, d in enumerate(pieces)]
    # heading east: a day at 400 m/s on the paper's 45 deg heading would reach the pole
    start = scn.start.model_copy(update={"heading_deg": 90.0})
    return scn.model_copy(update={"segments": [*segs, *cruise], "start": start})


def forms(hours: float) -> None:
    """The star-sensor mission, standard vs square-root (module docstring)."""
    from fednav.core import attitude as att
    from fednav.core import earth, units
    from fednav.ins.strapdown import STATE_LLA, STATE_Q
    from fednav.navigator.navigator import Navigator
    from fednav.sim.runs import _initial_state, make_run_data
    from fednav.sim.scenario import ModeConfig

    scn = _day_scenario(hours)
    star = scn.sensors["star"].model_copy(update={"period_s": 1.0, "sigma_arcsec": 3.0})
    scn = scn.model_copy(update={
        "sensors": scn.sensors.replace(star=star),
        "initial_errors": scn.initial_errors.model_copy(
            update={"attitude_arcsec": [3600.0, 3600.0, 3600.0]})})
    t0 = time.perf_counter()
    truth = scn.trajectory()
    data = make_run_data(scn, 1)
    print(f"{hours:g} h star-sensor mission (3 arcsec star every 1 s, SAR every 5 s, P0 "
          f"1 deg attitude, UKF locals + master), {len(truth.t) - 1} IMU samples; truth "
          f"and data {time.perf_counter() - t0:.0f} s", flush=True)
    out = {}
    for form in ("standard", "square_root"):
        s = scn.model_copy(update={"filter": scn.filter.model_copy(update={"form": form})})
        system = s.system_for(ModeConfig(name="SINS/CNS/SAR", aiding=["star", "sar"]))
        nav = Navigator(system, _initial_state(s, truth, data), truth.dt, record_rows=False,
                        record_covariance=False)
        for a in ("star", "sar", "baro"):
            nav.add_series(data.series[a])
        t1 = time.perf_counter()
        m = len(truth.t) - 1
        nav.add_imu(truth.t[:-1], dtheta=data.dtheta[:m], dv=data.dv[:m])
        res = nav.result()
        secs = time.perf_counter() - t1
        out[form] = (res, secs)
        print(f"{form}: {res.engine} engine, {secs:.0f} s", flush=True)
    print(f"{'hour':>4s} | {'form':11s} | {'max cond P':>10s} | {'min eig P':>10s} | "
          f"{'NIS/dof star':>12s} | {'NIS/dof sar':>11s}")
    n_hours = int(np.ceil(hours))
    summary = {}
    for form, (res, _) in out.items():
        fdi = pd.DataFrame(res.fdi, columns=["t", "local", "nis", "dof", "thr", "iso"])
        every = max(1, int(round(60.0 / (res.t[1] - res.t[0]))))   # eigenvalues each minute
        idx = np.arange(1, len(res.t), every)
        ev = np.linalg.eigvalsh(res.P[idx])
        hour = (res.t[idx] - res.t[0]) // 3600.0
        rows = []
        for h in range(n_hours):
            sel = hour == h
            f = fdi[(fdi.t - res.t[0]) // 3600.0 == h]
            nis = {k: float((g.nis / g.dof).mean()) for k, g in f.groupby("local")}
            cond = float((ev[sel, -1] / ev[sel, 0]).max()) if sel.any() else np.nan
            lo = float(ev[sel, 0].min()) if sel.any() else np.nan
            rows.append((h, cond, lo, nis.get("star", np.nan), nis.get("sar", np.nan)))
        summary[form] = rows
    for h in range(n_hours):
        for form in out:
            _, cond, lo, ns, na = summary[form][h]
            print(f"{h:4d} | {form:11s} | {cond:10.3g} | {lo:10.3g} | {ns:12.3f} | {na:11.3f}")
    for form, (res, secs) in out.items():
        idx = np.searchsorted(truth.t, res.t[-1] - 1e-9)
        st = res.states[-1]
        lla, q = st[STATE_LLA], st[STATE_Q]
        tl = truth.lla[idx]
        dp = earth.llh_difference_enu(lla[0], lla[1], lla[2], tl[0], tl[1], tl[2])
        da = att.misalignment(att.euler_to_dcm(truth.euler[idx]), att.quat_to_dcm(q))
        fdi = pd.DataFrame(res.fdi, columns=["t", "local", "nis", "dof", "thr", "iso"])
        r = fdi.nis / fdi.dof
        print(f"{form}: final position error {np.round(dp, 2)} m, attitude error "
              f"{np.round(units.to_arcsec(da), 2)} arcsec; NIS/dof over the flight "
              f"{r.mean():.3f} (hourly {min(min(x[3], x[4]) for x in summary[form]):.3f}"
              f" .. {max(max(x[3], x[4]) for x in summary[form]):.3f}); all finite "
              f"{bool(np.isfinite(res.states).all() and np.isfinite(res.P).all())}; "
              f"{secs:.0f} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hours", type=float, default=24.0)
    ap.add_argument("--forms", action="store_true",
                    help="the star-sensor mission, standard vs square-root filters")
    args = ap.parse_args()
    if args.forms:
        forms(args.hours)
        return
    from fednav.core import units
    from fednav.scenarios import paper002
    from fednav.sim.runs import make_run_data, run_configured_mode

    scn = paper002.load_scenario()
    segs = list(scn.segments[:3])
    # one-hour pieces: the truth integrator works segment by segment
    total = args.hours * 3600.0 - 60.0
    pieces = [min(3600.0, total - k * 3600.0) for k in range(int(np.ceil(total / 3600.0)))]
    cruise = [scn.segments[3].model_copy(update={"duration_s": d, "name": f"cruise {k}"})
              for k, d in enumerate(pieces)]
    # heading east: a day at 400 m/s on the paper's 45 deg heading would reach the pole
    start = scn.start.model_copy(update={"heading_deg": 90.0})
    scn = scn.model_copy(update={"segments": [*segs, *cruise], "start": start})
    mode = next(m for m in scn.modes if m.name == "SINS/CNS/SAR")
    t0 = time.perf_counter()
    tr = scn.trajectory()
    t1 = time.perf_counter()
    data = make_run_data(scn, 1)
    res = run_configured_mode(scn, mode, data)
    t2 = time.perf_counter()
    hour = res.t < 3600.0
    last = res.t > res.t[-1] - 3600.0
    from fednav.ins import error_model as em

    s = res.sigma / em.SCALE                      # filter units, as the filter holds them
    s = s[:, ~np.all(np.isnan(s), axis=0)]
    ratio = s.max(axis=1) / s.min(axis=1)
    print(f"{args.hours:g} h flight, {len(tr.t) - 1} IMU samples: truth {t1 - t0:.0f} s, "
          f"SINS/CNS/SAR run {t2 - t1:.0f} s")
    for name, m in (("first hour", hour), ("last hour", last)):
        print(f"{name}: position error RMS {np.sqrt(np.mean(res.pos[m] ** 2, axis=0))} m, "
              f"attitude RMS {units.to_arcsec(np.sqrt(np.mean(res.att[m] ** 2, axis=0)))} arcsec, "
              f"sigma max/min {ratio[m].max():.3g}")
    print(f"all finite: {np.isfinite(res.pos).all() and np.isfinite(res.att).all()}; "
          f"sigma max/min over the day {ratio.min():.3g} .. {ratio.max():.3g}")


if __name__ == "__main__":
    main()

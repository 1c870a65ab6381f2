"""Fault isolation that cannot lock out the last position source (issue 27, item 2):
the figures of docs/reliability.md, "Re-admitting the last position source".

    python benchmarks/readmission.py [seeds]        (default 10 seeds; ~1 min)

Side by side on fednav's simulated car drive (:func:`fednav.sim.drives.car_drive`,
ADIS16405-class IMU, 5 Hz GNSS, ``fdi_alpha: 0.001``), per seed:

* **overconfident**: the filter's IMU figures 30x (and 100x) too small — chi-square fault
  detection locks out a sound GNSS;
* **true fault**: the figures right, the receiver jumps 200 m east (and 20 m) at 50 s and
  stays there;

each with ``filter.fdi_readmit_s`` off (None) and at its default, reporting the largest
horizontal error after 50 s, the re-admissions and the share of GNSS fixes isolated.  With
``../shared/data/canada-planetary`` present, the real rover with its file's IMU figures
and ``fdi_alpha: 0.001`` (which locked the GNSS out from 6 s to the end) too.

Then the same two cases **tightly coupled** (``gnss_raw``: each satellite's pseudorange and
range rate, compared satellite by satellite as they rise and set): the car-grade drive of
``benchmarks/tight_coupling.py`` (100 Hz MEMS, 1 Hz raw GNSS, the whole sky), the
filter's figures 30x too small, or right with the receiver's position jumping 200 m east
at 100 s and staying (every pseudorange moved along its line of sight).
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from fednav.core import earth
from fednav.navigator.system import FilterConfig
from fednav.process.run import prepare, solution
from fednav.sim.drives import car_drive

ROOT = Path(__file__).resolve().parents[1]
ROVER = ROOT.parent / "shared" / "data" / "canada-planetary"
DEFAULT = FilterConfig().fdi_readmit_s
FIGURES = ("gyro_bias_radps", "gyro_markov_radps", "gyro_arw_rad_sqrt_s", "accel_bias_mps2",
           "accel_markov_mps2", "accel_vrw_mps_sqrt_s")


def flown(imu, gnss, system, hold):
    """The navigator's result and forward solution with ``fdi_alpha: 0.001`` and
    ``fdi_readmit_s: hold``."""
    f = system.filter.model_copy(update={"fdi_alpha": 0.001, "fdi_readmit_s": hold})
    prep = prepare(imu, {"gnss": gnss}, system.model_copy(update={"filter": f}))
    out = prep.feed(prep.navigator(record_rows=True, record_covariance=True)).result()
    return out, solution(out, prep, False).forward


def horizontal_error(sol, t, lla) -> np.ndarray:
    """|horizontal| error [m] of the solution at the reference times ``t``."""
    m = (t >= sol.t[0]) & (t <= sol.t[-1])
    p = np.column_stack([np.interp(t[m], sol.t, sol.lla[:, j]) for j in range(3)])
    d = earth.llh_difference_enu(*p.T, *lla[m].T)
    return np.hypot(d[:, 0], d[:, 1])


def drive_case(seed: int, case: str):
    """(imu, gnss, reference, system) of one case of one seed."""
    d = car_drive(seed=seed, static_s=10.0)
    imu, gnss, system = d.imu, d.gnss, d.system
    if case.startswith("overconfident"):
        k = float(case.split("x")[-1])
        figs = {n: getattr(system.imu, n) / k for n in FIGURES}
        system = system.model_copy(update={"imu": system.imu.model_copy(update=figs)})
        imu = replace(imu, errors=None)
    else:  # a receiver jump that stays
        size = float(case.split("jump")[-1].rstrip("m"))
        lla = gnss.lla.copy()
        off = gnss.t >= 50.0
        lla[off] = earth.move_enu(lla[off], np.array([size, 0.0, 0.0]))
        gnss = replace(gnss, lla=lla, quality={})
    return imu, gnss, d.reference, system


def tight_case(seed: int, case: str, hold):
    """One tightly coupled run (module docstring) of ``case`` ("overconfident x30" or
    "true fault jump200m"), ``fdi_alpha: 0.001``, ``fdi_readmit_s: hold``: the horizontal
    error per filter epoch [m], the epochs' times [s] and the navigator's result."""
    import tempfile

    from fednav.navigator.navigator import Navigator
    from fednav.sensors.gnss_raw import FIELDS, PR, SLOTS, SX, SZ
    from fednav.sim.runs import _initial_state, _result, make_run_data
    from fednav.sim.scenario import ModeConfig

    if str(ROOT / "benchmarks") not in sys.path:
        sys.path.insert(0, str(ROOT / "benchmarks"))
    import tight_coupling

    with tempfile.TemporaryDirectory(prefix="fednav-readmit-") as folder:
        scn = tight_coupling._scenario(Path(folder), 14, "tcxo")  # (the whole sky)
    data = make_run_data(scn, seed)
    truth = scn.trajectory(None)
    system = scn.system_for(ModeConfig(name="tight", aiding=["gnss_raw"]))
    f = system.filter.model_copy(update={"fdi_alpha": 0.001, "fdi_readmit_s": hold})
    system = system.model_copy(update={"filter": f})
    if case.startswith("overconfident"):
        k = float(case.split("x")[-1])
        figs = ("gyro_bias_deg_h", "gyro_markov_deg_h", "gyro_arw_deg_sqrt_h",
                "accel_bias_ug", "accel_markov_ug", "accel_vrw_ug_sqrt_hz")
        system = system.model_copy(update={"imu": system.imu.model_copy(
            update={n: getattr(system.imu, n) / k for n in figs})})
    else:  # the receiver's position jumps east and stays: each pseudorange moves by -u.d
        size = float(case.split("jump")[-1].rstrip("m"))
        s = data.series["gnss_raw"]
        z = s.z.reshape(len(s.t), SLOTS, len(FIELDS)).copy()
        lla = np.column_stack([np.interp(s.t, truth.t, truth.lla[:, j]) for j in range(3)])
        r = np.array([earth.llh_to_ecef(*p) for p in lla])
        east = np.array([earth.enu_to_ecef(a, b)[:, 0] for a, b, _ in lla]) * size
        u = z[:, :, SX:SZ + 1] - r[:, None, :]
        u /= np.linalg.norm(u, axis=2)[:, :, None]
        k = s.t >= 100.0
        z[k, :, PR] -= np.einsum("nsj,nj->ns", u[k], east[k])  # (NaN slots stay NaN)
        data = replace(data, series=dict(data.series, gnss_raw=replace(
            s, z=z.reshape(len(s.t), -1))))
    nav = Navigator(system, _initial_state(scn, truth, data), truth.dt)
    nav.add_series(data.series["gnss_raw"])
    m = len(truth.t) - 1
    nav.add_imu(truth.t[:-1], dtheta=data.dtheta[:m], dv=data.dv[:m])
    res = nav.result()
    out = _result(scn, truth, round(scn.filter.period_s / truth.dt), res.states[1:], "t",
                  res.sigma[1:], res.beta, res.fdi)
    return np.hypot(out.pos[:, 0], out.pos[:, 1]), out.t, res


def loose_flight(seed: int, case: str, hold):
    """One loosely coupled run (:func:`drive_case`): largest horizontal error after 50 s
    [m], NaN (no end figure), re-admissions, share of GNSS fixes isolated."""
    imu, gnss, ref, system = drive_case(seed, case)
    out, sol = flown(imu, gnss, system, hold)
    late = ref.t > 50.0
    return (horizontal_error(sol, ref.t[late], ref.lla[late]).max(), np.nan,
            len(out.readmissions), np.mean([e[5] for e in out.fdi]))


def tight_flight(seed: int, case: str, hold):
    """One tightly coupled run (:func:`tight_case`): largest horizontal error after 100 s
    and at the end [m], re-admissions, share of epochs isolated."""
    h, t, res = tight_case(seed, case, hold)
    return (h[t > 100.0].max(), h[-1], len(res.readmissions),
            np.mean([e[5] for e in res.fdi]))


def table(flight, cases, seeds: int, end: bool) -> None:
    """Per case, guard off and at its default: median and worst largest error (and the
    median at the end), re-admissions, runs with any, share isolated."""
    for case in cases:
        for hold in (None, DEFAULT):
            err, last, n_ep, iso = np.array([flight(seed, case, hold)
                                             for seed in range(1, seeds + 1)]).T
            tail = f"  end {np.median(last):8.1f}" if end else ""
            print(f"  {case:20s} fdi_readmit_s {hold!s:5s}: error {np.median(err):9.1f} "
                  f"{err.max():9.1f}{tail}  re-admissions {int(n_ep.sum()):3d} "
                  f"(runs with any: {int((n_ep > 0).sum())}/{seeds})  isolated "
                  f"{100 * iso.mean():5.1f} %")


def main(seeds: int = 10) -> None:
    print(f"fdi_readmit_s default {DEFAULT} s; {seeds} seeds; max horizontal error after "
          f"50 s [m] (median, worst), re-admissions, GNSS isolated")
    table(loose_flight, ("overconfident x30", "overconfident x100", "true fault jump200m",
                         "true fault jump20m"), seeds, end=False)
    print("tightly coupled (gnss_raw, car-grade MEMS, 1 Hz); max horizontal error after "
          "100 s [m] (median, worst), at the end (median), re-admissions, isolated")
    table(tight_flight, ("overconfident x30", "true fault jump200m"), seeds, end=True)
    if not ROVER.is_dir():
        print("rover: ../shared/data/canada-planetary not found (skipped)")
        return
    from fednav import System
    from fednav.io import read_navego_gnss, read_navego_imu, read_navego_reference

    imu = read_navego_imu(ROVER / "imu_planetary.mat")
    gnss = read_navego_gnss(ROVER / "gnss_planetary.mat")
    ref = read_navego_reference(ROVER / "gnss_planetary_r.mat")
    print("rover, the file's IMU figures, fdi_alpha 0.001: horizontal error [m]")
    for hold in (None, 2.0, DEFAULT, 7.0, 10.0, 20.0, 30.0):
        out, sol = flown(imu, gnss, System(), hold)
        h = horizontal_error(sol, ref.t, ref.lla)
        print(f"  fdi_readmit_s {hold!s:5s}: max {h.max():10.1f}  final {h[-1]:9.1f}  rms "
              f"{np.sqrt(np.mean(h ** 2)):9.2f}  re-admissions {len(out.readmissions):2d}  "
              f"GNSS isolated {100 * np.mean([e[5] for e in out.fdi]):5.1f} %")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)

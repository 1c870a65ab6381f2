"""Satellite positions and clocks from broadcast ephemerides: fednav's
(:func:`fednav.sensors.satellites.satellite_states`) against a second implementation,
gnss_lib_py's (Stanford NAV Lab, ``gnss_lib_py.utils.sv_models.find_sv_states``).

    python -m venv /tmp/glp && . /tmp/glp/bin/activate && pip install -e . gnss-lib-py
    python benchmarks/satellite_positions.py [NAV ...]

(gnss-lib-py is not a dependency of fednav: it pins older georinex and xarray, with which
georinex no longer reads RINEX observation files under numpy 2 — a virtual environment
of its own keeps fednav's.)

Default: the two GSI stations' navigation files of ``../shared/data/rinex-static``.  Each
record of a file is evaluated by both at times from 2 h before to 2 h after its ``toe``
(every 10 min), and the differences of the ECEF positions [m] (at the same instant, no
Earth rotation applied by either), velocities [m/s] and clock offsets [m] are
printed.  gnss_lib_py reads the file with georinex as fednav does; the orbit and clock
computations are its own.  Clocks (relativistic term and ``-TGD`` on both sides, fednav's
``l1_only=True``) are compared where both take the same clock epoch and the time is in
the record's week: gnss_lib_py takes the clock epoch ``t_oc`` as a time of week from the
record's ``toe`` side where the file's epoch line differs (a few records here), and its
week-crossing guard (``np.abs(t_offset).any() > 302400``) never fires, so across the end
of a week its clock is off by the drift over a week; those evaluations are counted apart.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
STATIC = ROOT.parent / "shared" / "data" / "rinex-static"


def compare(path: Path) -> dict:
    import gnss_lib_py as glp
    from gnss_lib_py.utils.sv_models import find_sv_states

    from fednav.io.rinex import read_rinex_nav
    from fednav.sensors.satellites import C, satellite_states

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        theirs = glp.RinexNav(str(path))
    ours = read_rinex_nav(path)
    # the same record on both sides: satellite and toe
    sv = np.array([f"G{int(s):02d}" for s in theirs["sv_id"]])
    toe = np.asarray(theirs["gps_week"], float) * 604800.0 + np.asarray(theirs["t_oe"], float)
    idx = np.array([int(np.flatnonzero((ours.sv == s) & (np.abs(ours.toe - e) < 0.5))[0])
                    for s, e in zip(sv, toe, strict=True)])
    worst = {"position_m": 0.0, "velocity_mps": 0.0, "clock_m": 0.0}
    n = apart = 0
    same_epoch = np.abs(np.mod(ours.toc[idx], 604800.0)
                        - np.asarray(theirs["t_oc"], float)) < 0.5
    for dt in np.arange(-7200.0, 7201.0, 600.0):
        t = toe + dt
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s = find_sv_states(t * 1000.0, theirs)
        p = np.column_stack([s["x_sv_m"], s["y_sv_m"], s["z_sv_m"]])
        v = np.column_stack([s["vx_sv_mps"], s["vy_sv_mps"], s["vz_sv_mps"]])
        pos, vel, clk, _ = satellite_states(ours, idx, t, l1_only=True)
        worst["position_m"] = max(worst["position_m"], float(np.abs(pos - p).max()))
        worst["velocity_mps"] = max(worst["velocity_mps"], float(np.abs(vel - v).max()))
        ok = same_epoch & (np.floor(t / 604800.0) == np.floor(toe / 604800.0))
        if ok.any():
            worst["clock_m"] = max(worst["clock_m"],
                                   float(np.abs(C * clk - s["b_sv_m"])[ok].max()))
        n += len(t)
        apart += int((~ok).sum())
    return {"records": len(idx), "evaluations": n, "clocks_apart": apart, **worst}


def main() -> None:
    paths = [Path(a) for a in sys.argv[1:]] or sorted(STATIC.glob("*.05n"))
    if not paths:
        sys.exit(f"no navigation file given and none in {STATIC}")
    print("largest |fednav - gnss_lib_py| over each file's records, toe -2 h .. +2 h")
    for p in paths:
        r = compare(p)
        print(f"  {p.name}: {r['records']} records, {r['evaluations']} evaluations: "
              f"position {r['position_m'] * 1e3:.3f} mm, velocity "
              f"{r['velocity_mps'] * 1e3:.3f} mm/s, clock {r['clock_m'] * 1e3:.3f} mm "
              f"({r['clocks_apart']} clock evaluations apart: another clock epoch or "
              f"week)")


if __name__ == "__main__":
    main()

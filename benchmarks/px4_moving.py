"""fednav's PX4 path on a moving vehicle with GNSS withheld, against an independent truth
(issue 38 item 7).

    python benchmarks/px4_moving.py [--out DIR] [--seed 38] [--seeds N] [--json FILE]

Builds the simulated flight of ``benchmarks/px4_flight.py`` (closed-form motion, no fednav
code: 300 s, a climb and a figure of eight at 11-18 m/s; GNSS withheld 120-160 s by
leaving the fixes out of the log) as a ULog file, runs

    fednav process ulog flight.ulg --out DIR/preset                 # as a user would
    fednav process ulog flight.ulg --config imu.yaml --out DIR/imu  # the IMU's figures

and scores each forward solution against the closed-form truth (not the log's own
ground-truth topics): position, velocity and attitude errors before, during and after the
outage, and how many of them lie within 3 sigma of the solution's own sigma.  ``ideal``
runs the same flight with an error-free IMU (the mechanization against the independent
motion).  ``--seeds N`` also runs seeds 1..N with the IMU's figures and prints, over
them, the RMS of the errors at the outage's end divided by their sigma (about 1 for a
filter whose sigma is honest).  Prints the tables; ``--json FILE`` writes the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import px4_flight as flight  # noqa: E402  (benchmarks/px4_flight.py: no fednav code)

#: statistics windows [s]: GNSS on (from the end of the ground alignment: the vehicle
#: takes off at 20 s), the outage, and the minute after it
WINDOWS = {"before": (20.0, flight.OUTAGE_S[0]), "outage": flight.OUTAGE_S,
           "after": (flight.OUTAGE_S[1], flight.OUTAGE_S[1] + 60.0)}
COMPONENTS = {"pos": (("E", "N", "U"), ("sigma_E_m", "sigma_N_m", "sigma_U_m")),
              "vel": (("E", "N", "U"), ("sigma_vE_mps", "sigma_vN_mps", "sigma_vU_mps")),
              "att": (("pitch", "roll", "heading"),
                      ("sigma_pitch_deg", "sigma_roll_deg", "sigma_heading_deg"))}


def read_solution(path) -> dict:
    """fednav's solution.csv as {column: array}."""
    a = np.genfromtxt(path, delimiter=",", names=True)
    return {k: a[k] for k in a.dtype.names}


def score(sol: dict, windows=None) -> dict:
    """Errors of a solution against the closed-form truth, per window: RMS and largest
    error per component, the largest error over its own sigma, the share of epochs
    within 3 sigma; and the horizontal error at the end of the outage."""
    windows = windows or WINDOWS
    t = sol["t_s"]
    err = flight.errors(t, np.column_stack([sol["lat_deg"], sol["lon_deg"], sol["h_m"]]),
                        np.column_stack([sol["vE_mps"], sol["vN_mps"], sol["vU_mps"]]),
                        np.column_stack([sol["pitch_deg"], sol["roll_deg"],
                                         sol["heading_deg"]]))
    out = {}
    for w, (a, b) in windows.items():
        m = (t >= a) & (t < b)
        out[w] = {}
        for q, (names, sig) in COMPONENTS.items():
            e = err[q][m]
            s = np.column_stack([sol[c][m] for c in sig])
            out[w][q] = {"names": list(names), "rms": np.sqrt(np.mean(e ** 2, 0)).tolist(),
                         "max": np.abs(e).max(0).tolist(),
                         "max_over_sigma": (np.abs(e) / s).max(0).tolist(),
                         "rms_over_sigma": np.sqrt(np.mean((e / s) ** 2, 0)).tolist(),
                         "within_3sigma": np.mean(np.abs(e) <= 3.0 * s, 0).tolist(),
                         "sigma_mean": s.mean(0).tolist()}
        out[w]["horizontal_max_m"] = float(np.hypot(*err["pos"][m][:, :2].T).max())
    a, b = flight.OUTAGE_S
    k = np.searchsorted(t, b) - 1  # the last epoch of the outage
    out["outage_end"] = {"t_s": float(t[k]),
                         "horizontal_m": float(np.hypot(*err["pos"][k, :2])),
                         "up_m": float(err["pos"][k, 2]),
                         "sigma_horizontal_m": float(np.hypot(sol["sigma_E_m"][k],
                                                              sol["sigma_N_m"][k]))}
    return out


def run_fednav(log, out, config=None) -> str:
    """``fednav process ulog`` (the installed command, else this source tree's CLI)."""
    cmd = ["fednav", "process", "ulog", str(log), "--out", str(out)]
    if config is not None:
        cmd += ["--config", str(config)]
    env = dict(os.environ)
    src = Path(__file__).resolve().parents[1] / "src"
    env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(src), env.get("PYTHONPATH"))))
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}\n{p.stdout}\n{p.stderr}")
    return " ".join(cmd)


def imu_yaml(path) -> Path:
    """A system description giving the simulated IMU's figures (``imu:``)."""
    lines = ["imu:"] + [f"  {k}: {v:.6g}" for k, v in flight.imu_config().items()]
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


def _row(label, v, fmt):
    return f"  {label:<30s}" + "".join(f"{fmt.format(x):>10s}" for x in v)


def print_score(name: str, s: dict) -> None:
    print(f"\n{name}: forward solution minus the closed-form truth")
    units = {"pos": "m", "vel": "m/s", "att": "deg"}
    for w in WINDOWS:
        a, b = WINDOWS[w]
        print(f" {w} ({a:g}-{b:g} s)")
        for q, r in s[w].items():
            if q == "horizontal_max_m":
                continue
            print(_row(f"{q} {'/'.join(r['names'])} RMS [{units[q]}]", r["rms"], "{:.3f}"))
            print(_row(f"{q} max |err| [{units[q]}]", r["max"], "{:.3f}"))
            print(_row(f"{q} max |err|/sigma", r["max_over_sigma"], "{:.2f}"))
            print(_row(f"{q} mean sigma [{units[q]}]", r["sigma_mean"], "{:.3f}"))
            print(_row(f"{q} RMS of err/sigma", r["rms_over_sigma"], "{:.2f}"))
            print(_row(f"{q} epochs within 3 sigma [%]",
                       [100 * x for x in r["within_3sigma"]], "{:.1f}"))
        print(f"  largest horizontal error: {s[w]['horizontal_max_m']:.2f} m")
    e = s["outage_end"]
    print(f" at the outage's end ({e['t_s']:.1f} s): horizontal {e['horizontal_m']:.2f} m "
          f"(sigma {e['sigma_horizontal_m']:.2f} m), up {e['up_m']:+.2f} m")


def seeds(out: Path, which, config) -> dict:
    """The flight of each seed in ``which`` with the IMU's figures: the errors at the
    outage's end over their sigma (east, north position and velocity; pitch, roll,
    heading), their RMS over the seeds, and the largest |error|/sigma of each run."""
    rows = []
    for seed in which:
        log = out / f"flight-{seed}.ulg"
        if not log.exists():
            flight.build(log, seed=seed)
        run_fednav(log, out / f"seed-{seed}", config)
        sol = read_solution(out / f"seed-{seed}" / "solution.csv")
        t = sol["t_s"]
        k = np.searchsorted(t, flight.OUTAGE_S[1]) - 1
        err = flight.errors(t[k:k + 1], np.column_stack([sol["lat_deg"], sol["lon_deg"],
                                                         sol["h_m"]])[k:k + 1],
                            np.column_stack([sol["vE_mps"], sol["vN_mps"],
                                             sol["vU_mps"]])[k:k + 1],
                            np.column_stack([sol["pitch_deg"], sol["roll_deg"],
                                             sol["heading_deg"]])[k:k + 1])
        z = np.r_[err["pos"][0, :2] / [sol["sigma_E_m"][k], sol["sigma_N_m"][k]],
                  err["vel"][0, :2] / [sol["sigma_vE_mps"][k], sol["sigma_vN_mps"][k]],
                  err["att"][0] / [sol["sigma_pitch_deg"][k], sol["sigma_roll_deg"][k],
                                   sol["sigma_heading_deg"][k]]]
        sc = score(sol)
        worst = max(max(sc[w][q]["max_over_sigma"][:2 if q != "att" else 3])
                    for w in WINDOWS for q in ("pos", "vel", "att"))
        rows.append((seed, z, worst, float(np.hypot(*err["pos"][0, :2]))))
        print(f"seed {seed}: at the outage's end horizontal {rows[-1][3]:.2f} m, "
              f"err/sigma " + " ".join(f"{v:+.2f}" for v in z)
              + f"; largest |err|/sigma (horizontal, attitude) {worst:.2f}", flush=True)
    z = np.array([r[1] for r in rows])
    rms = np.sqrt(np.mean(z ** 2, axis=0))
    names = ["E", "N", "vE", "vN", "pitch", "roll", "heading"]
    print(f"over {len(rows)} seeds, RMS of err/sigma at the outage's end: "
          + ", ".join(f"{n} {v:.2f}" for n, v in zip(names, rms, strict=True))
          + f"; runs with an epoch beyond 3 sigma: {sum(r[2] > 3 for r in rows)}")
    return {"rms_over_sigma_at_outage_end": dict(zip(names, rms.tolist(), strict=True)),
            "runs": [{"seed": r[0], "z": r[1].tolist(), "max_over_sigma": r[2],
                      "horizontal_m": r[3]} for r in rows]}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None, help="folder (default: a temporary one)")
    ap.add_argument("--seed", type=int, default=38)
    ap.add_argument("--seeds", type=int, default=0, help="also seeds 1..N (IMU figures)")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    tmp = None
    if args.out is None:
        tmp = tempfile.TemporaryDirectory()
        args.out = Path(tmp.name)
    args.out.mkdir(parents=True, exist_ok=True)
    results = {}
    cfg = imu_yaml(args.out / "imu.yaml")
    for name, errors, config in (("preset", True, None), ("imu", True, cfg),
                                 ("ideal", False, cfg)):
        log = args.out / f"flight-{'ideal' if not errors else args.seed}.ulg"
        if not log.exists():
            flight.build(log, seed=args.seed, imu_errors=errors)
        cmd = run_fednav(log, args.out / name, config)
        sol = read_solution(args.out / name / "solution.csv")
        s = score(sol)
        s["command"] = cmd
        s["summary"] = json.loads((args.out / name / "summary.json").read_text())
        results[name] = s
        print(f"\n$ {cmd}")
        for w in s["summary"].get("warnings", []):
            print(f"  warning: {w}")
        print_score(name, s)
    if args.seeds:
        results["seeds"] = seeds(args.out, range(1, args.seeds + 1), cfg)
    if args.json:
        args.json.write_text(json.dumps({k: {kk: vv for kk, vv in v.items() if kk != "summary"}
                                         for k, v in results.items()}, indent=1))
    if tmp is not None:
        tmp.cleanup()
    return results


if __name__ == "__main__":
    main()

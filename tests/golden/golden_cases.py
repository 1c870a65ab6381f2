"""What the golden-result tests pin: short runs of every paper's closed loops, `process`
forward and smoothed, and `tune`, flattened to named float arrays.

``python tests/golden/make_golden.py`` wrote ``tests/golden/*.npz`` from the code of
main before the one-navigator restructure (commit dca1acc); ``tests/golden/test_golden.py``
recomputes the same quantities with today's code and compares them to 1e-9 relative.
The functions below are the only place that knows how to ask today's code for them, so
when an interface moves only this file follows it; the stored numbers never change.
"""

from __future__ import annotations

import contextlib
import json
import platform
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
PLANETARY = ROOT.parent / "shared" / "data" / "canada-planetary"

#: When set, every data source below nudges its inputs by about one unit in the last place
#: (:func:`nudged`): how far that moves each result measures its sensitivity to rounding,
#: which is what a machine with another BLAS or libm changes.
_NUDGE = {"on": False}


@contextlib.contextmanager
def nudged():
    """Inside, the cases compute from inputs changed by one ulp in one value."""
    _NUDGE["on"] = True
    try:
        yield
    finally:
        _NUDGE["on"] = False


def _ulp(a: np.ndarray) -> np.ndarray:
    """``a`` with every value one ulp larger when nudged (else ``a``)."""
    return np.nextafter(a, np.inf) if _NUDGE["on"] else a


def _nudging(make):
    """A run-data factory whose IMU angle increments and first initial error are nudged."""
    def wrapped(*args, **kwargs):
        data = make(*args, **kwargs)
        data.dtheta = _ulp(data.dtheta)
        for name in ("init_phi", "x0_err"):
            v = getattr(data, name, None)
            if v is not None:
                setattr(data, name, np.r_[_ulp(v[:1]), v[1:]])
        return data
    return wrapped


def environment() -> dict:
    """What decides the last bits of a run besides fednav's code: CPU, numerical
    libraries and the SIMD paths numpy takes."""
    import numba
    import scipy
    import scipy.linalg  # noqa: F401  (loads scipy's BLAS, which numba calls)
    import threadpoolctl
    from numpy._core._multiarray_umath import __cpu_features__

    cpu = platform.processor()
    try:
        cpu = next(line.split(":", 1)[1].strip() for line in
                   Path("/proc/cpuinfo").read_text().splitlines()
                   if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    blas = sorted(f"{i.get('internal_api')} {i.get('version')} {i.get('architecture')}"
                  for i in threadpoolctl.threadpool_info())
    return {"cpu": cpu, "machine": platform.machine(), "numpy": np.__version__,
            "scipy": scipy.__version__, "numba": numba.__version__, "blas": blas,
            "simd": sorted(k for k, v in __cpu_features__.items() if v)}


def same_environment() -> bool:
    stored = json.loads((HERE / "environment.json").read_text())
    return stored == json.loads(json.dumps(environment()))


#: Fields of a simulation run result that are pinned (``None`` fields are skipped).
RESULT_FIELDS = ("t", "pos", "vel", "att", "sigma", "euler")


def _put(out: dict, key: str, value) -> None:
    a = np.asarray(value, dtype=float)
    out[key] = a


def _run_result(out: dict, prefix: str, r) -> None:
    for f in RESULT_FIELDS:
        v = getattr(r, f, None)
        if v is not None:
            _put(out, f"{prefix}/{f}", v)
    for k, b in (getattr(r, "beta", None) or {}).items():
        _put(out, f"{prefix}/beta/{k}", b)
    fdi = getattr(r, "fdi", None)
    if fdi is not None and len(fdi):
        _put(out, f"{prefix}/fdi/t", fdi["t"].to_numpy())
        _put(out, f"{prefix}/fdi/statistic", fdi["statistic"].to_numpy())
        _put(out, f"{prefix}/fdi/isolated", fdi["isolated"].to_numpy().astype(float))


def _rows(out: dict, prefix: str, rows: list[dict]) -> None:
    for i, row in enumerate(rows):
        for k, v in row.items():
            if isinstance(v, (int, float, np.floating, np.integer)) and k not in (
                    "seed", "time_s", "ms_per_cycle", "seconds_per_run"):
                _put(out, f"{prefix}/row{i}/{k}", v)


@contextlib.contextmanager
def _patched(module, name: str):
    """``module.name`` (a run-data factory) nudged while the block runs."""
    make = getattr(module, name)
    setattr(module, name, _nudging(make))
    try:
        yield
    finally:
        setattr(module, name, make)


# ----------------------------------------------------------------------------- papers
def paper000() -> dict:
    from fednav.scenarios import paper000 as p

    out: dict = {}
    scn = p.load_scenario()
    with _patched(p, "make_run_data"):
        rows, series = p.one_run((scn, 2, 250.0))
    _rows(out, "run", rows)
    for name, r in series.items():
        _run_result(out, name, r)
    return out


def paper001() -> dict:
    from fednav.scenarios import paper001 as p

    out: dict = {}
    scn = p.load_scenario()
    scn = scn.model_copy(update={"filters": scn.filters.model_copy(update={"particles": 100})})
    with _patched(p, "make_data"):
        rows, series = p._task(("T1", scn, 3, None, 80.0))
    _rows(out, "T1", rows)
    for name, r in series.items():
        for f in ("t", "att", "pos", "vel", "sigma"):
            _put(out, f"{name}/{f}", getattr(r, f))
    reg = next(g for g in scn.regimes if "chi-square" in g.name)
    with _patched(p, "make_data"):
        rows, _ = p._task(("regime", scn.with_regime(reg), 4, reg.name, 80.0))
    _rows(out, "regime", rows)
    return out


def paper002() -> dict:
    from fednav.scenarios import paper002 as p

    out: dict = {}
    scn = p.load_scenario()
    with _patched(p, "make_run_data"):
        for seed in (3, 4):
            rows, series = p.one_run((scn, seed, 120.0))
            _rows(out, f"s{seed}", rows)
            for name, r in series.items():
                _run_result(out, f"s{seed}/{name}", r)
        _rows(out, "T4", p.one_run_t4((scn, 3, 40.0)))
    obs = p.observability(scn, 120.0)
    for key, row in obs["rows"].items():
        for col, cell in row.items():
            _put(out, f"T1/{key}/{col}", cell["ours"])
    return out


def paper003() -> dict:
    from fednav.scenarios import paper003 as p

    out: dict = {}
    scn = p.load_scenario()
    scn = scn.model_copy(update={"fault_experiment": scn.fault_experiment.model_copy(
        update={"duration_s": 460.0})})
    with _patched(p, "make_run_data"):
        rows, series, fault_rows, fault_series = p.one_run((scn, 5, 460.0))
    _rows(out, "run", rows)
    _rows(out, "fault", fault_rows)
    for name, r in series.items():
        _run_result(out, name, r)
    for name, r in fault_series.items():
        _run_result(out, f"fault/{name}", r)
    return out


def paper004() -> dict:
    from fednav.scenarios import paper004 as p

    out: dict = {}
    scn = p.load_scenario()
    with _patched(p, "make_run_data"):
        rows, series = p.one_run((scn, 6, 300.0))
        _rows(out, "run", rows)
        for name, r in series.items():
            _run_result(out, name, r)
        _rows(out, "sweep", p.sweep_run((scn, 6, 200.0, 0.5)))
    return out


# ---------------------------------------------------------------------------- process
def car_drive(tmp: Path):
    """The simulated drive of examples/car-drive.yaml read back from its CSV files."""
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml")
    write_csv_dataset(simulate_dataset(cfg), tmp)
    return tmp


def _read_csv(folder: Path, cfg, velocity: bool = True):
    from fednav.io import read_gnss_csv, read_imu_csv, read_reference_csv, read_velocity_csv

    gc = cfg.sensors.gnss
    g = read_gnss_csv(folder / "gnss.csv",
                      gc.sigma_pos_enu_m if gc and gc.sigma_pos_enu_m else (5.0, 5.0, 5.0),
                      gc.sigma_vel_mps if gc and gc.sigma_vel_mps else (0.1, 0.1, 0.1),
                      gc.lever_m if gc and gc.lever_m else (0.0, 0.0, 0.0))
    return (read_imu_csv(folder / "imu.csv", cfg.imu.max_bridge_s), g,
            read_velocity_csv(folder / "velocity.csv") if velocity else None,
            read_reference_csv(folder / "reference.csv"))


def _solution(out: dict, prefix: str, sol, step: int) -> None:
    rows = np.r_[np.arange(0, len(sol.t), step), len(sol.t) - 1]
    for f in ("t", "lla", "vel", "euler", "sigma", "sigma_euler", "omega"):
        _put(out, f"{prefix}/{f}", getattr(sol, f)[rows])
    if sol.fdi:
        _put(out, f"{prefix}/nis", [e[2] for e in sol.fdi])
        _put(out, f"{prefix}/isolated", [float(e[5]) for e in sol.fdi])


def _process_case(out: dict, prefix: str, imu, gnss, vel, ref, cfg, smooth: bool) -> None:
    from fednav.process.run import errors_against, process, rmse

    # (the goldens pin the figures flown as given; fednav.process.identify's tests and
    # docs/real-data.md cover the identified ones)
    cfg = cfg.model_copy(update={"noise": "as-given"})
    res = process(imu, {"gnss": gnss, "velocity": vel}, cfg, smooth=smooth)
    _solution(out, f"{prefix}/forward", res.forward, 200)
    _put(out, f"{prefix}/epochs", res.epochs)
    # the goldens' keys are the 0.1 names (down, not up: the same RMSE)
    old = {"up_m": "down_m", "vu_mps": "vd_mps"}
    for k, v in rmse(errors_against(res.forward, ref)).items():
        _put(out, f"{prefix}/rmse/{old.get(k, k)}", v)
    if smooth:
        _solution(out, f"{prefix}/smoothed", res.smoothed, 200)
        for k, v in rmse(errors_against(res.smoothed, ref)).items():
            _put(out, f"{prefix}/rmse_smoothed/{old.get(k, k)}", v)


def process_cases(tmp: Path) -> dict:
    import yaml

    from fednav import load_system

    folder = car_drive(tmp)
    base = yaml.safe_load((folder / "process.yaml").read_text())
    out: dict = {}
    cfg = load_system(base)
    imu, gnss, vel, ref = _read_csv(folder, cfg)
    _process_case(out, "gnss", imu, gnss, None, ref, cfg, smooth=True)
    cfg2 = load_system({**base, "filter": {"fdi_alpha": {"velocity": 0.01},
                                           "fdi_recovery": 2, "substeps": 2}})
    _process_case(out, "gnss+velocity", imu, gnss, vel, ref, cfg2, smooth=True)
    cfg3 = load_system({**base, "alignment": {"initial_attitude": "coarse"},
                        "filter": {"fdi_alpha": 0.001, "period_s": 0.4}})
    _process_case(out, "coarse", imu, gnss, vel, ref, cfg3, smooth=False)
    return out


def planetary() -> dict:
    from fednav import load_system
    from fednav.io import (
        read_navego_gnss,
        read_navego_imu,
        read_navego_reference,
        read_navego_visual,
    )
    cfg = load_system(ROOT / "examples" / "canada-planetary.yaml")
    out: dict = {}
    _process_case(out, "planetary", read_navego_imu(PLANETARY / "imu_planetary.mat"),
                  read_navego_gnss(PLANETARY / "gnss_planetary.mat"),
                  read_navego_visual(PLANETARY / "visual_planetary.mat"),
                  read_navego_reference(PLANETARY / "gnss_planetary_r.mat"), cfg, True)
    return out


def tune_case(tmp: Path) -> dict:
    from fednav import load_system
    from fednav.process.tuning import tune
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml")
    cfg = cfg.model_copy(update={"segments": cfg.segments[:6], "seed": 4})
    write_csv_dataset(simulate_dataset(cfg), tmp)
    pcfg = load_system({"sensors": {"gnss": {"lever_m": list(cfg.gnss.lever_m)}}})
    imu, gnss, vel, _ = _read_csv(tmp, pcfg)
    imu.gyro = _ulp(imu.gyro)
    res = tune(imu, {"gnss": gnss, "velocity": vel}, pcfg)
    out: dict = {}
    legacy = {"sensors.gnss.sigma_pos_enu_m": "gnss_sigma_pos_m",
              "sensors.gnss.sigma_vel_mps": "gnss_sigma_vel_mps",
              "sensors.velocity.sigma_mps": "velocity_sigma_mps"}  # their 0.1 names
    for f in res.figures:
        # (gnss_sigma_pos_m in its 0.1 order, [north, east, up])
        v = f.value if f.key != "sensors.gnss.sigma_pos_enu_m" else np.asarray(f.value)[[1, 0, 2]]
        _put(out, f"figure/{legacy.get(f.key, f.key)}", v)
    _put(out, "before/loglik", res.before.loglik)
    _put(out, "after/loglik", res.after.loglik)
    for k, v in res.after.nis_per_dof.items():
        _put(out, f"after/nis/{k}", v)
    return out


CASES = {"paper000": paper000, "paper001": paper001, "paper002": paper002,
         "paper003": paper003, "paper004": paper004}

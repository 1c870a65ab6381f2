"""Measure how far the golden arrays move when only the numerical environment changes.

A machine with another CPU picks other BLAS kernels (OpenBLAS chooses per CPU: an Intel
Xeon with AVX-512 takes ``SkylakeX`` where the machine that wrote the goldens took
``Haswell``), numba compiles for another CPU, another numpy vectorises differently: the
last bits of every run move, and filters that amplify rounding carry them far.  This
script recomputes every golden case under each such environment on *this* machine —
OpenBLAS's kernels forced by ``OPENBLAS_CORETYPE``, numba's generic x86-64 target
(``NUMBA_CPU_NAME=generic``), optionally another interpreter with the oldest numpy
fednav supports (``--python``) — and writes, per array, the largest deviation from the
golden one relative to the array's scale, and the same of its statistics (mean and RMS of
each component over time, which chaotic arrays are compared by): ``spread.json``,
``{"cases": {case: {array: [samples, statistics]}}}``.  ``test_golden.py`` takes its
tolerance off the goldens' own environment from these measured figures.

Usage::

    python tests/golden/spread.py                     # every variant, every case
    python tests/golden/spread.py --variant SkylakeX paper000
    python tests/golden/spread.py --python numpy-1.26=/path/to/venv/bin/python

A run of every variant replaces its cases' figures; a run of some (``--variant``) raises
them where it measured more.

Each variant runs in a subprocess (numba's kernel cache keeps code per target CPU, so
the variants share it); a variant whose setting did not take (the BLAS reports another
kernel) is reported and left out.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import golden_cases as gc  # noqa: E402

#: name -> environment variables of each variant (x86-64 OpenBLAS kernels from the
#: oldest SSE2 core to AVX-512, and numba's generic target)
VARIANTS = {
    "Haswell": {"OPENBLAS_CORETYPE": "Haswell"},
    "SkylakeX": {"OPENBLAS_CORETYPE": "SkylakeX"},
    "SandyBridge": {"OPENBLAS_CORETYPE": "Sandybridge"},
    "Nehalem": {"OPENBLAS_CORETYPE": "Nehalem"},
    "Prescott": {"OPENBLAS_CORETYPE": "Prescott"},
    "numba-generic": {"NUMBA_CPU_NAME": "generic"},
    "numba-generic+Prescott": {"NUMBA_CPU_NAME": "generic", "OPENBLAS_CORETYPE": "Prescott"},
}

#: the kernel names OpenBLAS reports for a forced core type, where they differ
ALIASES = {"prescott": ("prescott", "katmai")}

ALL_CASES = [*gc.CASES, "process", "planetary", "tune"]


def _compute(out_dir: Path, cases: list[str]) -> None:
    """(In the variant's subprocess.) Every case's arrays into ``out_dir``."""
    import make_golden

    (out_dir / "environment.json").write_text(json.dumps(gc.environment(), indent=1))
    for name in cases:
        if name == "planetary" and not gc.PLANETARY.is_dir():
            continue
        np.savez_compressed(out_dir / f"{name}.npz", **make_golden.compute(name))


def deviation(golden: np.ndarray, got: np.ndarray) -> float:
    """Largest |got - golden| relative to the golden array's largest magnitude (inf when
    the shapes or the NaN pattern differ)."""
    if got.shape != golden.shape:
        return np.inf
    nan = np.isnan(golden)
    if not np.array_equal(nan, np.isnan(got)):
        return np.inf
    if nan.all() or not golden.size:
        return 0.0
    w, g = golden[~nan], got[~nan]
    if not np.all(np.isfinite(g)):
        return np.inf
    return float(np.max(np.abs(g - w))) / (float(np.max(np.abs(w))) or 1.0)


def statistics(a: np.ndarray) -> np.ndarray:
    """What a chaotic array is compared by: the mean and the RMS of each component over
    its first axis (a time series' level and size), NaN left out; a scalar itself."""
    a = np.asarray(a, dtype=float)
    if a.ndim == 0 or len(a) < 2:
        return a.ravel()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # (an all-NaN column: NaN)
        return np.r_[np.nanmean(a, axis=0).ravel(), np.sqrt(np.nanmean(a**2, axis=0)).ravel()]


def _run_variant(name: str, env: dict, python: str, cases: list[str], work: Path) -> dict:
    out = work / name
    out.mkdir()
    full = {**os.environ, **env, "PYTHONPATH": os.pathsep.join(
        [str(gc.ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    t0 = time.perf_counter()
    subprocess.run([python, __file__, "--compute", str(out), *cases], env=full, check=True)
    got_env = json.loads((out / "environment.json").read_text())
    want = env.get("OPENBLAS_CORETYPE", "").lower()
    blas = " ".join(got_env["blas"]).lower()
    took = not want or any(n in blas for n in ALIASES.get(want, (want,)))
    dev = {}
    for case in cases:
        f = out / f"{case}.npz"
        if not f.exists():
            continue
        golden, got = np.load(gc.HERE / f"{case}.npz"), np.load(f)
        dev[case] = {k: (deviation(golden[k], got[k]),
                         deviation(statistics(golden[k]), statistics(got[k])))
                     for k in golden.files if k in got.files}
    print(f"{name}: {time.perf_counter() - t0:.0f} s, BLAS {got_env['blas']}, numpy "
          f"{got_env['numpy']}{'' if took else '  (the setting did not take: left out)'}")
    for case, d in dev.items():
        worst = max(d.items(), key=lambda kv: kv[1][0], default=("-", (0.0, 0.0)))
        print(f"  {case}: largest deviation {worst[1][0]:.2g} ({worst[0]})")
    return {"env": env, "environment": got_env, "took": took, "deviation": dev}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="*", help=f"cases (default all: {' '.join(ALL_CASES)})")
    ap.add_argument("--variant", action="append", choices=list(VARIANTS),
                    help="only these variants (repeatable)")
    ap.add_argument("--python", action="append", default=[], metavar="NAME=PATH",
                    help="also run the cases with another interpreter (e.g. the oldest "
                         "numpy fednav supports, installed in another venv)")
    ap.add_argument("--compute", metavar="DIR", help=argparse.SUPPRESS)
    ap.add_argument("--out", type=Path, default=HERE / "spread.json")
    a = ap.parse_args(argv)
    if a.compute:
        _compute(Path(a.compute), a.cases)
        return
    cases = a.cases or ALL_CASES
    runs = [(v, VARIANTS[v], sys.executable) for v in (a.variant or VARIANTS)]
    for spec in a.python:
        name, _, path = spec.partition("=")
        runs.append((name, {}, path))
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, env, python in runs:
            results[name] = _run_variant(name, env, python, cases, Path(tmp))
    spread: dict = {}
    for r in results.values():
        if not r["took"]:
            continue
        for case, d in r["deviation"].items():
            c = spread.setdefault(case, {})
            for k, (v, st) in d.items():
                old_v, old_st = c.get(k, (0.0, 0.0))
                c[k] = (max(old_v, v), max(old_st, st))
    old = json.loads(a.out.read_text()) if a.out.exists() else {}
    cases_out = dict(old.get("cases", {}))
    every = a.variant is None  # every variant ran: a case's figures are replaced
    for c, d in spread.items():
        prev = {} if every else cases_out.get(c, {})
        merged = {k: tuple(max(x, y) for x, y in zip(prev.get(k, (0.0, 0.0)), v,
                                                       strict=True))
                  for k, v in {**{k: (0.0, 0.0) for k in prev}, **d}.items()}
        cases_out[c] = {k: [float(f"{v:.3g}"), float(f"{st:.3g}")]
                        for k, (v, st) in sorted(merged.items()) if v > 0}
    variants = {**old.get("variants", {}), **{n: {
        "env": r["env"], "blas": r["environment"]["blas"], "numpy": r["environment"]["numpy"],
        "took": r["took"]} for n, r in results.items()}}
    a.out.write_text(json.dumps({"golden_environment": json.loads(
        (HERE / "environment.json").read_text())["blas"], "variants": variants,
        "cases": cases_out}, indent=1) + "\n")
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()

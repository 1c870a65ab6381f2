"""Write the golden results (``tests/golden/*.npz``) from the code as it is now.

Run only to pin a deliberate change of results, and say so in the commit:
``python tests/golden/make_golden.py [CASE ...]`` (cases: the keys of
``golden_cases.CASES`` plus ``process``, ``planetary`` and ``tune``), then measure how
far they move in other numerical environments with ``python tests/golden/spread.py
[CASE ...]`` (it writes ``spread.json``, the tolerances off this machine).
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import golden_cases as gc  # noqa: E402


def compute(name: str) -> dict:
    if name in gc.CASES:
        return gc.CASES[name]()
    with tempfile.TemporaryDirectory() as tmp:
        if name == "process":
            return gc.process_cases(Path(tmp))
        if name == "tune":
            return gc.tune_case(Path(tmp))
    if name == "planetary":
        return gc.planetary()
    raise SystemExit(f"unknown case {name}")


def sensitivity(out: dict, nudged: dict) -> dict:
    """Per array: the largest change the nudge made, relative to the array's scale."""
    res = {}
    for key, a in out.items():
        b = nudged[key]
        ok = np.isfinite(a) & np.isfinite(b)
        if not ok.any():
            continue
        scale = float(np.max(np.abs(a[ok]))) or 1.0
        d = float(np.max(np.abs(a[ok] - b[ok]))) / scale
        if d > 0.0:
            res[key] = float(f"{d:.3g}")
    return res


def main(names: list[str]) -> None:
    sens_file = gc.HERE / "sensitivity.json"
    sens = json.loads(sens_file.read_text()) if sens_file.exists() else {}
    for name in names or [*gc.CASES, "process", "planetary", "tune"]:
        t0 = time.perf_counter()
        out = compute(name)
        with gc.nudged():
            sens[name] = sensitivity(out, compute(name))
        np.savez_compressed(gc.HERE / f"{name}.npz", **out)
        print(f"{name}: {len(out)} arrays, {sum(a.size for a in out.values())} values, "
              f"{time.perf_counter() - t0:.1f} s; largest change from a one-ulp nudge "
              f"{max(sens[name].values(), default=0.0):.2g}")
    sens_file.write_text(json.dumps(sens, indent=1, sort_keys=True) + "\n")
    every = [*gc.CASES, "process", "planetary", "tune"]
    if not names or set(names) >= set(every):
        (gc.HERE / "environment.json").write_text(json.dumps(gc.environment(), indent=1)
                                                  + "\n")
    elif not gc.same_environment():
        # (the other cases were written where environment.json says: marking this
        # machine as the goldens' would hold them to 1e-9 here)
        print("environment.json kept: the other goldens were written there; the cases "
              "re-pinned here are held to spread.json's tolerances off it")


if __name__ == "__main__":
    main(sys.argv[1:])

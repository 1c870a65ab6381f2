"""Golden results: every closed loop of fednav gives today's numbers to 1e-9 relative.

The stored arrays (``tests/golden/*.npz``) were written by ``make_golden.py`` from main
before the one-navigator restructure; ``golden_cases.py`` says what each holds.  An
array matches when every element is within ``1e-9 * max(|golden|)`` of the golden one
(relative to the array's own scale, so values crossing zero compare sensibly).

Some filters amplify rounding: a one-ulp nudge of the inputs moves paper 003's
total-state UKF by 1e-3 relative after 460 s and the small-alpha UKFs of papers 000 and
002 by 1e-5 .. 1e-6 (``sensitivity.json``, measured when the goldens were written).  A
machine with another CPU, BLAS or libm rounds differently, so there the tolerance of
each array is ``max(1e-9, 100 x its sensitivity)``; on the machine and libraries that
wrote the goldens (``environment.json``) every array is held to 1e-9.
"""

from __future__ import annotations

import json

import golden_cases as gc
import numpy as np
import pytest

RTOL = 1e-9
SAME = gc.same_environment()
SENSITIVITY = json.loads((gc.HERE / "sensitivity.json").read_text())


def _tolerance(name: str, key: str) -> float:
    if SAME:
        return RTOL
    return max(RTOL, 100.0 * SENSITIVITY.get(name, {}).get(key, 0.0))


def _mismatches(name: str, got: dict) -> tuple[int, list[str]]:
    """How many golden arrays were compared, and each that is missing, has another shape
    or differs beyond its tolerance (worst first)."""
    want = np.load(gc.HERE / f"{name}.npz")
    bad = [f"{k} missing" for k in sorted(set(want.files) - set(got))]  # (new keys may come)
    worst = []
    for key in sorted(set(want.files) & set(got)):
        w, g = want[key], np.asarray(got[key], dtype=float)
        if g.shape != w.shape:
            bad.append(f"{key} shape {g.shape}, golden {w.shape}")
            continue
        if not w.size:
            continue
        nan = np.isnan(w)
        if not np.array_equal(np.isnan(g), nan):
            worst.append((np.inf, key))
            continue
        if nan.all():
            continue
        w, g = w[~nan], g[~nan]
        scale = float(np.max(np.abs(w))) or 1.0
        err = float(np.max(np.abs(g - w))) / scale if np.all(np.isfinite(g)) else np.inf
        if err > _tolerance(name, key):
            worst.append((err, key))
    worst.sort(reverse=True)
    return len(want.files), bad + [f"{k} ({e:.2g})" for e, k in worst]


def _report(name: str, bad: list[str]) -> str:
    return (f"{name}: {len(bad)} arrays differ (same environment as the goldens: {SAME}), "
            f"worst " + ", ".join(bad[:5]))


@pytest.mark.parametrize("name", list(gc.CASES))
def test_paper_closed_loops(name):
    n, bad = _mismatches(name, gc.CASES[name]())
    assert n > 0 and not bad, _report(name, bad)


def test_process_forward_and_smoothed(tmp_path):
    n, bad = _mismatches("process", gc.process_cases(tmp_path))
    assert n > 0 and not bad, _report("process", bad)


@pytest.mark.skipif(not gc.PLANETARY.is_dir(), reason="../shared/data not available")
def test_process_real_rover_data():
    n, bad = _mismatches("planetary", gc.planetary())
    assert n > 0 and not bad, _report("planetary", bad)


def test_tune(tmp_path):
    n, bad = _mismatches("tune", gc.tune_case(tmp_path))
    assert n > 0 and not bad, _report("tune", bad)

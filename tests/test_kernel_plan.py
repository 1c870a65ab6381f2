"""The kernel plans (fednav.campaign.kernel_plan): current, compiled from the leaves up,
harmless when stale, handed to a worker on a first run only."""

import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import typeof

from fednav.campaign import kernel_plan
from fednav.campaign.store import run_units

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_the_plan_is_what_its_command_compiles(tmp_path):
    """Recorded again on an empty kernel cache, the paper-002 plan is the one kept (else
    it is stale: ``python tests/make_kernel_plan.py paper002``)."""
    cache = tmp_path / "cache"
    cache.mkdir()
    code = ("import pickle, sys\n"
            "sys.path.insert(0, sys.argv[1])\n"
            "from make_kernel_plan import run_command\n"
            "from fednav.campaign import kernel_plan\n"
            "plan = kernel_plan.record(run_command('paper002', __import__('pathlib')"
            ".Path(sys.argv[2])))\n"
            "open(sys.argv[3], 'wb').write(pickle.dumps(plan))\n")
    out = tmp_path / "plan.pkl"
    subprocess.run([sys.executable, "-c", code, str(ROOT / "tests"), str(tmp_path / "o"),
                    str(out)], check=True, env=dict(os.environ, NUMBA_CACHE_DIR=str(cache)))
    import numba

    fresh = pickle.loads(out.read_bytes())
    kept, version = kernel_plan.load("paper002", numba_version=True)
    assert kept is not None, "no paper002 plan (python tests/make_kernel_plan.py paper002)"
    if version != numba.__version__:  # (another numba may compile other helpers)
        pytest.skip(f"the paper002 kernel plan was recorded with numba {version}, this is "
                    f"{numba.__version__}: record it again (tests/make_kernel_plan.py)")
    gone = [e[:2] for e in kept if e not in fresh]
    new = [e[:2] for e in fresh if e not in kept]
    assert fresh == kept, (f"the paper002 kernel plan is stale (run python tests/"
                           f"make_kernel_plan.py paper002 on an empty NUMBA_CACHE_DIR): "
                           f"not compiled any more {gone}, not in the plan {new}")
    assert len(kept) > 50 and ("fednav.navigator.engine", "run_epochs") in {
        e[:2] for e in kept}


def test_a_plan_compiles_from_its_end_and_skips_what_it_cannot(tmp_path, monkeypatch):
    from fednav.core import kernels

    a = np.eye(3)
    plan = [("fednav.navigator.engine", "run_epochs", ()),  # a top: left to the command
            ("fednav.core.kernels", "no_such_kernel", (typeof(a),)),  # stale: skipped
            ("fednav.core.kernels", "cholesky_lower", ("not a type",)),  # stale: skipped
            ("fednav.core.kernels", "cholesky_lower", (typeof(a),))]
    monkeypatch.setattr(kernel_plan, "PLANS", tmp_path)
    kernel_plan.write("t", plan)
    assert kernel_plan.load("t") == plan
    assert kernel_plan.load("t", numba_version=True)[1] == __import__("numba").__version__
    assert kernel_plan.compile_plan("t") == 1
    assert (typeof(a),) in kernels.cholesky_lower.signatures
    assert kernel_plan.compile_plan("none") == 0  # no plan, no harm
    (tmp_path / "bad.pkl").write_bytes(b"not a pickle")
    assert kernel_plan.load("bad") is None and kernel_plan.compile_plan("bad") == 0
    assert kernel_plan.load("bad", numba_version=True) == (None, None)


def test_a_plan_is_needed_until_the_top_kernel_is_in_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert kernel_plan.needed()
    sub = tmp_path / "fednav" / "navigator"
    sub.mkdir(parents=True)
    (sub / "engine.other-10.py311.nbi").write_bytes(b"")
    assert kernel_plan.needed()
    (sub / "engine.run_epochs-900.py311.nbi").write_bytes(b"")
    assert not kernel_plan.needed()
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "absent"))
    assert not kernel_plan.needed()


def _square(x):
    return x * x


def _mark(name):  # (a worker's compile_plan: leaves its name where the test looks)
    Path(name).write_text("compiled")
    return 1


@pytest.mark.parametrize("needed", [True, False])
def test_a_worker_compiles_the_plan_on_a_first_run_only(tmp_path, monkeypatch, needed):
    mark = tmp_path / "plan-compiled"
    monkeypatch.setattr(kernel_plan, "needed", lambda: needed)
    monkeypatch.setattr(kernel_plan, "compile_plan", lambda name: _mark(name))
    out = run_units(_square, [1, 2, 3], jobs=2, plan=str(mark))
    assert out == [1, 4, 9]
    assert mark.exists() == needed

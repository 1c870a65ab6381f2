"""The kernel plans (fednav.campaign.kernel_plan): current, compiled from the leaves up,
harmless when stale, handed to a worker on a first run only."""

import os
import pickle
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from numba import typeof

from fednav.campaign import kernel_plan
from fednav.campaign.store import run_units

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper002", "process-csv"])
def test_the_plan_is_what_its_command_compiles(tmp_path, name):
    """Recorded again on an empty kernel cache, each plan is the one kept (else it is
    stale: ``python tests/make_kernel_plan.py NAME``)."""
    import numba

    cache = tmp_path / "cache"
    cache.mkdir()
    out = tmp_path / "plan.pkl"
    subprocess.run([sys.executable, str(ROOT / "tests" / "make_kernel_plan.py"), name,
                    "--to", str(out)], check=True,
                   env=dict(os.environ, NUMBA_CACHE_DIR=str(cache)))
    fresh = pickle.loads(out.read_bytes())
    version = kernel_plan.recorded_with(name)
    assert version is not None, f"no {name} plan (python tests/make_kernel_plan.py {name})"
    if version != numba.__version__:  # (the plan is not used: load() gives None)
        pytest.skip(f"the {name} kernel plan was recorded with numba {version}, this is "
                    f"{numba.__version__}, so it is not used: record it again "
                    f"(tests/make_kernel_plan.py)")
    kept = kernel_plan.load(name)
    gone = [e[:2] for e in kept if e not in fresh]
    new = [e[:2] for e in fresh if e not in kept]
    assert fresh == kept, (f"the {name} kernel plan is stale (run python tests/"
                           f"make_kernel_plan.py {name} on an empty NUMBA_CACHE_DIR): "
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
    assert kernel_plan.recorded_with("t") == __import__("numba").__version__
    assert kernel_plan.compile_plan("t") == 1
    assert (typeof(a),) in kernels.cholesky_lower.signatures
    assert kernel_plan.compile_plan("none") == 0  # no plan, no harm
    (tmp_path / "bad.pkl").write_bytes(b"not a pickle")
    assert kernel_plan.load("bad") is None and kernel_plan.compile_plan("bad") == 0
    assert kernel_plan.recorded_with("bad") is None
    # a plan recorded by another numba is not used
    (tmp_path / "old.pkl").write_bytes(pickle.dumps({"numba": "0.1", "kernels": plan}))
    assert kernel_plan.recorded_with("old") == "0.1" and kernel_plan.load("old") is None
    # asked to stop, it stops before the next kernel
    assert kernel_plan.compile_plan("t", stop=lambda: True) == 0


def test_a_plan_is_needed_until_the_top_kernel_is_in_the_cache(tmp_path, monkeypatch):
    index = kernel_plan._index_of("fednav.navigator.engine", "run_epochs")
    assert index is not None and index.name.startswith("engine.run_epochs-")
    assert index.suffix == ".nbi"
    fake = tmp_path / "engine.run_epochs-1.py311.nbi"
    monkeypatch.setattr(kernel_plan, "_index_of", lambda module, name: fake)
    assert kernel_plan.needed()
    fake.write_bytes(b"")
    assert not kernel_plan.needed()
    monkeypatch.setattr(kernel_plan, "_index_of", lambda module, name: None)
    assert not kernel_plan.needed()  # (numba does not say: no plan)
    monkeypatch.setattr(kernel_plan, "_index_of", lambda module, name: tmp_path / "none")
    seen = []
    assert kernel_plan.record(lambda: seen.append(kernel_plan.needed())) == []
    assert seen == [False] and kernel_plan.needed()  # (none while a plan is recorded)


def _square(x):
    time.sleep(0.2)  # (the plan's worker has its turn before the units are done)
    return x * x


def _mark(name, stop=None):  # (a worker's compile_plan: leaves its name where looked for)
    Path(name).write_text("compiled")
    return 1


@pytest.mark.parametrize("needed, jobs, units, plan, submitted", [
    (True, 2, 3, True, True),
    (False, 2, 3, True, False),  # not a first run
    (True, 1, 3, True, False),  # no second worker
    (True, 2, 1, True, False),  # one unit: flown in this process
    (True, 2, 3, False, False)])  # no plan
def test_a_worker_compiles_the_plan_on_a_first_run_only(tmp_path, monkeypatch, needed, jobs,
                                                        units, plan, submitted):
    mark = tmp_path / "plan-compiled"
    monkeypatch.setattr(kernel_plan, "needed", lambda: needed)
    monkeypatch.setattr(kernel_plan, "compile_plan", _mark)  # (the workers are forked)
    out = run_units(_square, list(range(1, units + 1)), jobs=jobs,
                    plan=str(mark) if plan else None)
    assert out == [x * x for x in range(1, units + 1)]
    assert mark.exists() == submitted


def test_paper_002_hands_its_plan_to_the_campaign(monkeypatch):
    from fednav.campaign import paper
    from fednav.scenarios.paper002 import Paper002

    assert Paper002.kernel_plan == "paper002" and kernel_plan.load("paper002")
    seen = {}

    def run_seeds(fns, args, jobs, progress, campaign, plan=None):
        seen["plan"] = plan
        raise RuntimeError("enough")

    monkeypatch.setattr(paper, "run_seeds", run_seeds)
    p = Paper002()
    with pytest.raises(RuntimeError, match="enough"):
        p.reproduce(p.load_scenario(), 1, 1)
    assert seen["plan"] == "paper002"
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert '"campaign/kernel_plans/*.pkl"' in pyproject  # (in the wheel too)


@pytest.mark.parametrize("needed", [True, False])
def test_a_one_process_command_has_the_plan_compiled_beside_it(monkeypatch, needed):
    monkeypatch.setattr(kernel_plan, "needed", lambda: needed)
    monkeypatch.setattr(kernel_plan, "load", lambda name: [("m", "k", ())])
    with kernel_plan.beside("process-csv") as proc:
        if needed and len(os.sched_getaffinity(0)) > 1:
            assert proc is not None and proc.args[0] == sys.executable
            assert "compile_plan('process-csv')" in proc.args[-1]
        else:
            assert proc is None
    if proc is not None:  # (stopped, or done, when the command is)
        assert proc.poll() is not None


def test_fednav_process_compiles_its_plan_beside_it(tmp_path, monkeypatch):
    """``fednav process`` reads and flies with the process-csv plan beside it."""
    from contextlib import contextmanager

    from typer.testing import CliRunner

    from fednav.cli import app

    entered = []

    @contextmanager
    def beside(name):
        entered.append(name)
        yield None

    monkeypatch.setattr(kernel_plan, "beside", beside)
    r = CliRunner().invoke(app, ["process", "csv", "--imu", str(tmp_path / "missing.csv"),
                                 "--gnss", str(tmp_path / "g.csv"), "--out",
                                 str(tmp_path / "out")])
    assert r.exit_code == 2 and "not found" in r.output  # (refused inside the block)
    assert entered == ["process-csv"] and kernel_plan.load("process-csv")

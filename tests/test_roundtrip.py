"""Round trip: `fednav simulate PAPER --seed S --mode M` files through `fednav process
csv` give the error series of run S, mode M of `fednav reproduce PAPER` (the same
navigator on the same data): positions to 1e-6 m, attitude to 1e-9 rad."""

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from fednav.cli import app
from fednav.scenarios import paper_module
from fednav.sim.export import find_mode, truth_errors

CASES = [("002", "SINS/CNS/SAR", 3, 150.0), ("003", "FKF", 2, 150.0),
         ("004", "recompute", 5, 150.0), ("004", "curve_fit", 5, 150.0)]


@pytest.mark.parametrize(("paper", "mode", "seed", "max_time"), CASES)
def test_process_on_simulated_files_equals_the_reproduced_run(tmp_path, paper, mode, seed,
                                                              max_time):
    runner = CliRunner()
    sim, out = tmp_path / "sim", tmp_path / "out"
    r = runner.invoke(app, ["simulate", paper, "--seed", str(seed), "--mode", mode,
                            "--max-time", str(max_time), "--out", str(sim)])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["process", "csv", "--config", str(sim / "system.yaml"),
                            "--out", str(out)])
    assert r.exit_code == 0, r.output
    err = pd.read_csv(out / "errors.csv")
    scn = paper_module(paper).EXPERIMENT.load_scenario()
    run = truth_errors(scn, find_mode(scn, mode), seed, max_time)
    t = err.t_s.to_numpy()
    keep = run.t <= t[-1] + 1e-9  # (process integrates whole epochs of the samples after
    assert keep.sum() >= len(run.t) - 1  # the first: one epoch fewer at the end)
    for k in ("t", "pos", "vel", "euler"):
        setattr(run, k, getattr(run, k)[keep])
    rows = np.searchsorted(t, run.t - 1e-9)
    assert np.allclose(err.t_s.to_numpy()[rows], run.t, atol=1e-9, rtol=0)
    e = err.iloc[rows]
    pos = np.column_stack([e.east_m, e.north_m, -e.down_m])
    vel = np.column_stack([e.ve_mps, e.vn_mps, -e.vd_mps])
    eul = np.radians(np.column_stack([e.pitch_deg, e.roll_deg, e.yaw_deg]))
    assert np.abs(pos - run.pos).max() < 1e-6
    assert np.abs(vel - run.vel).max() < 1e-6
    assert np.abs(eul - run.euler).max() < 1e-9
    assert np.abs(run.pos).max() > 1e-3  # (a real error series, not zeros on both sides)

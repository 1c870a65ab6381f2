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

#: (paper, mode, seed, seconds, position tolerance [m], attitude tolerance [rad])
CASES = [# paper 000's constrained UKF with air data through the wind constraint: its
         # sigma points magnify the one-ulp rounding of the files' degrees (measured
         # 4e-6 m after 100 s), hence 1e-4 m
         ("000", "CUKF", 1, 100.0, 1e-4, 1e-8),
         ("002", "SINS/CNS/SAR", 3, 150.0, 1e-6, 1e-9), ("003", "FKF", 2, 150.0, 1e-6, 1e-9),
         ("004", "recompute", 5, 150.0, 1e-6, 1e-9), ("004", "curve_fit", 5, 150.0, 1e-6, 1e-9),
         # Paper 003's total-state UKF: the files' angles in degrees read back within one
         # ulp of the simulation's radians, and this filter magnifies one ulp (measured: a
         # 1e-19 state difference at epoch 4 grows to 3e-3 m by 150 s; its state holds
         # latitude/longitude in radians and its sigma-point weights are ~ -1e6 at alpha
         # 1e-3), where the error-state filters keep it below 1e-9 m: 1 cm over 150 s
         ("003", "FUKF", 2, 150.0, 1e-2, 1e-6)]


@pytest.mark.parametrize(("paper", "mode", "seed", "max_time", "tol_m", "tol_rad"), CASES)
def test_process_on_simulated_files_equals_the_reproduced_run(tmp_path, paper, mode, seed,
                                                              max_time, tol_m, tol_rad):
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
    pos = np.column_stack([e.east_m, e.north_m, e.up_m])
    vel = np.column_stack([e.ve_mps, e.vn_mps, e.vu_mps])
    eul = np.radians(np.column_stack([e.pitch_deg, e.roll_deg, e.yaw_deg]))
    assert np.abs(pos - run.pos).max() < tol_m
    assert np.abs(vel - run.vel).max() < tol_m
    assert np.abs(eul - run.euler).max() < tol_rad
    assert np.abs(run.pos).max() > 1e-3  # (a real error series, not zeros on both sides)


def test_simulate_a_scenario_file_and_its_refusals(tmp_path):
    from fednav.scenarios import scenario_path

    runner = CliRunner()
    a, b = tmp_path / "a", tmp_path / "b"
    for src, out in (("sar-delay", a), (str(scenario_path("paper004")), b)):
        r = runner.invoke(app, ["simulate", src, "--seed", "4", "--mode", "curve_fit",
                                "--max-time", "30", "--out", str(out)])
        assert r.exit_code == 0, r.output
    names = sorted(p.name for p in a.iterdir() if not p.name.startswith("."))
    assert names == ["baro.csv", "imu.csv", "reference.csv", "sar.csv", "sarvel.csv",
                     "system.yaml"]
    for n in names:  # a paper by name and its scenario file give the same data
        assert (a / n).read_text().splitlines()[1:] == (b / n).read_text().splitlines()[1:]
    sar = pd.read_csv(a / "sar.csv")
    assert (sar.t_arrival_s > sar.t_s).all()  # the delayed SAR fixes say when they arrived
    for args, msg in ((["001"], "paper 001 flies in its own frame"),
                      (["002", "--mode", "nope"], "has no mode 'nope'; its modes: SINS, "),
                      (["002", "--seed", "-1"], "--seed must be 0 .. 2^63-1, got -1"),
                      (["002", "--format", "navego"], "--format navego applies to dataset"),
                      (["002", "--mode", "SINS"], "mode SINS has no aiding sensor"),
                      (["002", "--max-time", "-5"], "--max-time must be at least 1 s"),
                      (["002", "--max-time", "0.005"], "--max-time must be at least 1 s"),
                      (["nothing-here"], "is neither a paper")):
        r = runner.invoke(app, ["simulate", *args, "--out", str(tmp_path / "x")])
        assert r.exit_code == 2 and msg in r.output, r.output
        assert len(r.output.strip().splitlines()) == 1

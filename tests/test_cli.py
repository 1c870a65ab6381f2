"""The command line's own help: every command renders it, nothing in it is eaten as markup."""

import re
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from fednav.cli import app

# rich reads "[word...]" (lower-case letter, '/', '#' or '@' after the bracket) as a markup
# tag: it hides the text, or fails on a closing tag that matches nothing.
_MARKUP = re.compile(r"(?<!\\)\[[a-z#/@]")


def _commands(cmd, path=()):
    yield path, cmd
    for name, sub in getattr(cmd, "commands", {}).items():
        yield from _commands(sub, (*path, name))


COMMANDS = list(_commands(typer.main.get_command(app)))


@pytest.mark.parametrize("path", [p for p, _ in COMMANDS], ids=lambda p: " ".join(p) or "fednav")
def test_every_command_prints_its_help(path):
    res = CliRunner().invoke(app, [*path, "--help"])
    assert res.exit_code == 0, res.output
    assert "Usage" in res.output


def test_no_help_text_is_read_as_markup():
    texts = [(path, cmd.help or "") for path, cmd in COMMANDS]
    texts += [(path, p.help or "") for path, cmd in COMMANDS for p in cmd.params]
    bad = [(" ".join(path), t) for path, t in texts if _MARKUP.search(t)]
    assert not bad, bad


def test_bracketed_text_survives_in_the_help():
    out = CliRunner().invoke(app, ["reproduce", "--help"], env={"COLUMNS": "200"}).output
    assert "results/<paper>" in out
    out = CliRunner().invoke(app, ["--help"], env={"COLUMNS": "200"}).output
    assert "optional velocity aiding" in out


ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("argv, name, source", [
    # simulate: a dataset scenario where it writes its config, a paper-layout one where it
    # writes the system description, a file named as a sensor's CSV
    (["simulate", "{input}"], "process.yaml", "examples/car-drive.yaml"),
    (["simulate", "{input}"], "system.yaml", "examples/uav-gnss-baro-star.yaml"),
    (["simulate", "{input}", "--format", "navego"], "gnss.csv", "examples/car-drive.yaml"),
    # campaigns: a scenario named as a table, a plot, or kept in runs/ (--fresh empties it)
    (["reproduce", "002", "--scenario", "{input}"], "summary.json",
     "src/fednav/scenarios/paper002.yaml"),
    (["reproduce", "000", "--scenario", "{input}", "--fresh"], "runs/mine.yaml",
     "src/fednav/scenarios/paper000.yaml"),
    (["run", "{input}"], "tables.md", "examples/uav-gnss-baro-star.yaml"),
    (["run", "{input}", "--fresh"], "runs/design.yaml", "examples/uav-gnss-baro-star.yaml"),
    # allan: an IMU file named as one of its outputs
    (["allan", "{input}"], "summary.json", "tests/data/bad/good/imu.csv"),
])
def test_an_output_folder_holding_an_input_it_would_overwrite_is_refused(tmp_path, argv,
                                                                         name, source):
    """Issue 27: an output that is (or would overwrite) one of the command's inputs is
    refused in one line before anything is written (`fednav simulate scenario.yaml` with
    the scenario saved as OUT/process.yaml replaced it with the written config)."""
    out = tmp_path / "out"
    path = out / name
    path.parent.mkdir(parents=True)
    text = (ROOT / source).read_text()
    path.write_text(text)
    args = [a.replace("{input}", str(path)) for a in argv]
    r = CliRunner().invoke(app, [*args, "--out", str(out)])
    assert r.exit_code == 2, r.output
    assert r.output.strip() == (f"error: --out {out}: writing there would overwrite the "
                                f"{'imu' if argv[0] == 'allan' else 'scenario'} file {path}, "
                                f"an input; choose another output folder")
    assert path.read_text() == text
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*")) == \
        sorted({name, *[str(q.as_posix()) for q in Path(name).parents][:-1]})


def test_inputs_beside_the_outputs_are_not_refused():
    """A scenario kept in the output folder under a name no output has is fine."""
    from fednav.cli import _campaign_writes, _simulate_writes

    assert not _campaign_writes(Path("design.yaml")) and not _campaign_writes(Path("runs"))
    assert _campaign_writes(Path("runs/a.nc")) and _campaign_writes(Path("errors.png"))
    assert not _simulate_writes(Path("car-drive.yaml"))
    assert not _simulate_writes(Path("processed/solution.csv"))


def test_tables_are_full_width_when_the_output_is_not_a_terminal(monkeypatch):
    """Issue 29: piped output keeps full column names (rich used the width of whichever
    standard stream was a terminal, 80 columns, and cut them: ``north…``)."""
    import io

    from rich.table import Table

    from fednav import cli
    from fednav.core.console import PipeConsole

    names = [f"degree_filter_units_{i}" for i in range(9)]
    tab = Table()
    for n in names:
        tab.add_column(n)
    tab.add_row(*("1.0" for _ in names))
    monkeypatch.delenv("COLUMNS", raising=False)
    out = io.StringIO()
    PipeConsole(file=out).print(tab)
    assert all(n in out.getvalue() for n in names) and "…" not in out.getvalue()
    out = io.StringIO()
    PipeConsole(file=out, width=80).print(tab)  # an explicit width is kept
    assert "…" in out.getvalue() or not all(n in out.getvalue() for n in names)
    assert isinstance(cli.console, PipeConsole)


def test_reproduction_tables_in_the_terminal_say_better_worse_and_why():
    """Issue 29: the terminal tables judge each measure as the HTML report does (smaller
    errors are better, timings not judged), name the docs section of each worse cell,
    say a CI only where there is one, and print no '×-0.00'."""
    import io

    from fednav.campaign.report import print_tables
    from fednav.core.console import PipeConsole

    summary = {"paper": "002", "runs": 3, "seed": 1, "tables": {
        "T2": {"rows": {"SINS": {"dVx_mps": {"ours": 0.68, "ci95": 0.1, "paper": 0.2},
                                 "dlambda_m": {"ours": 20.0, "ci95": 3.0, "paper": 267.0}},
                        "SINS/SAR": {"dVx_mps": {"ours": 0.02, "ci95": 0.01, "paper": 0.019},
                                     "dlambda_m": {"ours": None, "ci95": None,
                                                   "paper": 0.89}}}},
        "T4": {"rows": {"UKF": {"ms_per_cycle": {"ours": 30.0, "ci95": 2.0, "paper": 2.1}}}},
        "T1": {"rows": {"phiE": {"degree": {"ours": 3437.0, "ci95": None, "paper": 8.67},
                                 "sigma_shrink": {"ours": 5.96, "ci95": None,
                                                  "paper": None}}}},
        "imp": {"rows": {"position": {"improvement_pct": {"ours": -0.001, "ci95": 0.1,
                                                          "paper": 25.8}}}}}}
    out = io.StringIO()
    print_tables(summary, {"T2": "Table 2 — mean absolute error"}, PipeConsole(file=out))
    text = out.getvalue()
    assert "Table 2 — mean absolute error" in text and "Table T4" in text
    assert "east velocity δVx [m/s]" in text and "east position δλ [m]" in text
    assert "0.68 ± 0.1 | 0.2 ×3.40 worse [1]" in text
    assert "20.0 ± 3.00 | 267 ×0.075 better" in text
    assert "(timing: not compared)" in text and "-25.8 points worse" in text
    assert "×-0.00" not in text
    t1 = text.split("observability")[0] if "observability" in text else text
    assert "one computation" in text and "3437 | 8.67 ×396 differs" in t1
    assert "docs/paper002.md#beyond-x3" in text and "docs/paper002.md#observability" in text


def test_tune_table_keeps_each_why_on_one_line(tmp_path, monkeypatch):
    """Issue 29: fednav tune's "how / why" column wrapped each reason over 5 lines; the
    table now holds the figures and each reason is one line under it (whole when piped;
    a narrow terminal keeps the figure names whole too)."""
    from types import SimpleNamespace

    from fednav import cli
    from fednav.navigator.system import System
    from fednav.process import tuning

    why = ("kept (sample scatter): x1.8 gains +3.4 on the fitted blocks but -6.1 on the "
           "held-back ones")
    figs = [tuning.Figure("imu.gyro_arw_rad_sqrt_s", 0.0029, 0.00059, why, 0.000576),
            tuning.Figure("sensors.gnss.sigma_vel_mps", [0.1, 0.1, 0.1],
                          [0.0512, 0.0658, 0.0969], "innovation covariance matching on "
                          "the fitted blocks, floored at the scatter of the data",
                          [0.0477, 0.0517, 0.0969])]
    res = SimpleNamespace(blocks=SimpleNamespace(length_s=25.0), figures=figs,
                          config=System(), lever_from_file=(0.1, 0.2, 0.3), notes=[],
                          warnings=[], runs=20, run_time_s=1.0, summary=lambda: [])
    monkeypatch.setattr(cli, "_csv_reader", lambda *a: (
        lambda cfg: {"imu": None, "sensors": {"gnss": None}}))
    monkeypatch.setattr(tuning, "tune", lambda *a, **k: res)
    monkeypatch.setattr(tuning, "config_yaml", lambda *a, **k: "imu: {}\n")
    args = ["tune", "csv", "--imu", str(tmp_path / "i.csv"), "--gnss",
            str(tmp_path / "g.csv"), "--out", str(tmp_path / "t.yaml")]
    monkeypatch.delenv("COLUMNS", raising=False)
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 0, r.output
    lines = r.output.splitlines()
    assert f"  gyro_arw_rad_sqrt_s: {why}" in lines
    assert "  sensors.gnss.lever_m: kept: from the file (written into the config)" in lines
    r = CliRunner().invoke(app, args, env={"COLUMNS": "80"})  # a narrow terminal
    assert r.exit_code == 0, r.output
    assert "sensors.gnss.sigma_vel_mps │" in r.output and "…" not in r.output
    assert max(len(line) for line in r.output.splitlines() if "│" in line) <= 80


def test_version_answers_without_importing_the_command_line():
    """``fednav --version`` (the console script, fednav.__main__) imports neither numba
    nor the sensor registry (issue 39: at most 2x ``import numpy``; 0.05 s against
    0.10 s on the development VM, 0.55 s before); ``python -m fednav`` is the same."""
    import subprocess
    import sys

    code = ("import sys; sys.argv = ['fednav', '--version']; "
            "from fednav.__main__ import main; main(); "
            "print(sorted(m for m in ('numba', 'fednav.cli', 'fednav.sensors', 'pydantic') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split("\n")
    assert out[0].startswith("fednav ") and out[1] == "[]"
    res = subprocess.run([sys.executable, "-m", "fednav", "--version"], capture_output=True,
                         text=True)
    assert res.returncode == 0 and res.stdout.startswith("fednav ")

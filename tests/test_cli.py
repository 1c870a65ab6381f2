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

"""A full disk or a folder without write permission ends a command in one line naming the
file; every output completed before stays as it is (issue 27: `OSError: [Errno 28]` in a
rich traceback box, during `process` and during a campaign).

The disk fills for real: the temporary name fednav writes a result under (hidden, with
this process's id: ``fednav.core.atomic.replacing``) is made a link to ``/dev/full``,
whose writes fail with ENOSPC; no root, no small file system needed."""

import errno
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from fednav.campaign.store import _read_unit
from fednav.cli import app
from fednav.core import atomic
from fednav.core.atomic import OutputError, write_bytes, write_json, write_text

GOOD = Path(__file__).parent / "data" / "bad" / "good"
FULL = Path("/dev/full")
needs_dev_full = pytest.mark.skipif(not FULL.exists(), reason="no /dev/full (Linux)")
as_root = hasattr(os, "geteuid") and os.geteuid() == 0
SETPRIV = shutil.which("setpriv")


def _without_override(argv: list[str]) -> subprocess.CompletedProcess:
    """`fednav ARGV` subject to file permissions: as root (CI containers), without the
    capabilities that override them (``setpriv``, util-linux)."""
    fednav = str(Path(sys.executable).parent / "fednav")
    pre = [SETPRIV, "--bounding-set", "-dac_override,-dac_read_search,-fowner"] \
        if as_root else []
    return subprocess.run([*pre, fednav, *argv], capture_output=True, text=True, timeout=300)


needs_permissions = pytest.mark.skipif(
    os.name != "posix" or (as_root and not SETPRIV),
    reason="as root, file permissions apply only without CAP_DAC_OVERRIDE (setpriv)")


def _fill(folder: Path, name: str) -> Path:
    """Make writing ``folder/name`` (from this process) hit a full disk."""
    folder.mkdir(parents=True, exist_ok=True)
    link = folder / f".{name}.{os.getpid()}.tmp"
    link.symlink_to(FULL)
    return link


def _process(out: Path, *extra: str):
    return CliRunner().invoke(app, ["process", "csv", "--imu", str(GOOD / "imu.csv"),
                                    "--gnss", str(GOOD / "gnss.csv"), "--ref",
                                    str(GOOD / "ref.csv"), "--config", str(GOOD / "cfg.yaml"),
                                    "--out", str(out), *extra])


def _error_lines(output: str) -> list[str]:
    assert "Traceback" not in output and "╭" not in output, output   # no (rich) traceback
    return [line for line in output.splitlines() if line.startswith("error:")]


@needs_dev_full
def test_write_layer_names_the_file_on_a_full_disk(tmp_path):
    p = write_text(tmp_path / "a.txt", "old")
    _fill(tmp_path, "a.txt")
    with pytest.raises(OutputError, match=f"cannot write {p}: no space left on the device "
                                          r"\(the disk is full\)") as e:
        write_bytes(p, b"new" * 100_000)
    assert e.value.errno == errno.ENOSPC and e.value.filename == str(p)
    assert isinstance(e.value, OSError)            # (callers catching OSError still do)
    assert p.read_text() == "old" and [f.name for f in tmp_path.iterdir()] == ["a.txt"]


def test_write_layer_names_the_file_without_permission(tmp_path, monkeypatch):
    def denied(src, dst):
        raise PermissionError(errno.EACCES, "Permission denied", str(dst))

    monkeypatch.setattr(atomic.os, "replace", denied)
    with pytest.raises(OutputError, match=r"cannot write .*s.json: permission denied"):
        write_json(tmp_path / "s.json", {"a": 1})
    assert list(tmp_path.iterdir()) == []          # the temporary file removed


@needs_dev_full
@pytest.mark.parametrize("name", ["summary.json", "errors.png", "solution.csv"])
def test_process_on_a_full_disk_ends_in_one_line(tmp_path, name, monkeypatch):
    """The disk fills while `process` writes ``name``: one line naming it, exit 2; the
    files written before it are complete, no summary.json (the run did not finish), no
    temporary file left; the same command then finishes.  (The plots drawn here: the
    full disk is a link at the temporary's name, which carries the writer's process id;
    a drawing worker's failures are the next test's.)"""
    from fednav.core import drawer

    monkeypatch.setattr(drawer, "can_fork", lambda: 0)
    out = tmp_path / "out"
    _fill(out, name)
    r = _process(out)
    assert r.exit_code == 2, r.output
    assert _error_lines(r.output) == [f"error: cannot write {out / name}: no space left on "
                                      f"the device (the disk is full)"]
    assert not (out / "summary.json").exists()
    assert not [f for f in out.iterdir() if f.name.startswith(".")]
    for f in out.glob("*.csv"):
        assert len(pd.read_csv(f)) > 0             # whatever was written is whole
    if name != "solution.csv":
        assert (out / "solution.csv").exists() and (out / "track.png").exists()
    r = _process(out)
    assert r.exit_code == 0, r.output
    json.loads((out / "summary.json").read_text())


@needs_permissions
def test_process_into_a_read_only_folder_ends_in_one_line(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "solution.csv").write_text("a user's file\n")
    out.chmod(0o555)
    try:
        r = _without_override(["process", "csv", "--imu", str(GOOD / "imu.csv"), "--gnss",
                               str(GOOD / "gnss.csv"), "--out", str(out)])
    finally:
        out.chmod(0o755)
    assert r.returncode == 2 and r.stdout == "", r.stdout + r.stderr
    assert r.stderr == f"error: output folder {out}: Permission denied\n"
    assert (out / "solution.csv").read_text() == "a user's file\n"


def test_process_denied_a_file_mid_run_ends_in_one_line(tmp_path, monkeypatch):
    """A permission error on one file after others were written (a folder made
    read-only mid-run; injected at the rename, so it holds as root too): one line, no
    summary.json (the mark of a finished run). The files written beside the failed plot
    (the plots are drawn while the others are written) stay; the failed one is absent."""
    real = os.replace

    def replace(src, dst):
        if Path(dst).name == "track.png":
            raise PermissionError(errno.EACCES, "Permission denied", str(dst))
        real(src, dst)

    monkeypatch.setattr(atomic.os, "replace", replace)
    out = tmp_path / "out"
    r = _process(out)
    assert r.exit_code == 2
    assert _error_lines(r.output) == [f"error: cannot write {out / 'track.png'}: permission "
                                      f"denied"]
    assert len(pd.read_csv(out / "solution.csv")) > 0 and not (out / "summary.json").exists()
    names = {f.name for f in out.iterdir()}
    assert "solution.csv" in names and "track.png" not in names
    assert names <= {"solution.csv", "errors.csv", "errors.png"}
    assert not any(n.endswith(".tmp") for n in names)  # (no temporary left behind)


ARGS = ["--runs", "2", "--max-time", "30", "--jobs", "1"]


def _reproduce(out: Path):
    return CliRunner().invoke(app, ["reproduce", "002", *ARGS, "--out", str(out)])


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    """An uninterrupted campaign: its run files' names and its tables."""
    out = tmp_path_factory.mktemp("whole")
    r = _reproduce(out)
    assert r.exit_code == 0, r.output
    return out


def _tables(out: Path) -> dict:
    t = json.loads((out / "summary.json").read_text())["tables"]
    for row in t["T4"]["rows"].values():   # wall-clock timings differ between runs
        row.pop("ms_per_cycle")
    return t


@needs_dev_full
def test_campaign_on_a_full_disk_keeps_the_stored_runs_and_resumes(tmp_path, whole):
    """The disk fills while a campaign stores a run, then while it writes its tables:
    each time one line naming the file and what is stored, exit 2, every stored run
    whole; the same command then reuses them and gives the uninterrupted tables."""
    names = sorted(f.name for f in (whole / "runs").glob("*.nc"))
    out = tmp_path / "c"
    _fill(out / "runs", names[-1])
    r = _reproduce(out)
    assert r.exit_code == 2, r.output
    (line,) = _error_lines(r.output)
    m = re.fullmatch(f"error: cannot write {re.escape(str(out / 'runs' / names[-1]))}: no "
                     r"space left on the device \(the disk is full\); (\d) of 5 units of "
                     f"work are stored in {re.escape(str(out))}; the same command computes "
                     f"the others", line)
    assert m, line
    stored = sorted(f.name for f in (out / "runs").iterdir())
    assert len(stored) == int(m[1]) and names[-1] not in stored
    assert set(stored) < set(names) and not (out / "summary.json").exists()
    for f in (out / "runs").glob("*.nc"):          # every stored run whole (which ones
        _read_unit(f, out)                         # are stored: the work keys' order)

    _fill(out, "runs.csv")
    r = _reproduce(out)
    assert r.exit_code == 2, r.output
    assert _error_lines(r.output) == [f"error: cannot write {out / 'runs.csv'}: no space "
                                      f"left on the device (the disk is full)"]
    assert sorted(f.name for f in (out / "runs").iterdir()) == names
    assert not (out / "summary.json").exists() and not (out / "runs.csv").exists()

    r = _reproduce(out)
    assert r.exit_code == 0, r.output
    assert json.loads((out / "summary.json").read_text())["campaign"]["runs_reused"] == 5
    assert _tables(out) == _tables(whole)


def test_campaign_denied_its_runs_folder_ends_in_one_line(tmp_path, whole, monkeypatch):
    """Permission refused on the runs (injected at the rename, so it holds as root)."""
    def denied(src, dst):
        raise PermissionError(errno.EACCES, "Permission denied", str(dst))

    out = tmp_path / "c"
    out.mkdir()
    (out / "notes.txt").write_text("the user's")
    real = os.replace
    monkeypatch.setattr(atomic.os, "replace",
                        lambda s, d: (denied if Path(d).suffix == ".nc" else real)(s, d))
    r = _reproduce(out)
    assert r.exit_code == 2, r.output
    (line,) = _error_lines(r.output)
    assert line.startswith(f"error: cannot write {out / 'runs'}/") and \
        ".nc: permission denied; 0 of 5 units of work are stored" in line
    assert (out / "notes.txt").read_text() == "the user's"
    assert list((out / "runs").iterdir()) == []


@needs_permissions
def test_campaign_with_a_read_only_runs_folder_ends_in_one_line(tmp_path):
    out = tmp_path / "c"
    (out / "runs").mkdir(parents=True)
    (out / "runs").chmod(0o555)
    try:
        r = _without_override(["reproduce", "002", *ARGS, "--out", str(out)])
    finally:
        (out / "runs").chmod(0o755)
    assert r.returncode == 2 and r.stdout == "", r.stdout + r.stderr   # at once: no run
    assert r.stderr == f"error: cannot write in {out / 'runs'}: permission denied\n"


def test_an_os_error_naming_a_file_is_one_line(tmp_path, monkeypatch):
    """Any OSError naming a file that reaches the command line (outside the write
    layer) is one line too, exit 2; with --debug, the traceback."""
    from fednav.scenarios import paper002

    def boom(*a, **k):
        raise OSError(errno.EIO, "Input/output error", str(tmp_path / "x.nc"))

    monkeypatch.setattr(paper002.EXPERIMENT, "reproduce", boom)
    r = CliRunner().invoke(app, ["reproduce", "002", "--out", str(tmp_path / "o")])
    assert r.exit_code == 2
    assert _error_lines(r.output) == [f"error: {tmp_path / 'x.nc'}: Input/output error"]
    r = CliRunner().invoke(app, ["--debug", "reproduce", "002", "--out", str(tmp_path / "o")])
    assert isinstance(r.exception, OSError)


@needs_permissions
def test_tune_into_a_read_only_folder_ends_in_one_line_before_the_work(tmp_path):
    """`fednav tune --out DIR/tuned.yaml`: a folder it cannot write in is said before its
    filter runs (minutes), not after."""
    out = tmp_path / "ro"
    out.mkdir()
    out.chmod(0o555)
    try:
        r = _without_override(["tune", "csv", "--imu", str(GOOD / "imu.csv"), "--gnss",
                               str(GOOD / "gnss.csv"), "--out", str(out / "tuned.yaml")])
    finally:
        out.chmod(0o755)
    assert r.returncode == 2 and r.stdout == "", r.stdout + r.stderr
    assert r.stderr == f"error: output folder {out}: Permission denied\n"

"""The command line's own help: every command renders it, nothing in it is eaten as markup."""

import re

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

"""Every positional and option of every subcommand says what it is in ``--help``; options with a fixed set of
values list them."""
import argparse

import pytest

from cli_in_process import run_cli
from master.algorithm_options import ALGORITHM_OPTIONS
from master.cli import _parser


def _subcommands():
    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices


@pytest.mark.parametrize("command", sorted(_subcommands()))
def test_every_argument_has_help(command):
    parser = _subcommands()[command]
    missing = [a.dest if not a.option_strings else a.option_strings[-1] for a in parser._actions
               if not isinstance(a, argparse._HelpAction) and (not a.help or a.help == argparse.SUPPRESS)]
    assert not missing, f"{command}: no help text for {', '.join(missing)}"


def test_every_subcommand_has_a_summary():
    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    described = {a.dest for a in sub._choices_actions if a.help}
    assert described == set(sub.choices)


def test_choices_are_listed(monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")        # argparse wraps the help to it: one line per choice list
    r = run_cli(["run", "--help"])
    assert r.returncode == 0, r.stderr
    text = r.stdout
    for opt in ALGORITHM_OPTIONS.values():
        if opt.kind == "choice":
            line = text[text.index("\n  " + opt.flag):]      # its entry, not the usage line
            line = line[:line.index("\n  -", 1)]
            assert all(str(c) in line for c in opt.choices), (opt.flag, line)

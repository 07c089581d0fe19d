"""The CLI builds only the parser of the command it is given (master.cli._parser(command)): that command must
parse, help and refuse exactly as with every command built, and the names it recognises must be the commands."""
import argparse

import pytest

from master.cli import COMMANDS, _built_for, _command_in, _parser


def _commands(parser):
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def test_the_commands_known_before_parsing_are_the_parsers_commands():
    assert list(COMMANDS) == list(_commands(_parser()))


@pytest.mark.parametrize("argv, command", [
    (["run", "x.ssp", "--step", "0.1"], "run"),
    (["--version"], None),
    ([], None),
    (["rnu", "x.ssp"], None),                       # misspelt: every command built, the choices listed
    (["-h", "inspect"], "inspect"),
    (["campaign", "run"], "campaign"),              # the first word names the command, not a later one
])
def test_the_command_is_the_first_word_that_is_not_an_option(argv, command):
    assert _command_in(argv) == command


@pytest.mark.parametrize("command", COMMANDS)
def test_a_command_built_alone_helps_as_with_every_command_built(command):
    alone, every = _commands(_parser(command))[command], _commands(_parser())[command]
    assert alone.format_help() == every.format_help()
    assert len(alone._actions) > 1 or len(every._actions) == 1
    assert list(_commands(_parser(command))) == [command]      # the others are not built


@pytest.mark.parametrize("argv", [
    ["run", "a.ssp", "--stop-time", "3", "--step", "0.01", "--record", "x.*", "--param", "a.k=2", "--no-supervise",
     "--algorithm", "gauss-seidel", "--extrapolation", "1", "--timeout", "5", "-o", "out"],
    ["inspect", "a.ssp", "--json", "--step", "0.5"],
    ["campaign", "c.yaml", "--workers", "2", "--max-runs", "3"],
    ["study", "a.ssp", "--algorithm", "jacobi", "gauss-seidel", "--step", "0.1", "0.05", "--reference", "r", "-o", "o"],
])
def test_a_command_built_alone_parses_as_with_every_command_built(argv):
    assert vars(_parser(_command_in(argv)).parse_args(argv)) == vars(_parser().parse_args(argv))


@pytest.mark.parametrize("argv, built", [
    (["-h", "inspect"], None),                      # the program's help, which lists every command
    (["--help", "run", "x.ssp"], None),
    (["run", "-h"], "run"),
    (["run", "x.ssp", "-o", "out"], "run"),
    (["--version", "run"], "run"),
])
def test_the_program_help_builds_every_command(argv, built):
    assert _built_for(argv) == built


def test_the_program_help_lists_every_command(capsys):
    with pytest.raises(SystemExit):
        _parser(_built_for(["-h", "inspect"])).parse_args(["-h", "inspect"])
    listed = capsys.readouterr().out
    assert all(command in listed for command in COMMANDS)

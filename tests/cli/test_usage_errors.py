"""A usage error (an unknown option, a value of the wrong kind, a missing argument) is one line on stderr
naming the command and the option, exit 2, on every subcommand of the program: not click's usage text and
a framed box of three lines or more.

The commands and their options are collected from the program's command tree (as tests/cli/test_options.py
does), so a new subcommand or option is checked without being listed here.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app

from _helpers import command_tree, option_type  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
runner = CliRunner()


COMMANDS = command_tree()
# every option taking a number: a word given instead must be refused naming that option
NUMBERS = [(command, p) for command, cmd in COMMANDS.items() for p in cmd.params
           if p.param_type_name == "option" and option_type(p) in (int, float)]


def _one_line(result) -> str:
    lines = result.stderr.splitlines()
    assert result.exit_code == 2, (result.exit_code, result.output)
    assert len(lines) == 1, result.stderr
    assert result.stdout == "", result.stdout
    return lines[0]


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_an_unknown_option_is_one_line_naming_it(command):
    line = _one_line(runner.invoke(app, [*command.split(), "--no-such-option-xyz"]))
    assert line.startswith(f"chronofuse {command}: error: No such option: --no-such-option-xyz"), line


@pytest.mark.parametrize("command, param", NUMBERS, ids=[f"{c} {p.opts[0]}" for c, p in NUMBERS])
def test_a_word_for_a_number_is_one_line_naming_the_option(command, param):
    option = param.opts[0]
    line = _one_line(runner.invoke(app, [*command.split(), option, "plenty"]))
    assert line.startswith(f"chronofuse {command}: error: Invalid value for '{option}'"), line


def test_a_misspelt_option_is_named_with_the_ones_it_may_mean():
    line = _one_line(runner.invoke(app, ["detect", "x.csv", "--pfq", "0.1"]))
    assert line == "chronofuse detect: error: No such option: --pfq (Possible options: --pfa)", line


def test_an_unknown_command_and_a_missing_argument_are_one_line_too():
    assert _one_line(runner.invoke(app, ["detetc"])).startswith("chronofuse: error: No such command 'detetc'")
    assert _one_line(runner.invoke(app, ["detect"])) == "chronofuse detect: error: Missing argument 'file'."


def test_the_console_script_says_it_in_one_line():
    env = {"PYTHONPATH": str(REPO / "src"), "PATH": "/usr/bin:/bin", "COLUMNS": "40"}
    done = subprocess.run([sys.executable, "-m", "chronofuse", "monitor", "--window", "many"], capture_output=True,
                          text=True, env=env, timeout=120)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.splitlines() == ["chronofuse monitor: error: Invalid value for '--window': Input should be a "
                                        "valid integer, unable to parse string as an integer"], done.stderr

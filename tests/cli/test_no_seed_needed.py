"""``detect``, ``inspect`` and ``monitor`` take no ``--seed``: they draw no random numbers (tests/cli/test_options.py
lists them in NO_SEED). Checked by running each with every random number generator a library could reach
replaced by one that fails the test when it is drawn from; the same input twice gives the same document."""

from __future__ import annotations

import json
import random

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from chronofuse.cli import detect as detect_cli
from chronofuse.cli import inspect as inspect_cli
from chronofuse.cli import monitor as monitor_cli

from _recordings import step  # noqa: E402

STEP = step()  # simulated here, before any test replaces the generators
runner = CliRunner()
app = typer.Typer()
for module in (detect_cli, inspect_cli, monitor_cli):
    module.register(app)


@app.callback()
def _root() -> None:
    """Local app holding the commands under test."""


class _Drawn(AssertionError):
    pass


def _refuse(*args, **kwargs):
    raise _Drawn("a random number was drawn")


def _forbid(monkeypatch) -> None:
    """Every generator a library could draw from fails the test once called (after the imports, some of which,
    scipy.stats's among them, draw at import time for their documentation)."""
    monkeypatch.setattr(np.random, "default_rng", _refuse)
    monkeypatch.setattr(np.random, "RandomState", _refuse)
    monkeypatch.setattr(np.random, "Generator", _refuse)
    for name in ("seed", "random", "normal", "uniform", "standard_normal", "randn", "rand", "randint", "choice"):
        monkeypatch.setattr(np.random, name, _refuse)
    for name in ("random", "gauss", "uniform", "randint", "choice", "shuffle"):
        monkeypatch.setattr(random, name, _refuse)


COMMANDS = {
    "detect": (["--train", "300", "--json"], 1),
    "inspect": (["--json"], 0),
    "monitor": (["--replay-speed", "1e6", "--train", "300", "--json"], 0),
}


def _run(command: str, path) -> dict:
    args, code = COMMANDS[command]
    where = ["--replay", str(path)] if command == "monitor" else [str(path)]
    result = runner.invoke(app, [command, *where, *args])
    assert result.exit_code == code, result.output
    doc = json.loads(result.stdout)
    if command == "monitor":  # what differs between two live runs: the wall clock's times
        doc = [(r["receiver"], r["epochs"], r["alarms"]) for r in doc["receivers"]]
    return doc


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_the_command_draws_no_random_numbers_and_repeats_itself(command, tmp_path, monkeypatch):
    path = tmp_path / "step.ubx"
    path.write_bytes(STEP)
    first = _run(command, path)  # everything it needs imported
    _forbid(monkeypatch)
    assert _run(command, path) == first


def test_the_guard_catches_a_draw(monkeypatch):
    _forbid(monkeypatch)
    with pytest.raises(_Drawn):
        np.random.default_rng(1).normal()

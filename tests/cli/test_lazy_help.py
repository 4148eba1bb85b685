"""``chronofuse --help`` lists every subcommand without importing any subcommand's module (they import the
library, seconds for some), and says exactly what the full program says; ``chronofuse detect --help`` loads
its own module only, none of the numerical stack. The timings are in benchmarks/bench_import.py."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import COMMANDS, SUMMARIES, app, build_index

REPO = Path(__file__).resolve().parents[2]
runner = CliRunner()

_LOADED = """
import json, sys
sys.argv = ["chronofuse", *sys.argv[1:]]
from chronofuse.cli.main import main
try:
    main()
except SystemExit:
    pass
print(json.dumps(sorted(m for m in sys.modules if m.startswith(("chronofuse", "numpy", "scipy", "pandas", "pydantic", "numba", "matplotlib")))))
"""


def _loaded(*argv: str) -> list[str]:
    done = subprocess.run([sys.executable, "-c", _LOADED, *argv], capture_output=True, text=True, timeout=300,
                          env={"PYTHONPATH": str(REPO / "src"), "PATH": "/usr/bin:/bin", "COLUMNS": "100"})
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


@pytest.mark.parametrize("columns", ["80", "200"])
def test_the_index_says_what_the_full_program_says(columns):
    lazy = runner.invoke(build_index(), ["--help"], env={"COLUMNS": columns})
    full = runner.invoke(app, ["--help"], env={"COLUMNS": columns})
    assert lazy.exit_code == full.exit_code == 0
    assert lazy.stdout == full.stdout


def test_the_index_lists_every_subcommand():
    assert set(SUMMARIES) == set(COMMANDS)


def test_the_programs_help_imports_no_subcommand_and_no_numerical_library():
    loaded = _loaded("--help")
    assert [m for m in loaded if m.startswith(("numpy", "scipy", "pandas"))] == []
    assert [m for m in loaded if m.split(".")[-1] in COMMANDS] == [], loaded


def test_a_subcommands_help_imports_that_subcommand_only():
    loaded = _loaded("detect", "--help")
    assert "chronofuse.cli.detect" in loaded
    assert [m for m in loaded if m.startswith("chronofuse.cli.") and m.split(".")[-1] in COMMANDS] == \
        ["chronofuse.cli.detect"]
    # nor pydantic: typer built a pydantic TypeAdapter to coerce the root's flags left out (None), 1 s of it
    assert [m for m in loaded if m.startswith(("numpy", "scipy", "pandas", "pydantic"))] == []


@pytest.mark.parametrize("argv, out", [(["--version"], "0."), (["--debug", "--version"], "0.")])
def test_the_roots_flags_still_work_without_typers_coercion(argv, out):
    done = subprocess.run([sys.executable, "-m", "chronofuse", *argv], capture_output=True, text=True, timeout=300,
                          env={"PYTHONPATH": str(REPO / "src"), "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0 and done.stdout.startswith(out), done.stderr
    bad = subprocess.run([sys.executable, "-m", "chronofuse", "--version=3"], capture_output=True, text=True,
                         timeout=300, env={"PYTHONPATH": str(REPO / "src"), "PATH": "/usr/bin:/bin"})
    assert bad.returncode == 2 and "--version" in bad.stderr


@pytest.mark.parametrize("command", ["simulate", "position", "validate"])
def test_a_help_naming_registry_entries_imports_no_simulation_or_analysis(command):
    # simulate --help took 28 s on a loaded machine (scipy.signal, numba, pandas for the preset names), validate
    # --help 29 s (the whole validation suite for its seed), position --help 20 s
    loaded = _loaded(command, "--help")
    assert [m for m in loaded if m.startswith(("scipy.signal", "numba", "pandas", "matplotlib"))] == [], command
    assert not [m for m in loaded if m.startswith(("chronofuse.experiments.", "chronofuse.gnss.simulate",
                                                   "chronofuse.positioning.scenario")) or m == "chronofuse.models.receiver"]


def test_the_names_in_those_helps_are_the_registries_own():
    from chronofuse.cli import position, validate  # noqa: F401
    from chronofuse.experiments.validation import SEED
    from chronofuse.experiments import VALIDATION_SEED
    from chronofuse.gnss.simulate import ENVIRONMENTS
    from chronofuse.positioning.scenario import MAX_SPEED_M_PER_S, SYSTEMS

    assert sorted(position.ENVIRONMENTS) == sorted(ENVIRONMENTS)
    assert (position.SYSTEMS, position.MAX_SPEED_M_PER_S) == (SYSTEMS, MAX_SPEED_M_PER_S)
    assert SEED == VALIDATION_SEED
    help_text = runner.invoke(app, ["validate", "--help"], env={"COLUMNS": "200"}).stdout
    assert str(SEED) in help_text

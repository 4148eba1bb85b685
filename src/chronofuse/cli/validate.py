"""``chronofuse validate``: check this installation against Stable32, NIST SP 1065 and real records."""

from __future__ import annotations

import json
import time
from pathlib import Path

import typer

from chronofuse.cli.common import fail, human_console, print_json, progress_reporter, quiet_output, user_errors
from chronofuse.experiments.validation import SEED, write_validation_figures


def register(app: typer.Typer) -> None:
    app.command("validate")(validate)


def validate(
    data: Path = typer.Option(..., "--data", help="Real data folder holding stability/ (the project's shared/data, or tests/data)."),
    out: Path = typer.Option(Path("out/validate"), "--out",
                             help="Folder for the figures and validation.json (docs/figures holds the published run)."),
    quick: bool = typer.Option(False, "--quick", help="Short simulations (a smoke run)."),
    seed: int = typer.Option(SEED, "--seed", help="Seed of the simulations."),
    json_out: bool = typer.Option(False, "--json", help="Print validation.json's numbers on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Figures and numbers: our statistics on real records against Stable32, the receiver calibration,
    each oscillator preset against theory, and the Cs 5071A record against the ITU-T masks."""
    quiet_output(quiet)
    if not (data / "stability").is_dir():
        fail(f"{data}: no stability/ folder (give the real data folder with --data)")
    with user_errors():
        start = time.perf_counter()
        with progress_reporter("validate"):
            paths = write_validation_figures(out, data, quick=quick, seed=seed)
    if json_out:
        print_json(json.loads((Path(out) / "validation.json").read_text()))
        return
    con = human_console(False)
    for path in paths:
        con.print(str(path))
    con.print(f"done in {time.perf_counter() - start:.1f} s")

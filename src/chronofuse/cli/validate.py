"""``chronofuse validate``: check this installation against Stable32, theory and real records: a PASS/FAIL
table of every check, from the records shipped with the package; files only with ``--out``."""

from __future__ import annotations

import time
from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import fail, human_console, print_json, progress_reporter, quiet_output, user_errors
from chronofuse.experiments import VALIDATION_SEED as SEED


def register(app: typer.Typer) -> None:
    app.command("validate")(validate)


def validate(
    data: Path | None = typer.Option(None, "--data", help="A folder holding stability/gps and stability/Cs5071A "
                                     "(default: the records shipped with chronofuse)."),
    out: Path | None = typer.Option(None, "--out", help="Also write the figures and validation.json to this folder "
                                    "(default: nothing is written)."),
    quick: bool = typer.Option(False, "--quick", help="Short simulations (a smoke run)."),
    seed: int = typer.Option(SEED, "--seed", help="Seed of the simulations."),
    json_out: bool = typer.Option(False, "--json", help="Print the checks and the numbers as one JSON document."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Our statistics on real records against Stable32's tables, the receiver model against the GPS
    record, each oscillator preset against theory: one PASS/FAIL line per check (exit 1 if any fails)."""
    from chronofuse.experiments.validation import run_validation
    from chronofuse.experiments.validation_checks import checks

    quiet_output(quiet)
    if data is not None and not (data / "stability").is_dir():
        fail(f"{data}: no stability/ folder (give a folder holding stability/gps and stability/Cs5071A with --data)")
    with user_errors():
        start = time.perf_counter()
        with progress_reporter("validate") as say:
            numbers, paths = run_validation(data, out, quick=quick, seed=seed, progress=say)
        verdicts = checks(numbers)
    seconds = time.perf_counter() - start
    failed = sum(not c.passed for c in verdicts)
    if json_out:
        print_json({"checks": [c.to_dict() for c in verdicts], "failed": failed, "seconds": seconds,
                    "files": [str(p) for p in paths], "numbers": numbers})
    else:
        con = human_console(False)
        table = Table("check", "criterion", "measured", "verdict", title="chronofuse validate"
                      + (" (quick)" if quick else ""))
        for c in verdicts:
            table.add_row(c.name, c.criterion, c.value, "[green]PASS[/green]" if c.passed else "[red]FAIL[/red]")
        con.print(table)
        con.print(f"{len(verdicts) - failed} of {len(verdicts)} checks pass, in {seconds:.1f} s"
                  + (f"; figures and validation.json in {out}" if out is not None else ""))
    if failed:
        raise typer.Exit(1)

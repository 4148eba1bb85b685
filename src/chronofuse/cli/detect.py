"""``chronofuse detect FILE``: clock-bias anomaly detection (SPEC 4) on a CSV, UBX or RINEX record.

The work is :func:`chronofuse.integrity.modes.detect_file` (its docstring says how the mode is chosen, how
the noise model is set and how missing data are counted); this command parses the options, calls it and
prints its document: ``--json`` as it is, else a summary line and a table of alarms.
"""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import fail, human_console, print_json, user_errors
from chronofuse.integrity.modes import detect_file

_MAX_TABLE_ROWS = 50


def register(app: typer.Typer) -> None:
    app.command("detect")(detect)


def detect(
    file: Path = typer.Argument(..., help="Clock-bias CSV (time + bias column), UBX (NAV-CLOCK) or RINEX observation file."),
    rate: float = typer.Option(..., "--rate", help="Sampling rate of the clock bias (Hz)."),
    column: str | None = typer.Option(None, "--column", help="CSV clock-bias column (name)."),
    h0: float | None = typer.Option(None, "--h0", help="White FM level h0 (s)."),
    hm2: float | None = typer.Option(None, "--hm2", help="Random-walk FM level h-2 (1/s)."),
    sigma_rho: float | None = typer.Option(None, "--sigma-rho", help="Mean pseudorange noise (m)."),
    train: float | None = typer.Option(None, "--train", help="Estimate missing noise parameters from the first SECONDS."),
    window: int = typer.Option(20, "--window", help="Window length n (epochs)."),
    pfa: float = typer.Option(1e-3, "--pfa", help="False-alarm probability per epoch."),
    position: str | None = typer.Option(None, "--position", help="Static antenna ECEF X,Y,Z (m): identification mode."),
    nav: Path | None = typer.Option(None, "--nav", help="RINEX navigation file (identification mode)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
) -> None:
    """Detect clock-bias anomalies with the high-order-difference chi-square test (SPEC 4)."""
    if rate <= 0 or not math.isfinite(rate):
        fail(f"--rate {rate:g}: must be a positive number of Hz")
    if window < 1:
        fail(f"--window {window}: must be >= 1")
    if not 0.0 < pfa < 1.0:
        fail(f"--pfa {pfa:g}: must be in (0, 1)")
    if train is not None and train <= 0:
        fail(f"--train {train:g}: must be > 0 seconds")
    if train is None and None in (h0, hm2, sigma_rho):
        fail("give the noise model (--h0, --hm2 and --sigma-rho) or a training stretch (--train SECONDS)")
    with user_errors():
        doc = detect_file(file, rate, column=column, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho, train_s=train,
                          window=window, pfa=pfa, position_m=position, nav=nav)
    if json_out:
        print_json(doc)
        return
    _print_human(file, doc)


def _print_human(file: Path, doc: dict) -> None:
    con = human_console(False)
    con.print(f"[bold]{file}[/bold]: {doc['mode']} mode, {doc['n_epochs']:,} epochs ({doc['n_skipped']} skipped), "
              f"window {doc['window']}, P_fa {doc['pfa']:g}, threshold {doc['threshold']:.3f}")
    if doc.get("untested"):
        con.print(f"not tested (too few epochs above the elevation mask): {', '.join(doc['untested'])}")
    if doc.get("faulty"):
        con.print("faulty: " + ", ".join(f"{f['channel']} (from t = {f['t']:g} s)" for f in doc["faulty"]))
    if not doc["alarms"]:
        con.print("[green]no alarm[/green]")
        return
    table = Table("t (s)", "statistic", "channel", title=f"{doc['n_alarms']} alarm(s)")
    for alarm in doc["alarms"][:_MAX_TABLE_ROWS]:
        table.add_row(f"{alarm['t']:.3f}", f"{alarm['statistic']:.2f}", alarm["channel"] or "clock")
    con.print(table)
    if doc["n_alarms"] > _MAX_TABLE_ROWS:
        con.print(f"... {doc['n_alarms'] - _MAX_TABLE_ROWS} more (use --json for all)")

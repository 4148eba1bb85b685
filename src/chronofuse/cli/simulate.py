"""``chronofuse simulate oscillator|receiver``: write simulated truth to a file."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import typer
from rich.table import Table

from chronofuse.cli.common import human_console, print_json, progress_reporter, quiet_output, user_errors
# the help text names the presets and environments; what simulates and analyses is imported by the command
from chronofuse.models.oscillator_presets import PRESETS, preset
from chronofuse.models.environment import ENVIRONMENTS

simulate_app = typer.Typer(help="Simulate clocks and receivers (truth models) and write them to a file.",
                           no_args_is_help=True)


def register(app: typer.Typer) -> None:
    app.add_typer(simulate_app, name="simulate")


@simulate_app.command("oscillator")
def oscillator(
    preset_name: str = typer.Option("ocxo", "--oscillator", help=f"Oscillator preset, one of {sorted(PRESETS)}."),
    duration: float = typer.Option(3600.0, "--duration", help="Duration (s)."),
    rate: float = typer.Option(1.0, "--rate", help="Sample rate (Hz)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the run (numpy SeedSequence)."),
    out: Path = typer.Option(Path("oscillator.csv"), "--out", help="Output file: CSV (t_s,x_s) or .parquet."),
    h2: float | None = typer.Option(None, "--h2", help="White PM level h2 (s^3); each level given overrides the preset's."),
    h1: float | None = typer.Option(None, "--h1", help="Flicker PM level h1 (s^2)."),
    h0: float | None = typer.Option(None, "--h0", help="White FM level h0 (s)."),
    hm1: float | None = typer.Option(None, "--hm1", help="Flicker FM level h-1 (dimensionless)."),
    hm2: float | None = typer.Option(None, "--hm2", help="Random-walk FM level h-2 (1/s)."),
    drift: float | None = typer.Option(None, "--drift", help="Linear frequency drift, aging (1/s)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Simulate a free-running oscillator's phase x(t) in seconds."""
    from chronofuse.analysis.stability.taus import averaging_factors
    from chronofuse.analysis.theory import adev_theory
    from chronofuse.io.tables import write_table
    from chronofuse.models.oscillator import simulate_oscillator

    quiet_output(quiet)
    with user_errors():
        model = preset(preset_name)
        overrides = {k: v for k, v in dict(h2=h2, h1=h1, h0=h0, hm1=hm1, hm2=hm2).items() if v is not None}
        if overrides:
            model = dataclasses.replace(model, h=dataclasses.replace(model.h, **overrides))
        if drift is not None:
            model = dataclasses.replace(model, drift_per_s=drift)
        with progress_reporter("simulate oscillator") as say:
            say(f"{int(round(duration * rate)):,} samples")
            truth = simulate_oscillator(model, duration, rate, seed, trials=1)
            say(f"writing {out}")
            write_table({"t_s": truth.t_s, "x_s": truth.x_s[0]}, out)
        n = truth.t_s.size
        tau = averaging_factors(max(n // 4, 1), "decade") / rate
        theory = adev_theory(model.h, tau, rate, model.drift_per_s)
    h = dataclasses.asdict(model.h)
    if json_out:
        print_json({"h": h, "drift": model.drift_per_s, "theory": {"tau": tau, "adev": theory}, "out": str(out)})
        return
    con = human_console(False)
    con.print(f"[bold]{model.name}[/bold]: {n:,} samples at {rate:g} Hz -> {out}")
    table = Table("tau (s)", "theoretical ADEV", title="Theory (NIST SP 1065)")
    for t, a in zip(tau, theory):
        table.add_row(f"{t:g}", f"{a:.3e}")
    con.print(table)


@simulate_app.command("receiver")
def receiver(
    scenario: str = typer.Option("open-sky", "--environment", help=f"Receiver environment, one of {sorted(ENVIRONMENTS)}."),
    duration: int = typer.Option(3600, "--duration", help="Duration (s)."),
    receivers: int = typer.Option(3, "--receivers", help="Number of receivers (independent errors)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the run (numpy SeedSequence)."),
    out: Path = typer.Option(Path("receivers.csv"), "--out", help="Output file: CSV or .parquet, one row per receiver and second."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Simulate GNSS timing receivers: 1PPS error, qErr, fix, satellites, GDOP, UTC and leap seconds."""
    from chronofuse.analysis.metrics import gdop_over_5_fraction
    from chronofuse.io.tables import write_table
    from chronofuse.models.receiver import simulate_receivers

    quiet_output(quiet)
    with user_errors():
        with progress_reporter("simulate receiver") as say:
            say(f"{receivers} x {duration:,} s")
            truth = simulate_receivers(scenario, duration, receivers, seed)
            frame = truth.to_frame(0)
            say(f"writing {out}")
            write_table({c: frame[c].to_numpy() for c in frame.columns}, out)
    rows = []
    for r in range(receivers):
        corrected = truth.pps_error_s[0, r] + truth.epochs.qerr_s[0, r]  # u-blox qErr sign: add it
        valid = corrected[np.isfinite(corrected)]
        rows.append({
            "receiver": r + 1,
            "pps_rms_ns": float(np.sqrt(np.mean(valid**2)) * 1e9) if valid.size else None,
            "fix_fraction": float(np.mean(truth.epochs.has_fix[0, r])),
            "gdop_over_5_fraction": gdop_over_5_fraction(truth.epochs.gdop[0, r]),
        })
    if json_out:
        print_json({"scenario": scenario, "receivers": receivers, "duration_s": duration, "out": str(out),
                    "summary": rows})
        return
    con = human_console(False)
    table = Table("receiver", "1PPS rms after qErr (ns)", "fix", "GDOP > 5 (with fix)", title=f"{scenario}, {duration:,} s -> {out}")
    for row in rows:
        rms = "-" if row["pps_rms_ns"] is None else f"{row['pps_rms_ns']:.2f}"
        table.add_row(str(row["receiver"]), rms, f"{row['fix_fraction']:.1%}", f"{row['gdop_over_5_fraction']:.1%}")
    con.print(table)

"""``chronofuse position`` and ``chronofuse reproduce positioning``: GNSS, GNSS/INS and smoothed solutions."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import (
    fail,
    human_console,
    print_json,
    progress_reporter,
    quiet_output,
    run_reproduction,
    user_errors,
)
from chronofuse.cli.reproduce import reproduce_app
from chronofuse.gnss.simulate import ENVIRONMENTS
from chronofuse.positioning.scenario import MAX_SPEED_M_PER_S, SYSTEMS


def register(app: typer.Typer) -> None:
    app.command("position")(position)


def _table(summary: dict, title: str) -> Table:
    table = Table("solution", "CEP50 (m)", "CEP95 (m)", "vertical 95 % (m)", "availability",
                  "bridging 2 m / 10 m (s)", title=title)
    for name, m in summary["solutions"].items():
        b = m["bridging_s"]
        table.add_row(name, f"{m['cep50_m']:.2f}", f"{m['cep95_m']:.2f}", f"{m['vertical95_m']:.2f}",
                      f"{m['availability']:.1%}", f"{b['2m']:g} / {b['10m']:g}")
    return table


def position(
    scenario: str = typer.Option("urban-canyon", "--environment", help=f"Signal environment of the drive, one of {sorted(ENVIRONMENTS)}."),
    systems: str = typer.Option("gps+bds", "--systems", help=f"One of {sorted(SYSTEMS)}."),
    ins: str = typer.Option("industrial", "--ins", help="IMU grade: none, consumer, industrial or tactical."),
    smooth: bool = typer.Option(False, "--smooth", help="Add the RTS-smoothed GNSS/INS solution."),
    duration: float = typer.Option(600.0, "--duration", help="Drive length (s; 1 Hz GNSS)."),
    trials: int = typer.Option(10, "--trials", help="Monte Carlo trials."),
    seed: int = typer.Option(0, "--seed", help="Seed of the run."),
    imu_rate: float = typer.Option(100.0, "--imu-rate", help="IMU sample rate (Hz, at least 10)."),
    speed: float = typer.Option(12.0, "--speed", help=f"Vehicle speed (m/s, at most {MAX_SPEED_M_PER_S:g})."),
    nav: Path | None = typer.Option(None, "--nav", help="RINEX navigation file: GPS orbits from its broadcast "
                                    "ephemeris (the drive starts at its first record) instead of the model."),
    out: Path | None = typer.Option(None, "--out", help="Report folder: summary.json and PNG figures."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Simulate a drive and compare GNSS-only, GNSS/INS and (with --smooth) RTS-smoothed positions."""
    quiet_output(quiet)
    from chronofuse.experiments.positioning import PositioningConfig, run_positioning, write_report

    if imu_rate < 10.0:
        fail(f"--imu-rate == {imu_rate:g}, must be >= 10 Hz (a loosely coupled INS needs the motion sampled)")
    if not 0.0 < speed <= MAX_SPEED_M_PER_S:
        fail(f"--speed == {speed:g}, must be in (0, {MAX_SPEED_M_PER_S:g}] m/s (the scenarios' road vehicle)")
    with user_errors():
        cfg = PositioningConfig(scenario=scenario, systems=systems, ins=ins, smooth=smooth, duration_s=duration,
                                trials=trials, seed=seed, imu_rate_hz=imu_rate, speed_m_per_s=speed, nav=nav)
        with progress_reporter("position") as say:
            run = run_positioning(cfg, progress=say)
            files = write_report(run, out) if out is not None else []
    summary = run["summary"] | {"files": [str(p) for p in files]}
    if json_out:
        print_json(summary)
        return
    con = human_console(False)
    con.print(_table(summary, f"{scenario}, {systems}, INS {ins}: {trials} trials of {duration:g} s "
                              f"(mean GDOP {summary['gdop_mean']:.2f})"))
    if files:
        con.print(f"report -> {out}/")


@reproduce_app.command("positioning")
def reproduce_positioning(
    quick: bool = typer.Option(False, "--quick", help="Fewer, shorter drives (about a minute)."),
    out: Path = typer.Option(Path("out/reproduce/positioning"), "--out",
                             help="Report folder (created; docs/positioning holds the published run)."),
    seed: int = typer.Option(6300, "--seed", help="Root seed of every drive (6300: the published run)."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """The GNSSDO paper section 6.3: GPS+BDS+INS with smoothing against the claimed CEP95 and vertical 95 %."""
    quiet_output(quiet)
    from chronofuse.experiments.positioning_claims import reproduce_positioning_claims

    summary = run_reproduction("reproduce positioning", reproduce_positioning_claims, out, quick=quick,
                               json_out=json_out, seed=seed)
    if summary is None:
        return
    con = human_console(False)
    table = Table("claim", "source paper", "ours", "physical floor", "verdict", title="The GNSSDO paper section 6.3, measured")
    for row in summary["claims"]:
        table.add_row(row["claim"], f"{row['claimed']:g}", f"{row['ours']:.2f}", row["floor"], row["verdict"])
    con.print(table)
    con.print(f"report -> {out}/")

"""``chronofuse reproduce ...``: the source papers' experiments, one subcommand each."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import human_console, quiet_output, run_reproduction
from chronofuse.cli.swarm import reproduce_swarm_command

reproduce_app = typer.Typer(help="Reproduce the source papers' experiments and write their reports.",
                            no_args_is_help=True)


def register(app: typer.Typer) -> None:
    app.add_typer(reproduce_app, name="reproduce")


reproduce_app.command("swarm")(reproduce_swarm_command)


@reproduce_app.command("integrity")
def integrity(
    quick: bool = typer.Option(False, "--quick", help="Fewer trials (under a minute)."),
    out: Path = typer.Option(Path("out/reproduce/integrity"), "--out",
                             help="Report folder (created; docs/integrity holds the published run)."),
    seed: int | None = typer.Option(None, "--seed", help="Root seed (default: the published run's, 20260402)."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """The detection patent: false-alarm rate, training effect, and detection of steps, ramps, drag-off and bursts."""
    quiet_output(quiet)
    from chronofuse.experiments.integrity import DETECTORS, run_integrity

    summary = run_reproduction("reproduce integrity", run_integrity, out, quick=quick, json_out=json_out, seed=seed)
    if summary is None:
        return
    con = human_console(False)
    table = Table("detector", "nominal P_fa", "empirical", "99 % CI", title="False-alarm rate (independent epochs)")
    for r in summary["false_alarms"]:
        table.add_row(r["detector"], f"{r['pfa']:g}", f"{r['rate_independent']:.3g}",
                      f"[{r['ci99_lo']:.3g}, {r['ci99_hi']:.3g}]")
    con.print(table)
    table = Table("anomaly", *DETECTORS, title="Smallest size (sigma_df) detected with probability >= 0.9")
    for kind, best in summary["min_size_p90"].items():
        table.add_row(kind, *("-" if best[d] is None else f"{best[d]:g}" for d in DETECTORS))
    con.print(table)
    con.print(f"report -> {out}/ ({', '.join(summary['files'])})")


@reproduce_app.command("gnssdo")
def gnssdo(
    quick: bool = typer.Option(False, "--quick", help="Shorter runs and fewer trials (a few minutes)."),
    out: Path = typer.Option(Path("out/reproduce/gnssdo"), "--out",
                             help="Report folder (created; docs/gnssdo holds the published run)."),
    seed: int = typer.Option(0, "--seed", help="Root seed (0: the published run)."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """The GNSSDO paper section 6: time error, convergence, ADEV, holdover and smoothing against the source paper's claims."""
    quiet_output(quiet)
    from chronofuse.experiments.gnssdo_reproduce import reproduce_gnssdo

    summary = run_reproduction("reproduce gnssdo", reproduce_gnssdo, out, quick=quick, json_out=json_out, seed=seed)
    if summary is None:
        return
    human_console(False).print(f"report -> {out}/ ({', '.join(summary['files'])})")

"""``chronofuse run [SCENARIO.toml]``: the main job on a scenario, writing a report folder."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import human_console, print_json, progress_reporter, user_errors
from chronofuse.experiments.main_job import run_scenario
from chronofuse.experiments.scenario import load_scenario


def register(app: typer.Typer) -> None:
    app.command("run")(run)


def run(
    scenario: Path | None = typer.Argument(None, help="Scenario TOML file (default: the built-in default scenario)."),
    out: Path = typer.Option(Path("out/run"), "--out", help="Report folder (created)."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
) -> None:
    """Simulate a scenario (oscillator + GNSS receivers) and write its report: JSON, CSV and PNG plots."""
    with user_errors():
        scn = load_scenario(scenario)
        with progress_reporter(f"run {scn.name}") as say:
            report = run_scenario(scn, out, progress=say)
    if json_out:
        print_json({"out": str(report.out_dir), **report.summary})
        return
    con = human_console(False)
    s = report.summary
    osc = s["oscillator"]
    con.print(f"[bold]{scn.name}[/bold]: {scn.description}")
    con.print(f"oscillator {osc['model']}: free-run phase after {scn.duration_s:g} s = "
              f"{osc['free_run']['max_abs_ns']:.1f} ns max |x|")
    table = Table("receiver", "1PPS rms (ns)", "peak-to-peak (ns)", "missing", "fix", "GDOP > 5 (with fix)",
                  title=f"Receivers ({scn.receivers.scenario}), 1PPS after qErr correction")
    for label, rx in s["receivers"].items():
        pe = rx["pps_error"]
        table.add_row(label, f"{pe.get('rms_ns', float('nan')):.2f}", f"{pe.get('peak_to_peak_ns', float('nan')):.1f}",
                      str(pe["n_missing"]), f"{rx['fix_fraction']:.1%}", f"{rx['gdop_over_5_fraction']:.1%}")
    con.print(table)
    if s["mask"] is not None:
        verdicts = ", ".join(f"{k} {'PASS' if v['passed'] else 'FAIL'}" for k, v in s["mask"]["receivers"].items())
        con.print(f"mask {s['mask']['name']}: {verdicts}")
    con.print(f"report -> {report.out_dir}/ ({', '.join(s['files'])})")

"""``chronofuse run [SCENARIO.toml]``: the main job on a scenario, writing a report folder."""

from __future__ import annotations

from pathlib import Path

import typer

# The main job (the whole toolkit) and the console are imported inside the command, so that `run --help`
# pays only for typer.


def register(app: typer.Typer) -> None:
    app.command("run")(run)


def run(
    scenario: Path | None = typer.Argument(None, help="Scenario TOML file (default: the built-in default scenario)."),
    out: Path = typer.Option(Path("out/run"), "--out", help="Report folder (created)."),
    seed: int | None = typer.Option(None, "--seed", help="Root seed, replacing the scenario's own."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Simulate a scenario and write its report (JSON, CSV, PNG): the free-running OCXO and the receivers, the
    OCXO disciplined to them through a GNSS outage, and followers keeping its time over two-way links."""
    from rich.table import Table

    from chronofuse.cli.common import human_console, print_json, progress_reporter, quiet_output, user_errors
    from chronofuse.experiments.main_job import run_scenario
    from chronofuse.experiments.scenario import load_scenario
    from chronofuse.report.html import mask_reason

    quiet_output(quiet)
    with user_errors():
        scn = load_scenario(scenario)
        if seed is not None:
            scn = type(scn).model_validate({**scn.model_dump(), "seed": seed})
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
        for k, v in s["mask"]["receivers"].items():
            con.print(f"mask {s['mask']['name']}: {k} {'PASS' if v['passed'] else 'FAIL'} ({mask_reason(v)})")
    if "discipline" in s and "skipped" in s["discipline"]:
        con.print(f"no disciplining: {s['discipline']['skipped']}")
    elif "discipline" in s:
        d = s["discipline"]
        con.print(f"disciplined ({d['controller']}): time error rms {d['time_error_rms_ns']:.1f} ns "
                  f"(clairvoyant {d['optimal_rms_ns']:.1f} ns), peak-to-peak {d['time_error_pp_ns']:.1f} ns; "
                  f"holdover {d.get('holdover_s', 0):g} s -> {d.get('holdover_error_ns', float('nan')):.1f} ns")
        con.print("states (s): " + ", ".join(f"{k} {v:g}" for k, v in d["state_seconds"].items()))
        for name, v in d.get("masks", {}).items():
            con.print(f"disciplined output, mask {name}: {'PASS' if v['passed'] else 'FAIL'} ({mask_reason(v)})")
    if "swarm" in s:
        w = s["swarm"]
        table = Table("follower", "to leader rms (ns)", "to true time rms (ns)", "to leader in the outage (ns)",
                      title=f"Swarm ({w['algorithm']}, {w['topology']}): leader to true time rms "
                            f"{w['leader_to_true_rms_ns']:.1f} ns")
        for i in range(w["followers"]):
            outage = w["to_leader_in_outage_rms_ns"]
            table.add_row(str(i + 1), f"{w['to_leader_rms_ns'][i]:.3f}", f"{w['to_true_rms_ns'][i]:.1f}",
                          "-" if outage is None else f"{outage[i]:.3f}")
        con.print(table)
    con.print(f"report -> {report.out_dir}/report.html ({len(s['files'])} files: report.html, summary.json, "
              "timeseries.csv, PNG plots)")

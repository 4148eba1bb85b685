"""``chronofuse gnssdo``: discipline a simulated oscillator to GNSS receivers (or a real 1PPS record)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import fail, human_console, print_json, progress_reporter, quiet_output, user_errors


def register(app: typer.Typer) -> None:
    app.command("gnssdo")(gnssdo)


#: Options that say how the simulated receivers are made and fused; a real reference record replaces all that.
SIMULATION_ONLY = ("scenario", "receivers", "gdop_max", "dac_bits", "fusion", "design", "integrity_pfa", "duration")


def _given(ctx: typer.Context, name: str) -> bool:
    """Whether option ``name`` was given on the command line (its source's name: typer has its own enum)."""
    return getattr(ctx.get_parameter_source(name), "name", None) == "COMMANDLINE"


def gnssdo(
    ctx: typer.Context,
    scenario: str = typer.Option("open-sky", "--environment",
                                 help="Receiver environment: open-sky, urban-canyon, outage, outliers, spoofing, "
                                      "paper-canyon, jamming or tunnel."),
    controller: str = typer.Option("gated-kalman", "--controller",
                                   help="Servo: null, pi, kalman, adaptive-kalman, gated-kalman, huber-kalman, or one "
                                        "a plugin registers (group chronofuse.servos); default gated-kalman, picked "
                                        "by measurement."),
    receivers: int = typer.Option(3, "--receivers", help="Number of receivers fused."),
    duration: int = typer.Option(86_400, "--duration", help="Run length (s, >= 3600)."),
    trials: int = typer.Option(1, "--trials", help="Monte Carlo trials (vectorized)."),
    seed: int = typer.Option(0, "--seed", help="Root seed (>= 0)."),
    rate: float = typer.Option(1.0, "--rate", help="Loop rate (Hz; the 1PPS: 1)."),
    gdop_max: float = typer.Option(5.0, "--gdop-max", help="A receiver is usable only with GDOP below this (>= 1)."),
    dac_bits: int | None = typer.Option(None, "--dac-bits", help="DAC resolution (default: the oscillator's)."),
    loop_bandwidth: float | None = typer.Option(None, "--loop-bandwidth",
                                                help="pi only: design the PI from this natural frequency (Hz)."),
    fusion: str = typer.Option("fusion", "--fusion", help="fusion (inverse-variance) or selection (best source)."),
    design: str = typer.Option("fit", "--design",
                               help="fit (the Kalman controllers learn the noise from a day's calibration record) or "
                                    "datasheet (designed from the oscillator preset and the receivers' figures)."),
    integrity_pfa: float | None = typer.Option(None, "--integrity-pfa",
                                               help="Exclude receivers on clock-bias HOD alarms at this P_fa."),
    oscillator: str = typer.Option("ocxo", "--oscillator", help="Oscillator preset: tcxo, ocxo, rb or csac."),
    oscillator_file: Path | None = typer.Option(None, "--oscillator-file",
                                                help="An oscillator JSON file (chronofuse characterize --out writes "
                                                     "oscillator.json) instead of a preset."),
    reference: Path | None = typer.Option(None, "--reference",
                                          help="Real 1PPS phase record against a reference clock (1 Hz, no gaps): a "
                                          "phase file, or a field log's first clock (a ts2phc or phc2sys offset). "
                                          "Its first 4 h calibrate the cable offset and the servo's noise."),
    out: Path | None = typer.Option(None, "--out", help="Report folder (PNG plots, summary.json)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """GNSS-disciplined oscillator (the GNSSDO paper): time error, convergence, holdover, states and ADEV."""
    quiet_output(quiet)
    from chronofuse.experiments.gnssdo import GnssdoSetup, run_gnssdo, run_reference

    if not rate > 0:
        fail(f"--rate == {rate}, must be > 0")
    if rate != 1.0:
        fail(f"--rate == {rate}, must be 1 (the loop runs on the 1PPS, one sample per second)")
    if reference is not None:
        given = [p.opts[0] for p in ctx.command.params if p.name in SIMULATION_ONLY and _given(ctx, p.name)]
        if given:
            fail(f"{', '.join(given)}: not used with --reference (the record is the receiver; its length the run's)")
    if oscillator_file is not None and _given(ctx, "oscillator"):
        fail("--oscillator, --oscillator-file: give one (the file is the oscillator)")
    with user_errors():
        model = None
        if oscillator_file is not None:
            from chronofuse.discipline.characterize import read_oscillator_file

            model = read_oscillator_file(oscillator_file)
        setup = GnssdoSetup(scenario=scenario, controller=controller, receivers=receivers, duration_s=duration,
                            trials=trials, seed=seed, gdop_max=gdop_max, dac_bits=dac_bits, oscillator=oscillator,
                            loop_bandwidth_hz=loop_bandwidth, fusion=fusion, integrity_pfa=integrity_pfa,
                            design=design, oscillator_model=model)
        with progress_reporter("gnssdo") as say:
            if reference is not None:
                summary = run_reference(reference, controller, seed=seed, trials=trials, progress=say,
                                        oscillator=oscillator, oscillator_model=model)
                if out is not None:
                    from chronofuse.report.gnssdo import plot_adev
                    from chronofuse.report.jsonio import dumps

                    out.mkdir(parents=True, exist_ok=True)
                    plot_adev(summary["adev"], out / "adev.png", f"ADEV against {reference.name}")
                    (out / "summary.json").write_text(dumps(summary) + "\n")
                    summary["files"] = ["adev.png", "summary.json"]
            else:
                summary = run_gnssdo(setup, out, progress=say)
    if out is not None:
        summary["out"] = str(out)
    if json_out:
        print_json(summary)
        return
    con = human_console(False)
    table = Table("metric", "value", title=f"GNSSDO: {summary.get('scenario', 'reference')}, {controller}")
    for key in ("time_error_rms_ns", "time_error_pp_ns", "convergence_s", "optimal_rms_ns", "ratio_to_optimal",
                "holdover_error_ns", "holdover_s"):
        if key in summary:
            value = summary[key]
            ci = summary.get(f"{key}_ci_ns" if key.endswith("_ns") else f"{key}_ci")
            text = "never" if value is None else f"{value:.4g}"
            table.add_row(key, text if not ci else f"{text} (95 % CI {ci[0]:.4g}..{ci[1]:.4g})")
    for state, seconds in summary["state_seconds"].items():
        table.add_row(f"seconds {state}", f"{seconds:.0f}")
    con.print(table)
    if summary.get("optimal_note"):
        con.print(f"optimal_rms_ns: {summary['optimal_note']}")
    check = summary.get("drag_check")
    if check and check["slowest_rate_ns_per_s"] is None:
        con.print(f"spoofing: no drag is caught before |TE| reaches {check['budget_ns']:g} ns with these receivers'"
                  f" noise; a drag is refused from {check['refused_from_te_ns']:.0f} ns")
    elif check:
        con.print(f"spoofing: drags from {check['slowest_rate_ns_per_s']:.3g} ns/s are refused before |TE| reaches"
                  f" {check['budget_ns']:g} ns")
    if summary.get("unresolved_offset_alarm_seconds"):
        con.print(f"unresolved offset: {summary['unresolved_offset_alarm_seconds']:.0f} s in alarm (per trial): the "
                  "receivers were let back in after a refusal and may carry an offset the oscillator could not "
                  "resolve, so the output is not claimed locked")
    if summary.get("no_usable_receiver"):
        con.print("no usable receiver at any second: the oscillator stayed in free-run")
    if out is not None:
        con.print(f"report -> {out}/ ({', '.join(summary.get('files', []))})")

"""``chronofuse characterize RECORD``: an oscillator's noise, drift and temperature coefficient from its
measured record, the fit against the measured ADEV, a loop, holdover, and an oscillator file for ``gnssdo``
(the algorithm: :mod:`chronofuse.discipline.characterize`)."""

from __future__ import annotations

from pathlib import Path

import typer

from chronofuse.cli.common import fail, human_console, print_json, progress_reporter, quiet_output, user_errors


def register(app: typer.Typer) -> None:
    app.command("characterize")(characterize)


def characterize(
    file: Path = typer.Argument(..., help="The oscillator's phase (s) or frequency record against a reference: the "
                                "files and options of chronofuse stability (1 or 2 columns, a header, .gz ok)."),
    kind: str | None = typer.Option(None, "--kind", help="phase (seconds) or freq (fractional frequency); default: "
                                    "from the value column's unit or name, phase without either."),
    rate: float | None = typer.Option(None, "--rate", help="Sample rate (Hz; required without a time column or a "
                                      "stated interval)."),
    column: str | None = typer.Option(None, "--column", help="Value column (name or 1-based number)."),
    nominal_hz: float | None = typer.Option(None, "--nominal-hz", help="For frequency in Hz: the nominal frequency."),
    temperature_column: str | None = typer.Option(None, "--temperature-column",
                                                  help="A column of the oscillator's temperature (degC; kelvin when "
                                                       "its name ends in _k): fits the temperature coefficient."),
    receiver_sigma: float = typer.Option(10e-9, "--receiver-sigma",
                                         help="White phase noise of the receiver the loop is designed for (s)."),
    oscillator: str = typer.Option("ocxo", "--oscillator", help="Preset whose nominal frequency, EFC gain and DAC "
                                   "the oscillator file takes (a record cannot tell them): tcxo, ocxo, rb or csac."),
    trials: int = typer.Option(200, "--trials", help="Monte Carlo trials of the holdover prediction."),
    seed: int = typer.Option(0, "--seed", help="Root seed of the holdover trials (>= 0)."),
    out: Path | None = typer.Option(None, "--out", help="Report folder: adev.png, characterization.json and "
                                    "oscillator.json (for gnssdo --oscillator-file)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Fit an oscillator's h-coefficients, drift and temperature coefficient to its record; loop and holdover."""
    quiet_output(quiet)
    if kind is not None and kind not in ("phase", "freq"):
        fail(f"--kind {kind!r}: choose from phase, freq")
    if seed < 0:
        fail(f"--seed == {seed}, must be >= 0")
    with user_errors():
        from chronofuse.discipline.characterize import characterize_file, oscillator_document
        from chronofuse.models.oscillator_presets import preset

        base = preset(oscillator)
        with progress_reporter("characterize") as say:
            say("fitting")
            result = characterize_file(file, kind=kind, rate_hz=rate, column=column, nominal_hz=nominal_hz,
                                       temperature_column=temperature_column, receiver_sigma_s=receiver_sigma,
                                       holdover_trials=trials, seed=seed)
    doc = {"file": str(file), **result.to_dict()}
    osc_doc = oscillator_document(result, base, name=f"{file.name.split('.')[0]}", source=file.name)
    doc["oscillator"] = osc_doc
    if out is not None:
        from chronofuse.report.gnssdo import plot_characterization
        from chronofuse.report.jsonio import dumps

        out.mkdir(parents=True, exist_ok=True)
        plot_characterization(doc, out / "adev.png", f"{file.name}: measured and fitted ADEV")
        (out / "characterization.json").write_text(dumps(doc) + "\n")
        (out / "oscillator.json").write_text(dumps(osc_doc) + "\n")
        doc["files"] = ["adev.png", "characterization.json", "oscillator.json"]
        doc["out"] = str(out)
    if json_out:
        print_json(doc)
        return
    from rich.table import Table

    con = human_console(False)
    con.print(f"[bold]{file}[/bold]: {result.n_samples:,} samples at {result.rate_hz:g} Hz", highlight=False)
    fit = Table("term", "value", title="fitted model")
    for key, value in result.h.as_dict().items():
        fit.add_row(key, f"{value:.4g}")
    fit.add_row("drift_per_s", f"{result.drift_per_s:.4g} +- {result.drift_sigma_per_s:.2g}")
    if result.temp_coeff_per_K is not None:
        fit.add_row("temp_coeff_per_K", f"{result.temp_coeff_per_K:.4g} +- {result.temp_coeff_sigma_per_K:.2g}")
    con.print(fit)
    a = result.adev
    table = Table("tau (s)", "measured ADEV", "lo", "hi", "model", "inside",
                  title=f"overlapping ADEV, {100 * 0.95:.0f} % simultaneous intervals (each at {100 * a.ci:.2f} %)")
    for k in range(a.tau_s.size):
        table.add_row(f"{a.tau_s[k]:g}", f"{a.dev[k]:.4e}", f"{a.lo[k]:.4e}", f"{a.hi[k]:.4e}",
                      f"{result.model_adev[k]:.4e}", "yes" if result.inside[k] else "NO")
    con.print(table)
    loop = result.loop
    con.print(f"loop for a receiver of {loop.receiver_sigma_s:.3g} s white noise: crossover {loop.crossover_s:.4g} s; "
              f"Kalman steady-state gains phase {loop.kalman_gains[0]:.4g}, frequency {loop.kalman_gains[1]:.4g}/s "
              f"(phase time constant {loop.kalman_phase_time_constant_s:.4g} s); PI kp {loop.pi_kp:.4g}, "
              f"ki {loop.pi_ki:.4g} (natural frequency {loop.pi_natural_hz:.4g} Hz)", highlight=False)
    hold = Table("horizon", "rms TE (ns)", "95 % CI (ns)", "95 % spread (ns)", "analytic (ns)",
                 title=f"holdover after the record ({result.holdover[0]['trials']} trials)")
    for row in result.holdover:
        hold.add_row(f"{row['horizon_s'] / 3600:g} h", f"{row['rms_s'] * 1e9:.4g}",
                     f"{row['rms_ci_s'][0] * 1e9:.4g}..{row['rms_ci_s'][1] * 1e9:.4g}",
                     f"{row['spread_95_s'][0] * 1e9:.4g}..{row['spread_95_s'][1] * 1e9:.4g}",
                     f"{row['analytic_s'] * 1e9:.4g}")
    con.print(hold)
    for note in result.notes:
        con.print(f"note: {note}", markup=False)
    if out is not None:
        con.print(f"report -> {out}/ ({', '.join(doc['files'])})")

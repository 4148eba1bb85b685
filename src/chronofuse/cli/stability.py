"""``chronofuse stability FILE``: stability statistics of a phase or frequency record.

Start-up overlaps the read: the stability engine (numba, scipy) is imported, and the requested statistics'
compiled kernels loaded, on a thread while the main thread reads the file (pyarrow's parser releases the
GIL), so this module names the statistics and masks itself (``STATISTIC_NAMES``, ``MASK_NAMES``; a test checks them against the engine's) instead of importing
the engine to list them.
"""

from __future__ import annotations

import importlib
import os
import threading
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import typer

from chronofuse.cli.common import (
    collected_warnings,
    fail,
    human_console,
    print_json,
    progress_reporter,
    quiet_output,
    user_errors,
)
from chronofuse.cli.loading import loading
from chronofuse.io.records import read_record
from chronofuse.validation import InputError, InputWarning

#: The engine's statistics (``chronofuse.analysis.stability.STATISTICS``) and ITU-T masks
#: (``chronofuse.analysis.masks.MASKS``), named here for the options' help without importing them.
STATISTIC_NAMES = ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev", "mtotdev", "ttotdev", "htotdev",
                   "theo1", "theobr", "theoh", "tie_rms", "mtie")
MASK_NAMES = ("prtc-a", "prtc-b", "g811", "eprtc", "t-bc-a", "t-bc-b", "t-bc-c", "t-bc-d", "t-bc-a-vartemp",
              "t-bc-b-vartemp", "t-bc-c-vartemp", "g8271.1-c", "g8271.1-c-enhanced", "g8271.1-c-access",
              "g8262-opt1", "g8262-opt1-temp", "g8262-opt2")
_ENGINE_MODULES = ("chronofuse.analysis.stability", "chronofuse.analysis.stability.taus")


def _load_meanwhile(modules: tuple[str, ...], statistics: list[str]) -> threading.Thread:
    """Start importing ``modules`` on a daemon thread, then running each of ``statistics`` once on a short
    synthetic record (256 points), which loads their compiled numba kernels from the cache: both overlap
    the main thread's read of the file. The thread is joined before the engine is used; it writes
    nothing, and an error in it is raised again where the main thread does the same."""

    def work() -> None:
        try:
            for name in modules:
                importlib.import_module(name)
            from chronofuse.analysis import stability as st

            x = np.cumsum(np.cos(np.arange(256) * 2.3)) * 1e-9  # emits no warning for any statistic
            for name in statistics:
                st.compute(name, x, 1.0, st.tau_grid("octave", x.size, 1.0, name))
        except Exception:  # the main thread's own import or computation raises it where it is handled
            return

    thread = threading.Thread(target=work, name="chronofuse-warm-up", daemon=True)
    thread.start()
    return thread


def register(app: typer.Typer) -> None:
    app.command("stability")(stability)


def stability(
    file: Path = typer.Argument(..., help="Phase or frequency record: 1 or 2 columns (time, value), CSV or whitespace, "
                                "a header block, units in the header, .gz ok; or a field log: ptp4l/phc2sys/ts2phc, chrony, "
                                "RTKLIB .stat, gpsd JSON, Trimble TSIP (--station picks its clock, --column its column)."),
    kind: str | None = typer.Option(None, "--kind", help="phase (seconds) or freq (fractional frequency); default: from "
                                    "the value column's unit or name, phase without either."),
    rate: float | None = typer.Option(None, "--rate", help="Sample rate (Hz; required without a time column or a "
                                      "stated interval; overrides a time column that disagrees, with a warning)."),
    dev: str = typer.Option("adev,mdev,tdev", "--dev", help=f"Comma list of: {', '.join(STATISTIC_NAMES)}."),
    taus: str = typer.Option("octave", "--taus", help="Averaging times: octave, decade, all, or a comma-separated list (s)."),
    mask: str | None = typer.Option(None, "--mask", help=f"ITU-T masks to check, comma list of: {', '.join(MASK_NAMES)}."),
    plot: Path | None = typer.Option(None, "--plot", help="Write a PNG plot of every statistic, the masks and the verdict."),
    column: str | None = typer.Option(None, "--column", help="Value column (name or 1-based number)."),
    station: str | None = typer.Option(None, "--station", help="RINEX clock product: the station to analyse; a field log (ptp4l, phc2sys, chrony, ...): the clock (default: the first)."),
    nominal_hz: float | None = typer.Option(None, "--nominal-hz", help="For frequency in Hz: the nominal frequency."),
    ci: float = typer.Option(0.683, "--ci", help="Confidence factor of the intervals."),
    no_bias_correction: bool = typer.Option(False, "--no-bias-correction", help="Report total deviations without bias correction."),
    zero_is_gap: bool = typer.Option(False, "--zero-is-gap", help="Read a value of 0 as a missing sample (Stable32's convention)."),
    gap_rule: str | None = typer.Option(None, "--gap-rule", help="samples (skip a term only when its own samples are "
                                        "missing; default for phase) or span (when any sample it spans is; default and "
                                        "the right rule for frequency input)."),
    te_offset: str | None = typer.Option(None, "--te-offset", help="measured (the record's constant offset is time "
                                         "error: max |TE| and cTE are checked; the default for phase) or arbitrary (a "
                                         "counter's offset against a reference that is not the time scale, or phase "
                                         "integrated from frequency: they are not; the default for frequency input)."),
    freq_mean: str = typer.Option("keep", "--freq-mean", help="Frequency input: keep the mean frequency in the "
                                  "integrated phase (TIE rms and MTIE see the offset) or remove it first (allantools' "
                                  "convention)."),
    export_stable32: Path | None = typer.Option(None, "--export-stable32", help="Also write the record read (a field "
                                                "log's clock too) as a Stable32 data file: one value per line, gaps as 0."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV, total deviations, Theo1, TheoBR, TheoH, TIE rms and MTIE, with confidence intervals."""
    quiet_output(quiet)
    names = [d.strip().lower() for d in dev.split(",") if d.strip()]
    unknown = [d for d in names if d not in STATISTIC_NAMES]
    if unknown or not names:
        fail(f"--dev {dev!r}: unknown statistic {unknown}; choose from {', '.join(STATISTIC_NAMES)}")
    mask_names = [m.strip().lower() for m in (mask or "").split(",") if m.strip()]
    bad_masks = [m for m in mask_names if m not in MASK_NAMES]
    if bad_masks or (mask is not None and not mask_names):
        fail(f"--mask {mask!r}: unknown mask {bad_masks}; choose from {', '.join(MASK_NAMES)}")
    for option, value, choices in (("--kind", kind, ("phase", "freq")), ("--gap-rule", gap_rule, ("samples", "span")),
                                   ("--te-offset", te_offset, ("measured", "arbitrary")),
                                   ("--freq-mean", freq_mean, ("keep", "remove"))):
        if value is not None and value not in choices:
            fail(f"{option} {value!r}: choose from {', '.join(choices)}")
    run_notes: list[str] = []
    with user_errors(), collected_warnings() as notes:
        with progress_reporter("stability") as say:
            say("reading")
            with loading():  # the engine loads while the file is read
                importing = _load_meanwhile(
                    _ENGINE_MODULES + (("chronofuse.analysis.masks",) if mask_names else ()), names)
                record = read_record(file, kind=kind, rate_hz=rate, column=column, nominal_hz=nominal_hz,
                                     station=station, zero_is_gap=zero_is_gap)
                importing.join()
            if export_stable32 is not None:
                from chronofuse.io.stable32_export import write_stable32

                write_stable32(export_stable32, record.values, record.rate_hz, record.kind, str(file))
            from chronofuse.analysis import stability as st

            is_freq = record.kind == "freq"
            x = st.frequency_to_phase(record.values, record.rate_hz, freq_mean) if is_freq else record.values
            rule = gap_rule or ("span" if is_freq else "samples")
            if is_freq and gap_rule == "samples" and record.n_gaps:
                warnings.warn(InputWarning(
                    "{gap_rule} samples on frequency input: a phase difference across a missing frequency sample "
                    "is unknown, so terms that span a gap use the value put in it (the record's mean frequency); "
                    "span is the rule that depends on no such value", fields=("gap_rule",)))
            offset = te_offset or ("arbitrary" if is_freq else "measured")
            if mask_names and is_freq and te_offset is None:
                run_notes.append("frequency input: the phase integrated from it has no known constant offset, so "
                                 "max |TE|, cTE and max |TE_L| are not evaluated (--te-offset arbitrary, the default "
                                 "for frequency input)")
            elif mask_names and is_freq and te_offset == "measured":
                warnings.warn(InputWarning("{te_offset} measured on frequency input: the integrated phase starts at 0 "
                                           "by construction, so max |TE| and cTE judge that arbitrary constant",
                                           fields=("te_offset",)))
            results = _compute_all(file, names, x, record.rate_hz, taus, ci, not no_bias_correction, rule, say)
            _warn_blank_taus(results, rule, is_freq)
            verdicts = []
            if mask_names:
                from chronofuse.analysis.masks import MASKS

                asked = [results[m].tau_s for m in ("mtie", "tdev") if m in results]
                asked_taus = np.concatenate(asked) if asked else None
                for name in mask_names:
                    say(f"mask {name}")
                    verdicts.append(MASKS[name].check(x, record.rate_hz, offset=offset, tau_s=asked_taus))
        if plot is not None:
            from chronofuse.analysis.masks import MASKS
            from chronofuse.report.figures import save_figure  # matplotlib only when a plot is asked for
            from chronofuse.report.stability_figure import stability_figure

            plot.parent.mkdir(parents=True, exist_ok=True)
            figure = stability_figure(results, verdicts=verdicts, masks=[MASKS[m] for m in mask_names],
                                      title=f"{file.name} ({record.values.size:,} points, {record.rate_hz:g} Hz)")
            save_figure(figure, plot)
    doc = {
        "file": str(file),
        "n": int(record.values.size),
        "rate": record.rate_hz,
        "kind": record.kind,
        "gaps": record.n_gaps,
        "gap_rule": rule,
        "frequency_mean": freq_mean if is_freq else None,
        "jitter_rms_s": record.jitter_rms_s,
        "jitter_max_s": record.jitter_max_s,
        "notes": list(record.notes) + run_notes,
        "te_offset": offset if mask_names else None,
        "deviations": {name: res.to_dict() for name, res in results.items()},
        "mask": verdicts[0].to_dict() if verdicts else None,
        "masks": [v.to_dict() for v in verdicts],
        "plot": str(plot) if plot is not None else None,
        "warnings": notes,
    }
    if plot is not None:
        from chronofuse.report.html import stability_page

        doc["report"] = str(stability_page(doc, plot))
    if json_out:
        print_json(doc)
        return
    from rich.table import Table  # the human output only

    con = human_console(False)
    timing = (f"; time tags off the grid by {record.jitter_rms_s:.3g} s rms, {record.jitter_max_s:.3g} s at most"
              if record.t_ns is not None else "")
    con.print(f"[bold]{file}[/bold]: {record.values.size:,} {record.kind} points at {record.rate_hz:g} Hz, "
              f"{record.n_gaps} missing{timing}" + (f" (gap rule: {rule})" if record.n_gaps else ""))
    for note in list(record.notes) + run_notes:
        con.print(f"note: {note}", markup=False)
    for note in notes:
        con.print(f"warning: {note}", markup=False)
    for name, res in results.items():
        table = Table("tau (s)", "n", "alpha", "lo", name.upper(), "hi", title=name.upper())
        for k in range(res.tau_s.size):
            table.add_row(f"{res.tau_s[k]:g}", str(res.n[k]), _alpha_label(res, k), _fmt(res.lo[k]), _fmt(res.dev[k]),
                          _fmt(res.hi[k]))
        con.print(table)
    for verdict in verdicts:
        color = {"pass": "green", "fail": "red"}.get(verdict.status, "yellow")
        con.print(f"mask {verdict.clock}: [{color}]{verdict_word(verdict.status)}[/{color}] "
                  f"({verdict_details(verdict)})")
    if plot is not None:
        con.print(f"plot -> {plot}, report -> {doc['report']}")


#: Statistics whose kernels are numba-parallel (``prange``): they already use every core, and numba's
#: fallback threading layer (workqueue, where OpenMP and TBB are absent) must not be entered from two
#: threads at once, so they run one after another in the calling thread.
_PARALLEL_KERNELS = {"mtotdev", "ttotdev", "htotdev", "theo1", "theobr", "theoh"}


def _compute_all(file: Path, names: list[str], x, rate_hz: float, taus: str, ci: float, bias: bool, rule: str,
                 say) -> dict:
    """Every statistic of ``names``, {name: result} in the order asked. The others than
    :data:`_PARALLEL_KERNELS` run on threads side by side: their kernels release the GIL (numba ``nogil``),
    so e.g. OADEV's sums and MTIE's sparse table share the cores; each statistic is a pure function of
    ``x``, so the results are the same as one after another (tested)."""
    args = (x, rate_hz, taus, ci, bias, rule, say)
    side_by_side = [n for n in names if n not in _PARALLEL_KERNELS]
    results = {}
    if len(side_by_side) > 1 and (os.cpu_count() or 1) > 1:
        with ThreadPoolExecutor(max_workers=min(len(side_by_side), os.cpu_count() or 1)) as pool:
            futures = {name: pool.submit(_compute, file, name, *args) for name in side_by_side}
            results = {name: future.result() for name, future in futures.items()}
    for name in names:
        if name not in results:
            results[name] = _compute(file, name, *args)
    return {name: results[name] for name in names}


def _compute(file: Path, name: str, x, rate_hz: float, taus: str, ci: float, bias: bool, rule: str, say):
    """One statistic on the octave/decade/all grid or the listed taus; a record too short for it is an
    error naming the file. ``rule`` is the gap rule of the statistics that have a choice."""
    from chronofuse.analysis import stability as st
    from chronofuse.analysis.stability.taus import parse_taus

    say(name)
    try:
        tau_s = parse_taus(taus, x.size, rate_hz, name)
        spec = st.STATISTICS[name]
        return st.compute(name, x, rate_hz, tau_s, ci=ci, bias_correction=bias,
                          gap_rule=rule if rule in spec.gap_rules else None)
    except InputError as exc:
        if "taus" in exc.fields:
            raise
        raise InputError(f"{name}: {exc.message}", str(file), fields=exc.fields) from None


def _warn_blank_taus(results: dict, rule: str, is_freq: bool) -> None:
    """Warn, per statistic, about the asked taus that kept no term (printed ``-``), and why."""
    for name, res in results.items():
        blank = np.asarray(res.n) == 0
        if not blank.any():
            continue
        why = ("the span rule skips a term when any sample it spans is missing, and with frequency input every "
               "integrated phase point after a missing frequency sample is unknown" if rule == "span" and is_freq
               else f"every term has a missing sample under the {rule} rule")
        taus = ", ".join(f"{t:g}" for t in np.asarray(res.tau_s)[blank])
        warnings.warn(InputWarning(f"{name}: {int(blank.sum())} of {blank.size} taus have no term and are left "
                                   f"blank (tau {taus} s): {why}"))


def verdict_word(status: str) -> str:
    """PASS, FAIL, INCOMPLETE or NOT EVALUATED (``ClockVerdict.status`` as printed)."""
    return status.upper()


def verdict_details(verdict) -> str:
    """One line saying which limits failed, at every failing tau, and the cTE/dTE split."""
    return verdict.summary()


def _alpha_label(res, k: int) -> str:
    """The noise type, marked when it came from the B1 fallback or was held (a less certain interval)."""
    method = "acf" if res.alpha_method is None else str(res.alpha_method[k])
    return str(res.alpha[k]) if method == "acf" else f"{res.alpha[k]} ({method})"


def _fmt(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{value:.4e}"

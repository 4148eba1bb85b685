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
from chronofuse.validation import InputError

_UNITS_S = {"tdev", "ttotdev", "tie_rms", "mtie"}
#: The engine's statistics (``chronofuse.analysis.stability.STATISTICS``) and ITU-T masks
#: (``chronofuse.analysis.masks.MASKS``), named here for the options' help without importing them.
STATISTIC_NAMES = ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev", "mtotdev", "ttotdev", "htotdev",
                   "theo1", "tie_rms", "mtie")
MASK_NAMES = ("prtc-a", "prtc-b", "g811")
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
    file: Path = typer.Argument(..., help="Phase or frequency record: 1 or 2 columns (time, value), CSV or whitespace, .gz ok."),
    kind: str = typer.Option("phase", "--kind", help="phase (seconds) or freq (fractional frequency)."),
    rate: float | None = typer.Option(None, "--rate", help="Sample rate (Hz; required without a time column, "
                                      "overrides a time column that disagrees, with a warning)."),
    dev: str = typer.Option("adev,mdev,tdev", "--dev", help=f"Comma list of: {', '.join(STATISTIC_NAMES)}."),
    taus: str = typer.Option("octave", "--taus", help="Averaging times: octave, decade, all, or a comma-separated list (s)."),
    mask: str | None = typer.Option(None, "--mask", help=f"ITU-T mask to check: {', '.join(MASK_NAMES)}."),
    plot: Path | None = typer.Option(None, "--plot", help="Write a PNG plot of the deviations."),
    column: str | None = typer.Option(None, "--column", help="Value column (name or 1-based number)."),
    station: str | None = typer.Option(None, "--station", help="RINEX clock product: the station to analyse (default: the first)."),
    nominal_hz: float | None = typer.Option(None, "--nominal-hz", help="For absolute frequency in Hz: the nominal frequency."),
    ci: float = typer.Option(0.683, "--ci", help="Confidence factor of the intervals."),
    no_bias_correction: bool = typer.Option(False, "--no-bias-correction", help="Report total deviations without bias correction."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV, total deviations, Theo1, TIE rms and MTIE, with confidence intervals."""
    quiet_output(quiet)
    names = [d.strip().lower() for d in dev.split(",") if d.strip()]
    unknown = [d for d in names if d not in STATISTIC_NAMES]
    if unknown or not names:
        fail(f"--dev {dev!r}: unknown statistic {unknown}; choose from {', '.join(STATISTIC_NAMES)}")
    if mask is not None and mask not in MASK_NAMES:
        fail(f"--mask {mask!r}: choose from {', '.join(MASK_NAMES)}")
    with user_errors(), collected_warnings() as notes:
        with progress_reporter("stability") as say:
            say("reading")
            with loading():  # the engine loads while the file is read
                importing = _load_meanwhile(
                    _ENGINE_MODULES + (("chronofuse.analysis.masks",) if mask is not None else ()), names)
                record = read_record(file, kind=kind, rate_hz=rate, column=column, nominal_hz=nominal_hz,
                                     station=station)
                importing.join()
            from chronofuse.analysis import stability as st

            x = record.values if kind == "phase" else st.frequency_to_phase(record.values, record.rate_hz)
            results = _compute_all(file, names, x, record.rate_hz, taus, ci, not no_bias_correction, say)
            verdict = None
            if mask is not None:
                from chronofuse.analysis.masks import MASKS

                say(f"mask {mask}")
                verdict = MASKS[mask].check(x, record.rate_hz)
        if plot is not None:
            from chronofuse.report.figures import plot_deviations  # matplotlib only when a plot is asked for

            dimensionless = {k: v for k, v in results.items() if k not in _UNITS_S}
            seconds = {k: v for k, v in results.items() if k in _UNITS_S}
            plot.parent.mkdir(parents=True, exist_ok=True)
            chosen = dimensionless or seconds
            plot_deviations(chosen, plot, ylabel="deviation" if dimensionless else "seconds",
                            title=f"{file.name} ({record.values.size:,} points, {record.rate_hz:g} Hz)")
    doc = {
        "file": str(file),
        "n": int(record.values.size),
        "rate": record.rate_hz,
        "kind": kind,
        "gaps": record.n_gaps,
        "jitter_rms_s": record.jitter_rms_s,
        "jitter_max_s": record.jitter_max_s,
        "deviations": {name: res.to_dict() for name, res in results.items()},
        "mask": verdict.to_dict() if verdict is not None else None,
        "plot": str(plot) if plot is not None else None,
        "warnings": notes,
    }
    if json_out:
        print_json(doc)
        return
    from rich.table import Table  # the human output only

    con = human_console(False)
    timing = (f"; time tags off the grid by {record.jitter_rms_s:.3g} s rms, {record.jitter_max_s:.3g} s at most"
              if record.t_ns is not None else "")
    con.print(f"[bold]{file}[/bold]: {record.values.size:,} {kind} points at {record.rate_hz:g} Hz, "
              f"{record.n_gaps} missing{timing}")
    for note in notes:
        con.print(f"warning: {note}", markup=False)
    for name, res in results.items():
        table = Table("tau (s)", "n", "alpha", "lo", name.upper(), "hi", title=name.upper())
        for k in range(res.tau_s.size):
            table.add_row(f"{res.tau_s[k]:g}", str(res.n[k]), _alpha_label(res, k), _fmt(res.lo[k]), _fmt(res.dev[k]),
                          _fmt(res.hi[k]))
        con.print(table)
    if verdict is not None:
        con.print(f"mask {mask}: {'[green]PASS[/green]' if verdict.passed else '[red]FAIL[/red]'} ({verdict_details(verdict)})")
    if plot is not None:
        con.print(f"plot -> {plot}")


#: Statistics whose kernels are numba-parallel (``prange``): they already use every core, and numba's
#: fallback threading layer (workqueue, where OpenMP and TBB are absent) must not be entered from two
#: threads at once, so they run one after another in the calling thread.
_PARALLEL_KERNELS = {"mtotdev", "ttotdev", "htotdev", "theo1"}


def _compute_all(file: Path, names: list[str], x, rate_hz: float, taus: str, ci: float, bias: bool, say) -> dict:
    """Every statistic of ``names``, {name: result} in the order asked. The others than
    :data:`_PARALLEL_KERNELS` run on threads side by side: their kernels release the GIL (numba ``nogil``),
    so e.g. OADEV's sums and MTIE's sparse table share the cores; each statistic is a pure function of
    ``x``, so the results are the same as one after another (tested)."""
    args = (x, rate_hz, taus, ci, bias, say)
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


def _compute(file: Path, name: str, x, rate_hz: float, taus: str, ci: float, bias: bool, say):
    """One statistic on the octave/decade/all grid or the listed taus; a record too short for it is an
    error naming the file."""
    from chronofuse.analysis import stability as st
    from chronofuse.analysis.stability.taus import parse_taus

    say(name)
    try:
        tau_s = parse_taus(taus, x.size, rate_hz, name)
        return st.compute(name, x, rate_hz, tau_s, ci=ci, bias_correction=bias)
    except InputError as exc:
        if "taus" in exc.fields:
            raise
        raise InputError(f"{name}: {exc.message}", str(file), fields=exc.fields) from None


def verdict_details(verdict) -> str:
    """One line saying which of MTIE, TDEV and max |TE| failed, and where."""
    parts = []
    for res in (verdict.mtie, verdict.tdev):
        bad = res.evaluated & ~res.passed_each
        where = f" at tau {', '.join(f'{t:g}' for t in res.tau_s[bad][:4])} s" if bad.any() else ""
        parts.append(f"{res.metric.upper()} {'pass' if res.passed else 'fail'}{where}")
    if verdict.time_error is not None:
        te = verdict.time_error
        parts.append(f"max |TE| {te.max_abs_te_s * 1e9:.1f} ns {'<=' if te.passed else '>'} {te.limit_s * 1e9:.0f} ns")
    return "; ".join(parts)


def _alpha_label(res, k: int) -> str:
    """The noise type, marked when it came from the B1 fallback or was held (a less certain interval)."""
    method = "acf" if res.alpha_method is None else str(res.alpha_method[k])
    return str(res.alpha[k]) if method == "acf" else f"{res.alpha[k]} ({method})"


def _fmt(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{value:.4e}"

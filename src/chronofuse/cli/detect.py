"""``chronofuse detect FILE``: clock-bias anomaly detection (SPEC 4) on a CSV, UBX or RINEX record.

Mode selection from what the input provides:

* CSV (a time column and a clock-bias column, e.g. ``t_s,clock_bias_s`` or ``*_ns`` columns; ``--column``
  picks the bias column, else one named ``clock_bias*``, else the only non-time column) and u-blox UBX
  (NAV-CLOCK ``clkB``) give one receiver clock bias: **detection** mode.
* RINEX observations with ``--nav NAVFILE`` and ``--position X,Y,Z`` (ECEF metres of the static antenna)
  give per-satellite clock biases: **identification** mode
  (:func:`chronofuse.integrity.identification.identify`: the common receiver clock removed, the same test
  per channel, each channel's noise fitted on its own first ``--train`` seconds; an alarm names its
  satellite).

Noise parameters: ``--h0``, ``--hm2`` and ``--sigma-rho`` together fix the model; ``--train SECONDS``
estimates the missing ones from the first SECONDS of the record (assumed anomaly-free; the test then runs
over the whole record). One of the two is required.

Missing data are skipped and counted, never dropped silently: NaN clock biases, time steps that are a
whole number of sample intervals (the epochs in between are missing), UBX frames that fail their
checksum or are truncated, RINEX epochs without data. ``n_skipped`` in the JSON is their sum. A time step
that is not a whole number of ``1/rate`` intervals (a changed sampling interval) is an error naming the
line: a new interval needs a new detector. Alarm times ``t`` are seconds on the file's time axis (the
time column for CSV, GPS time of week for UBX, seconds from the first epoch for RINEX).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import typer
from rich.table import Table

from chronofuse.cli.common import fail, human_console, print_json, user_errors
from chronofuse.integrity.detector import HodDetector, chi2_thresholds
from chronofuse.io.grid import grid_slots, place_on_grid
from chronofuse.io.records import read_record
from chronofuse.validation import InputDataError

_MAX_TABLE_ROWS = 50


def register(app: typer.Typer) -> None:
    app.command("detect")(detect)


@dataclass(frozen=True)
class ClockBiasInput:
    """One receiver clock bias on a regular grid: ``bias_s`` (epochs,) NaN = missing, ``t`` (epochs,) on the
    file's time axis (s), ``n_skipped`` missing epochs/frames counted from the file."""

    bias_s: np.ndarray
    t: np.ndarray
    n_skipped: int


def sniff_format(path: Path) -> str:
    """``"ubx"``, ``"rinex-obs"``, ``"rinex-nav"`` or ``"csv"`` from the file's first bytes."""
    if not path.exists():
        raise InputDataError("no such file", str(path))
    if path.is_dir():
        raise InputDataError("is a directory, not a data file", str(path))
    with open(path, "rb") as fh:
        head = fh.read(4096)
    if not head:
        raise InputDataError("empty file", str(path))
    if b"\xb5\x62" in head:
        return "ubx"
    first = head.split(b"\n", 1)[0].decode("ascii", errors="replace")
    if "RINEX VERSION / TYPE" in first or "CRINEX VERS" in first:
        kind = first[20:21].upper()
        return "rinex-nav" if kind in ("N", "G", "H") and "CRINEX" not in first else "rinex-obs"
    return "csv"


def _bias_column(path: Path, column: str | None) -> str | None:
    """The bias column: ``column`` if given, else a header name starting with ``clock_bias``, else None."""
    if column is not None:
        return column
    import gzip

    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", encoding="utf-8", errors="replace") as fh:
        for raw in fh:
            line = raw.split("#", 1)[0].strip()
            if line:
                names = [t for t in line.replace(";", ",").replace("\t", ",").replace(" ", ",").split(",") if t]
                return next((n for n in names if n.lower().startswith("clock_bias")), None)
    return None


def read_csv_bias(path: Path, rate_hz: float, column: str | None) -> ClockBiasInput:
    """Clock bias (s) from a CSV/text record via :func:`chronofuse.io.records.read_record` (gaps as NaN)."""
    record = read_record(path, kind="phase", rate_hz=rate_hz, column=_bias_column(path, column))
    t = record.t_ns / 1e9 if record.t_ns is not None else np.arange(record.values.size) / record.rate_hz
    return ClockBiasInput(bias_s=record.values, t=t, n_skipped=record.n_gaps)


# A receiver time-tags its solutions on its own clock: u-blox iTOW steps by 999 or 1001 ms now and then.
UBX_TIME_TOLERANCE = 0.05


def regular_grid(t_s: np.ndarray, values: np.ndarray, interval_s: float, source: str,
                 tolerance: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Place ``values`` at times ``t_s`` on the grid ``t_s[0] + k interval_s``; missing epochs become NaN.

    A step may differ from a whole number of intervals by ``tolerance`` (a fraction of the interval).

    Raises ``InputDataError`` (naming ``source`` and the epoch) when time does not increase or a step is
    not a whole number of intervals (a changed sampling interval). Returns (grid times, grid values).
    """
    steps = np.diff(t_s)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise InputDataError(f"epoch {k + 1}: time is not increasing ({t_s[k - 1]:g} s then {t_s[k]:g} s)", source)
    slots, bad = grid_slots(t_s - t_s[0], interval_s, tolerance)
    if bad >= 0:
        raise InputDataError(
            f"epoch {bad + 1}: time step {steps[bad - 1]:g} s is not a whole number of {interval_s:g} s intervals "
            "(the sampling interval changed: a new interval needs a new detector, check --rate)",
            source,
        )
    grid = place_on_grid(slots, values)
    return t_s[0] + np.arange(grid.size) * interval_s, grid


def read_ubx_bias(path: Path, rate_hz: float) -> ClockBiasInput:
    """Clock bias (s) from UBX NAV-CLOCK frames (corrupt frames skipped and counted by the reader).

    Epochs are placed on the ``1/rate`` grid within :data:`UBX_TIME_TOLERANCE` of an interval (the receiver
    tags solutions on its own clock); missing solutions become NaN epochs, counted in ``n_skipped``.
    """
    from chronofuse.io.ubx import read_nav_clock

    rec = read_nav_clock(path)
    if len(rec.t_s) == 0:
        raise InputDataError("no UBX NAV-CLOCK message", str(path))
    t_rel, bias = regular_grid(np.asarray(rec.t_s, float), np.asarray(rec.clock_bias_s, float), 1.0 / rate_hz,
                               str(path), tolerance=UBX_TIME_TOLERANCE)
    t = float(rec.itow_ms[0]) / 1000.0 + t_rel
    n_missing = int(np.isnan(bias).sum())
    return ClockBiasInput(bias_s=bias, t=t, n_skipped=n_missing + int(rec.n_skipped_frames))


def _training_rows(t: np.ndarray, train_s: float | None) -> slice:
    if train_s is None:
        return slice(0, t.size)
    return slice(0, int(np.searchsorted(t - t[0], train_s, side="left")))


def _fit(det: HodDetector, bias_s: np.ndarray, t: np.ndarray, train_s: float | None, source: str) -> HodDetector:
    if train_s is None:
        return det.fit()
    rows = _training_rows(t, train_s)
    training = bias_s[..., rows]
    if np.isfinite(training).sum() < det.window + 3:
        raise InputDataError(f"--train {train_s:g} s holds {int(np.isfinite(training).sum())} valid epochs; need at "
                             f"least window + 3 = {det.window + 3}", source)
    return det.fit(training)


# Geocentric radius of a static receiver: the WGS 84 polar radius minus the Dead Sea shore, to the
# equatorial radius plus a high mountain (metres).
_EARTH_SURFACE_M = (6_350_000.0, 6_390_000.0)


def _parse_position(text: str) -> np.ndarray:
    try:
        xyz = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise InputDataError(f"--position {text!r}: expected X,Y,Z in ECEF metres") from None
    if xyz.shape != (3,) or not np.isfinite(xyz).all():
        raise InputDataError(f"--position {text!r}: expected three finite numbers X,Y,Z (ECEF metres)")
    radius_m = float(np.linalg.norm(xyz))
    if not _EARTH_SURFACE_M[0] <= radius_m <= _EARTH_SURFACE_M[1]:
        raise InputDataError(f"--position {text!r}: {radius_m / 1e3:.1f} km from the Earth's centre, must be a static "
                             f"receiver near the surface ({_EARTH_SURFACE_M[0] / 1e3:.0f}..{_EARTH_SURFACE_M[1] / 1e3:.0f} km; "
                             "ECEF metres, not degrees or km)")
    return xyz


def _check_length(n_epochs: int, window: int, source: str) -> None:
    if n_epochs - 2 < window:
        raise InputDataError(f"window {window} is longer than the data: {n_epochs} epochs give {max(n_epochs - 2, 0)} "
                             "differences", source)


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
        kind = sniff_format(file)
        det = HodDetector(interval_s=1.0 / rate, window=window, pfa=pfa, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho)
        if kind == "rinex-nav":
            raise InputDataError("this is a RINEX navigation file: give the observation file and --nav NAVFILE",
                                 str(file))
        if kind == "rinex-obs":
            doc = _identification(file, nav, position, det, train)
        else:
            if nav is not None or position is not None:
                raise InputDataError("--nav/--position need a RINEX observation file (identification mode)", str(file))
            data = read_ubx_bias(file, rate) if kind == "ubx" else read_csv_bias(file, rate, column)
            doc = _detection(data, det, train, str(file))
    if json_out:
        print_json(doc)
        return
    _print_human(file, doc)


def _detection(data: ClockBiasInput, det: HodDetector, train: float | None, source: str) -> dict:
    _check_length(data.bias_s.size, det.window, source)
    _fit(det, data.bias_s, data.t, train, source)
    res = det.run(data.bias_s)
    idx = np.flatnonzero(res.alarm)
    alarms = [{"t": float(data.t[k]), "statistic": float(res.statistic[k]), "channel": None} for k in idx]
    return _document("detection", data.bias_s.size, det, alarms, data.n_skipped)


def _identification(obs: Path, nav: Path | None, position: str | None, det: HodDetector, train: float | None) -> dict:
    if nav is None or position is None:
        raise InputDataError("a RINEX observation file needs --nav NAVFILE and --position X,Y,Z (identification "
                             "mode)", str(obs))
    from chronofuse.integrity.identification import channel_clock_biases, identify

    biases = channel_clock_biases(obs, nav, _parse_position(position))
    interval = float(biases.interval_s)
    if not math.isclose(interval, det.interval_s, rel_tol=1e-6):
        raise InputDataError(f"observation interval {interval:g} s does not match --rate ({det.interval_s:g} s): a new "
                             "interval needs a new detector", str(obs))
    n_epochs = int(np.asarray(biases.t_s).size)
    _check_length(n_epochs, det.window, str(obs))
    options = {}
    if train is not None:
        # each channel's noise fitted on its own first valid epochs of the training length
        options["train_epochs"] = max(3, int(round(train / interval)))
    result = identify(biases, det, **options)
    n_skipped = int(result.n_skipped_epochs)  # grid epochs not read, unreadable ones included
    doc = _document("identification", n_epochs, det, result.alarms, n_skipped)
    doc["faulty"] = [{"channel": ch, "t": float(result.first_blame_s[result.satellites.index(ch)])}
                     for ch in result.faulty]
    doc["untested"] = result.untested
    return doc


def _document(mode: str, n_epochs: int, det: HodDetector, alarms: list[dict], n_skipped: int) -> dict:
    return {
        "mode": mode,
        "n_epochs": int(n_epochs),
        "threshold": float(chi2_thresholds(det.pfa, int(det.window))[-1]),
        "window": int(det.window),
        "pfa": float(det.pfa),
        "alarms": alarms,
        "n_alarms": len(alarms),
        "n_skipped": int(n_skipped),
    }


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

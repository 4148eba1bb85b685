"""chrony's logs (``log tracking statistics refclocks`` in chrony.conf) as clock series.

The columns and their signs are chrony's own documentation of the ``log`` directive (chrony.conf(5)):

* ``tracking.log``: date, time (UTC), reference, stratum, frequency (ppm, positive: the local clock runs
  fast), its error bound (ppm), offset (s, positive: the clock is fast of UTC), leap status (``N``, ``+``,
  ``-``, ``?`` = not synchronised), combined sources, offset sd, remaining correction (s, positive: the clock
  is slow), root delay, root dispersion, max error (s; chrony >= 3.5). One series, ``tracking``: phase
  ``offset_s``, frequency ``freq`` (ppm x 1e-6), ``ok`` where the leap status is not ``?``.
* ``statistics.log``: date, time, source, std dev, estimated offset (s, positive: the local clock is fast),
  offset sd, difference frequency (s/s, positive: the local clock gains), its error, stress, Ns, Bs, Nr,
  asymmetry (chrony >= 3.0). One series per source: phase ``offset_s``, frequency ``freq``.
* ``refclocks.log``: date, time (UTC, us), refid, driver poll sequence (``-`` for a filtered sample), leap,
  PPS flag, raw offset, cooked offset (s, positive: the local clock is slow), dispersion. One series per
  reference clock for the raw samples and one (``REFID filtered``) for the filter's output; both carry
  ``offset_s`` = minus the cooked offset, so that every chronofuse phase is local clock minus reference.
  The raw column is kept as chrony prints it (``raw_offset_s``, the driver's measurement, same sign as cooked).

The banner lines chrony repeats (``====`` and the column header, every ``logbanner`` lines) are passed over;
a data line that is not of the log's layout is an error naming its line.
"""

from __future__ import annotations

import calendar
from collections import defaultdict
from pathlib import Path

from chronofuse.io.log_series import LogSeries, log_series
from chronofuse.io.formats import open_text
from chronofuse.validation import InputDataError

__all__ = ["read_chrony", "LAYOUTS"]

#: Column names (after date, time and source) and their kinds, per log; ``_sign`` -1 flips a column into the
#: local-minus-reference convention; None marks a non-numeric column.
LAYOUTS = {
    "tracking": (("stratum", None), ("freq", "freq"), ("freq_bound", "other"), ("offset_s", "phase"),
                 ("leap", None), ("combined", "other"), ("offset_sd_s", "other"), ("remaining_s", "other"),
                 ("root_delay_s", "other"), ("root_dispersion_s", "other"), ("max_error_s", "other")),
    "statistics": (("std_dev_s", "other"), ("offset_s", "phase"), ("offset_sd_s", "other"), ("freq", "freq"),
                   ("freq_error", "other"), ("stress", "other"), ("samples", "other"), ("start_index", "other"),
                   ("runs", "other"), ("asymmetry", "other")),
    "refclocks": (("poll", None), ("leap", None), ("pps", None), ("raw_offset_s", "other"),
                  ("cooked_offset_s", "other"), ("dispersion_s", "other")),
}
_PPM = {("tracking", "freq"), ("tracking", "freq_bound")}
_HEADER_KEYS = {"Freq ppm": "tracking", "Std dev'n": "statistics", "Raw offset": "refclocks"}


def _utc_ns(date: str, time: str, source: str, lineno: int) -> int:
    """Integer ns since 1970 (UTC) of ``YYYY-MM-DD`` and ``HH:MM:SS[.ffffff]``."""
    try:
        y, mo, d = (int(x) for x in date.split("-"))
        hms, _, frac = time.partition(".")
        h, mi, s = (int(x) for x in hms.split(":"))
        whole = calendar.timegm((y, mo, d, h, mi, s, 0, 0, 0))
        return whole * 1_000_000_000 + int((frac + "000000000")[:9])
    except (ValueError, OverflowError):
        raise InputDataError(f"cannot read {date} {time} as a UTC date and time", source, lineno) from None


def _kind_of_row(tokens: list[str]) -> str | None:
    n = len(tokens)
    if 11 <= n <= 14 and tokens[7] in ("N", "+", "-", "?"):  # chrony 4 writes 14; older versions fewer
        return "tracking"
    if n == 9 and tokens[4] in ("N", "+", "-", "?"):
        return "refclocks"
    if n in (12, 13):
        return "statistics"
    return None


def read_chrony(path: str | Path) -> list[LogSeries]:
    """The series of one chrony log (tracking, statistics or refclocks; told by its banner or its columns)."""
    path, source = Path(path), str(Path(path))
    kind = None
    series: dict[str, dict] = {}
    refs: list[tuple[int, str]] = []  # tracking: (line, reference) where the reference changes
    unreferenced = 0
    with open_text(path) as fh:
        for lineno, raw in enumerate(fh, start=1):
            line = raw.strip()
            if not line or line.startswith("="):
                continue
            if "Date (UTC)" in line:
                kind = kind or next((k for key, k in _HEADER_KEYS.items() if key in line), None)
                continue
            tokens = line.split()
            row_kind = _kind_of_row(tokens)
            if kind is None:
                kind = row_kind
                if kind is None:
                    raise InputDataError(f"not a chrony tracking, statistics or refclocks line ({len(tokens)} "
                                         "columns)", source, lineno)
            layout = LAYOUTS[kind]
            if row_kind != kind or len(tokens) - 3 > len(layout):
                raise InputDataError(f"not a line of a chrony {kind} log ({len(tokens)} columns)", source, lineno)
            t_ns = _utc_ns(tokens[0], tokens[1], source, lineno)
            name = "tracking" if kind == "tracking" else tokens[2]  # one local clock; its reference may change
            values = dict(zip((c for c, _ in layout), tokens[3:]))
            if kind == "tracking" and (not refs or refs[-1][1] != tokens[2]):
                refs.append((lineno, tokens[2]))
            if kind == "tracking" and tokens[2] == "0.0.0.0" and tokens[7] == "?":
                unreferenced += 1  # chronyd's row before any source is selected: its zeros measure nothing
                continue
            if kind == "refclocks" and values["poll"] == "-":
                name += " filtered"
            s = series.setdefault(name, {"t": [], "lines": [], "cols": defaultdict(list), "ok": []})
            s["t"].append(t_ns)
            s["lines"].append(lineno)
            s["ok"].append(values.get("leap") != "?")
            for col, col_kind in layout:
                if col_kind is None:
                    continue
                text = values.get(col, "nan")
                try:
                    value = float(text) if text != "-" else float("nan")
                except ValueError:
                    raise InputDataError(f"{col}: cannot read {text!r} as a number", source, lineno) from None
                s["cols"][col].append(value * (1e-6 if (kind, col) in _PPM else 1.0))
            if kind == "refclocks":
                s["cols"]["offset_s"].append(-float(values["cooked_offset_s"]))
    if kind is None:
        raise InputDataError("no chrony log line", source)
    out = []
    for name, s in series.items():
        kinds = {col: k for col, k in LAYOUTS[kind] if k is not None}
        if kind == "refclocks":
            kinds["offset_s"] = "phase"
        cols = {c: s["cols"][c] for c in kinds if len(s["cols"][c]) == len(s["t"])}
        notes = [f"chrony {kind}.log; offsets in s, local clock minus reference"
                 + ("; frequency in ppm read as fractional frequency" if kind == "tracking" else "")]
        if unreferenced:
            notes.append(f"{unreferenced} rows without a reference (0.0.0.0, not synchronised) are not samples")
        out.append(log_series(s["t"], cols, {c: kinds[c] for c in cols}, s["lines"], clock=name,
                              time_scale="unix-utc", fmt="chrony", source=source, phase="offset_s",
                              freq="freq" if "freq" in cols else None, ok=s["ok"], notes=notes,
                              events=[(line, f"reference {ref}") for line, ref in refs]))
    return out

"""gpsd's JSON reports (``gpspipe -w``, or any client of ``?WATCH={"json":true,"pps":true}``): the timing
reports TOFF and PPS as clock series.

Both reports pair a true second with the host's system clock (gpsd_json(5)): ``real_sec``/``real_nsec`` is
the time the receiver said it was (UTC, UNIX seconds), ``clock_sec``/``clock_nsec`` the system clock when
gpsd saw it. ``TOFF`` is the arrival of the receiver's time message on the serial or USB line, ``PPS`` the
1PPS edge timed by the kernel (a ``/dev/pps`` device), with ``qErr`` (the receiver's quantisation error of
that edge, ps) and ``precision`` where gpsd has them.

One series per report class and device (``TOFF /dev/ttyS0``, ``PPS /dev/pps0``): time tags the true
second (``unix-utc``), phase ``offset_s`` = clock - real (s: the system clock minus GNSS time; for TOFF
that includes the message's latency, tens to hundreds of ms), ``qerr_s`` for PPS. Other reports (TPV, SKY,
DEVICE...) are counted in a note; ``#`` comment lines are passed over; a line that is not JSON is an error
naming its line (a cut capture must be cut at a line end).
"""

from __future__ import annotations

import json
from collections import Counter, defaultdict
from pathlib import Path

from chronofuse.io.log_series import LogSeries, log_series
from chronofuse.io.formats import open_text
from chronofuse.validation import InputDataError

__all__ = ["read_gpsd_json"]

_NS = 1_000_000_000


def _pair_ns(report: dict, name: str, source: str, lineno: int) -> int:
    try:
        return int(report[f"{name}_sec"]) * _NS + int(report.get(f"{name}_nsec", 0))
    except (KeyError, TypeError, ValueError):
        raise InputDataError(f"a {report.get('class')} report without {name}_sec/{name}_nsec", source,
                             lineno) from None


def read_gpsd_json(path: str | Path) -> list[LogSeries]:
    """The TOFF and PPS series of a gpsd JSON log (plain or gzip; see the module docstring)."""
    path, source = Path(path), str(Path(path))
    series: dict[str, dict] = {}
    others: Counter = Counter()
    with open_text(path) as fh:
        for lineno, raw in enumerate(fh, start=1):
            line = raw.strip()
            if not line or line.startswith("#"):
                continue
            try:
                report = json.loads(line)
            except json.JSONDecodeError as exc:
                raise InputDataError(f"not a gpsd JSON report ({exc.msg})", source, lineno) from None
            cls = report.get("class") if isinstance(report, dict) else None
            if cls not in ("TOFF", "PPS"):
                others[str(cls)] += 1
                continue
            real = _pair_ns(report, "real", source, lineno)
            clock = _pair_ns(report, "clock", source, lineno)
            s = series.setdefault(f"{cls} {report.get('device', '?')}",
                                  {"t": [], "lines": [], "cols": defaultdict(list), "cls": cls})
            s["t"].append(real)
            s["lines"].append(lineno)
            s["cols"]["offset_s"].append((clock - real) / _NS)
            if cls == "PPS":
                qerr = report.get("qErr")
                s["cols"]["qerr_s"].append(float("nan") if qerr is None else float(qerr) * 1e-12)
    note_other = ", ".join(f"{n} {c}" for c, n in sorted(others.items())) if others else ""
    out = []
    for name, s in series.items():
        kinds = {c: ("phase" if c == "offset_s" else "other") for c in s["cols"]}
        notes = [f"gpsd {s['cls']} reports: offset = system clock - the receiver's second (s)"]
        if note_other:
            notes.append(f"other reports, not timing samples: {note_other}")
        out.append(log_series(s["t"], s["cols"], kinds, s["lines"], clock=name, time_scale="unix-utc",
                              fmt="gpsd-json", source=source, phase="offset_s", notes=notes))
    return out

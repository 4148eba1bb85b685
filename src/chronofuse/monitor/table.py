"""The live table: one row per receiver, redrawn in place (rich ``Live``: no flicker, no scrolling),
laid out for the terminal's width.

It draws the status document (:mod:`chronofuse.monitor.status`), so the table, ``/api/status`` and the
web page give one verdict. Layouts by width (columns kept whole; a receiver's name is shortened in the
middle, never cut to three letters; names that would shorten alike show where they differ):

- 80 columns: receiver, link, age, fix, satellites, GDOP, ok (usable), bias, alarms, and why not usable;
- 100 columns: adds the UTC time of day, the leap count and qErr;
- under 80 columns: receiver, link, ok, alarms and why (the reasons kept readable);
- 140 and more: the whole record (date and time, drift, flags, outages); the flags say ``late N`` when N epochs
  came too late to be put back in order and were left out.

A quantity the receiver's kind of source cannot give (gpsd: clock bias, drift, qErr) shows ``n/a``,
one it has not sent ``-``.
"""

from __future__ import annotations

import math
import os

from rich.table import Table
from rich.text import Text

__all__ = ["receiver_table", "layout_for"]

_MODES = {0: "-", 1: "none", 2: "2D", 3: "3D"}
#: (minimum width, columns); each column is (header, key, width)
_LAYOUTS = (
    (140, ("receiver", "link", "age", "fix", "sats", "gdop", "ok", "utc_full", "leap", "bias", "drift", "qerr",
           "alarms", "outages", "flags", "why")),
    (100, ("receiver", "link", "age", "fix", "sats", "gdop", "ok", "utc_time", "leap", "bias", "qerr", "alarms",
           "why")),
    (80, ("receiver", "link", "age", "fix", "sats", "gdop", "ok", "bias", "alarms", "why")),
    (0, ("receiver", "link", "ok", "alarms", "why")),  # narrower: the verdict and why, readable
)
_HEADERS = {"receiver": "receiver", "link": "link", "age": "age s", "fix": "fix", "sats": "sv", "gdop": "GDOP",
            "ok": "ok", "utc_full": "UTC", "utc_time": "UTC", "leap": "leap", "bias": "bias ns",
            "drift": "drift ns/s", "qerr": "qErr ns", "alarms": "alm", "outages": "outages", "flags": "flags",
            "why": "why not ok"}
_LEFT = {"receiver", "utc_full", "utc_time", "flags", "why"}


def layout_for(width: int) -> tuple[str, ...]:
    """The columns shown at ``width`` terminal columns."""
    return next(cols for minimum, cols in _LAYOUTS if width >= minimum)


def _num(value, scale: float = 1.0, fmt: str = "{:.2f}") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return fmt.format(value * scale)


def _short(name: str, width: int) -> str:
    """``name`` within ``width`` characters, shortened in the middle (``ublox-z…1.11.log#1``)."""
    if len(name) <= width:
        return name
    keep = width - 1
    return name[: (keep + 1) // 2] + "…" + name[len(name) - keep // 2:]


def _distinct(names: list[str], width: int) -> dict[str, str]:
    """Each name shortened within ``width`` (:func:`_short`); names whose shortenings would be equal (udev
    by-id names differing only in a serial number in their middle) show the part where they differ."""
    out = {n: _short(n, width) for n in names}
    groups: dict[str, list[str]] = {}
    for n in names:
        groups.setdefault(out[n], []).append(n)
    for group in groups.values():
        if len(set(group)) < 2:
            continue
        prefix = len(os.path.commonprefix(group))
        suffix = len(os.path.commonprefix([n[::-1] for n in group]))
        for n in group:
            end = max(len(n) - suffix, prefix + 1)
            room = width - 2
            begin = max(0, min(prefix - max((room - (end - prefix)) // 2, 0), len(n) - room))
            piece = n[begin:begin + room]
            out[n] = ("…" if begin > 0 else "") + piece + ("…" if begin + room < len(n) else "")
            out[n] = out[n][:width]
    return out


def _cells(entry: dict, name_width: int, shown: str | None = None) -> dict:
    last = entry["last"] or {}
    missing = set(entry["unavailable"])

    def field(key, scale, fmt):
        return "n/a" if key in missing else _num(last.get(key), scale, fmt)

    usable = entry["usable"]
    flags = []
    if last.get("state") == "alarm" or last.get("alarm"):
        flags.append("[red]ALARM[/red]")
    elif last and last.get("state") not in ("ok", "alarm"):
        flags.append("[yellow]untested[/yellow]")  # never shown as "no alarm": the test has not run
    if last.get("dissent"):
        flags.append("[yellow]dissent[/yellow]")
    if last.get("jump"):
        flags.append("[yellow]jump[/yellow]")
    if entry["stale"]:
        flags.append("[magenta]stale[/magenta]")
    if entry.get("late"):
        flags.append(f"[yellow]late {entry['late']}[/yellow]")
    utc = last.get("utc") or "-"
    pending = last.get("leap_pending") or 0
    link = {"up": "[green]up[/green]", "down": "[red]down[/red]"}.get(entry["link"], entry["link"])
    return {
        "receiver": shown if shown is not None else _short(entry["receiver"], name_width),
        "link": link,
        "age": _num(entry["age_s"], 1.0, "{:.1f}"),
        "fix": _MODES.get(last.get("fix_mode", 0), "?"),
        "sats": str(last["n_sats"]) if last.get("n_sats", -1) >= 0 else "-",
        "gdop": _num(last.get("gdop")),
        "ok": "-" if usable is None else ("[green]yes[/green]" if usable else "[red]no[/red]"),
        "utc_full": utc,
        "utc_time": utc[11:19] if len(utc) >= 19 else utc,
        "leap": "-" if "leap_s" not in last else str(last["leap_s"]) + ("+" if pending > 0 else "-" if pending < 0 else ""),
        "bias": field("clock_bias_s", 1e9, "{:.1f}"),
        "drift": field("clock_drift_s_per_s", 1e9, "{:.3f}"),
        "qerr": field("qerr_s", 1e9, "{:.2f}"),
        "alarms": str(entry["alarms"]),
        "outages": str(entry["outages"]),
        "flags": " ".join(flags),
        "why": "; ".join(entry["reasons"]),
    }


def receiver_table(monitor, width: int | None = None, doc: dict | None = None) -> Table:
    """A rich table of ``monitor``'s receivers (a :class:`chronofuse.monitor.engine.Monitor`) for a
    terminal of ``width`` columns (None: the widest layout); ``doc``: a status document already made."""
    from chronofuse.monitor.status import status_document

    doc = doc if doc is not None else status_document(monitor)
    cols = layout_for(10_000 if width is None else width)
    name_width = 26 if width is None or width >= 140 else 22 if width >= 100 else 16
    table = Table(title=f"chronofuse monitor: {len(doc['receivers'])} receiver(s), {doc['acknowledged']:,} epochs "
                        f"logged, stale after {doc['stale_s']:g} s", expand=width is not None, padding=(0, 1, 0, 0),
                  pad_edge=False, box=None, header_style="bold underline", width=width)
    for col in cols:
        wrap = col == "why"
        table.add_column(_HEADERS[col], justify="left" if col in _LEFT else "right", no_wrap=not wrap,
                         overflow="fold" if wrap else "ellipsis", ratio=1 if wrap else None,
                         min_width=12 if wrap else None)
    shown = _distinct([e["receiver"] for e in doc["receivers"]], name_width)
    for entry in doc["receivers"]:
        cells = _cells(entry, name_width, shown[entry["receiver"]])
        table.add_row(*(Text.from_markup(cells[c]) if c not in ("receiver", "why") else Text(cells[c]) for c in cols))
    return table

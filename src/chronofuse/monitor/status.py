"""The monitor's state as one JSON document: what ``/api/status`` serves, what the web page draws, what
``/metrics`` counts and what the live table shows. Its JSON schema is ``status.schema.json`` beside this
module (served at ``/api/status.schema.json``).

Per receiver: the link (``up``, ``down``, ``ended``, ``unknown``), the age of its last epoch and whether
it is stale, its last record, its counters, and the verdict: ``usable`` (a boolean, or null before its
first epoch) with ``reasons``, every reason that withholds it. The record's own reasons (fix, time
validity, GDOP, alarm, dissent ...: the per-epoch decisions) are joined by what only the live monitor
knows: the receiver is stale, its link is down, its recording has ended. ``unavailable`` lists the
quantities its kind of source cannot give (a gpsd source has no clock bias, drift or qErr). ``reordered``
and ``late`` count the epochs its decoder's reorder buffer (:mod:`chronofuse.io.arrival`) put back in time
order and left out as too late (0 for a source without that buffer: gpsd JSON, a replayed clock product).
"""

from __future__ import annotations

import json
import math
import time
from collections import deque
from pathlib import Path

__all__ = ["status_document", "arrival_counts", "SCHEMA_PATH", "load_schema", "RECORD_FIELDS", "unavailable_fields", "verdict"]

SCHEMA_PATH = Path(__file__).with_name("status.schema.json")
SCHEMA_ID = "chronofuse.monitor.status/1"

#: The fields of a receiver's last record in the document.
RECORD_FIELDS = ("gps_ns", "utc", "fix_mode", "time_valid", "n_sats", "gdop", "pdop", "hdop", "vdop", "tdop",
                 "leap_s", "leap_pending", "qerr_s", "clock_bias_s", "clock_drift_s_per_s", "statistic", "alarm",
                 "state", "dissent", "jump", "received_unix_ns")

#: What a gpsd source cannot give: gpsd's JSON (TPV/SKY/TOFF) carries no receiver clock bias or drift,
#: no pending leap second, and a qErr only inside PPS reports (a receiver with a PPS line gpsd reads).
_GPSD_LACKS = ("clock_bias_s", "clock_drift_s_per_s", "leap_pending", "qerr_s")


def load_schema() -> dict:
    return json.loads(SCHEMA_PATH.read_text())


def unavailable_fields(source) -> list[str]:
    """The record fields ``source``'s kind cannot fill (empty for raw NMEA/UBX)."""
    return list(_GPSD_LACKS) if getattr(source, "kind", "raw") == "gpsd" else []


def _clean(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, bool) or value is None or isinstance(value, (int, float, str)):
        return value
    return str(value)


def verdict(record: dict | None, *, stale: bool, link: str, age_s: float | None, stale_s: float) -> tuple:
    """``(usable, reasons)`` of a receiver now: its last record's verdict and reasons, withheld when the
    receiver is stale, down or ended (each a reason). ``usable`` is None before any epoch."""
    if record is None:
        reasons = ["no epoch yet"] + ([f"link {link}"] if link in ("down", "ended") else [])
        if stale:
            reasons.append(f"stale: no epoch in {age_s:.1f} s since the link came up (> {stale_s:g} s)"
                           if age_s is not None else "stale")
        return None, reasons
    reasons = [str(r) for r in (record.get("reasons") or [])]
    if not record.get("usable") and not reasons:
        reasons.append("not yet decided")  # a record held for its verdict (the monitor shows it at once)
    if stale:
        reasons.append(f"stale: no epoch for {age_s:.1f} s (> {stale_s:g} s)" if age_s is not None else "stale")
    if link == "down":
        reasons.append("link down")
    elif link == "ended":
        reasons.append("recording ended")
    return bool(record.get("usable")) and not reasons, reasons


def arrival_counts(monitor, receiver: str) -> tuple[int, int]:
    """``(reordered, late)`` epochs of ``receiver``'s decoder (module docstring)."""
    decoder = monitor.decoders.get(monitor.source_of(receiver))
    return int(getattr(decoder, "n_reordered", 0)), int(getattr(decoder, "n_late", 0))


def status_document(monitor, events=(), chrony=None, now_s: float | None = None) -> dict:
    """The status of ``monitor`` (a :class:`~chronofuse.monitor.engine.Monitor`) now: see the module
    docstring and the schema. ``events``: recent :class:`~chronofuse.monitor.events.MonitorEvent` s;
    ``chrony``: the time server feed's state (a dict) or None."""
    mono = time.monotonic() if now_s is None else now_s
    sources = {s.name: s for s in monitor.sources}
    receivers = []
    for name, rx in monitor.receivers.items():
        st = monitor.tracker.states.get(monitor.source_of(name))
        link = (st.link if st is not None and st.link is not None else "unknown")
        age = monitor.age_s(name, mono)
        stale = monitor.is_stale(name)
        last = monitor.decided.get(name)  # decided: its verdict is known (a record may wait for it)
        silent = monitor.silent_s(name, mono) if hasattr(monitor, "silent_s") else age
        usable, reasons = verdict(last, stale=stale, link=link, age_s=age if last is not None else silent,
                                  stale_s=monitor.stale_s)
        reordered, late = arrival_counts(monitor, name)
        receivers.append({
            "receiver": name,
            "source": getattr(sources.get(monitor.source_of(name)), "kind", "raw"),
            "link": link,
            "age_s": None if age is None else round(age, 3),
            "stale": stale,
            "usable": usable,
            "reasons": reasons,
            "epochs": rx.epochs,
            "alarms": rx.alarms,
            "outages": rx.outages,
            "reordered": reordered,
            "late": late,
            "unavailable": unavailable_fields(sources.get(monitor.source_of(name))),
            "last": None if last is None else {k: _clean(last.get(k)) for k in RECORD_FIELDS},
        })
    return {
        "schema": SCHEMA_ID,
        "generated_unix_s": time.time(),
        "acknowledged": monitor.acknowledged,
        "stale_s": monitor.stale_s,
        "receivers": receivers,
        "events": [{k: _clean(v) for k, v in e.to_dict().items()} for e in events],
        "chrony": chrony,
    }


class RecentEvents(deque):
    """The last ``maxlen`` events, for the status document."""

    def __init__(self, maxlen: int = 50) -> None:
        super().__init__(maxlen=maxlen)

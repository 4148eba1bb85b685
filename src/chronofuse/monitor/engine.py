"""The monitor loop: sources -> live decoders (record chunks) -> per-receiver decisions (qualification and
the detection pipeline) -> cross-receiver decisions -> the durable log -> acknowledgements (and the live table).

Each pass drains the source events that arrived, decodes them per receiver, groups the epochs of all
receivers by GPS time (an epoch is decided once every connected receiver has passed it, or after
``hold_s`` of wall time), commits the decided records to the log in one transaction and only then
hands them to ``on_ack`` (the ``--json-lines`` printer): what was acknowledged is on disk.
"""

from __future__ import annotations

import time
from collections import defaultdict

from chronofuse.io.record_streams import decoder_for
from chronofuse.io.sources import SourceGroup
from chronofuse.monitor.decisions import MonitorSettings, ReceiverMonitor, decide_second
from chronofuse.monitor.log import EpochLog

__all__ = ["Monitor"]


def _utc_label(gps_ns: int, leap_s: int) -> str:
    """The receiver's UTC label of an epoch in ISO 8601, to the millisecond, or to the nanosecond when the
    epoch has a part of a millisecond (a gpsd TPV time written to the ns keeps its digits)."""
    import numpy as np

    from chronofuse.timescale import NS_PER_S, gps_ns_to_datetime64

    utc_ns = gps_ns - leap_s * NS_PER_S
    unit = "ms" if utc_ns % 1_000_000 == 0 else "ns"
    return str(np.datetime_as_string(gps_ns_to_datetime64(np.int64(utc_ns)), unit=unit)) + "Z"


class Monitor:
    """Watch ``sources`` (see :mod:`chronofuse.io.sources`), log to ``log`` (an :class:`EpochLog` or
    None), call ``on_ack(records)`` after each commit and ``on_event(receiver, kind, detail)`` on
    connection changes."""

    def __init__(self, sources, settings: MonitorSettings = MonitorSettings(), log: EpochLog | None = None,
                 on_ack=None, on_event=None, hold_s: float = 2.0) -> None:
        self.sources = list(sources)
        self.settings = settings
        self.log = log
        self.on_ack = on_ack
        self.on_event = on_event
        self.hold_s = hold_s
        self.receivers = {s.name: ReceiverMonitor(s.name, settings) for s in self.sources}
        self.decoders = {s.name: decoder_for(s) for s in self.sources}
        self._source_of = {s.name: s.name for s in self.sources}  # receiver -> its source (a product: many)
        self._pending: dict[int, list] = defaultdict(list)
        self._pending_since: dict[int, float] = {}
        self._previous_bias: dict[str, float] = {}
        self._ended: set[str] = set()
        self.acknowledged = 0

    def run(self, duration_s: float | None = None, on_tick=None, tick_s: float = 0.25) -> None:
        """Run until every source has ended (files) or ``duration_s`` has passed; ``on_tick(self)`` is
        called about every ``tick_s`` (the live table's refresh)."""
        group = SourceGroup(self.sources).start()
        start = last_tick = time.monotonic()
        try:
            while len(self._ended) < len(self.sources):
                if duration_s is not None and time.monotonic() - start >= duration_s:
                    break
                self.step(group, timeout_s=tick_s)
                if on_tick is not None and time.monotonic() - last_tick >= tick_s:
                    on_tick(self)
                    last_tick = time.monotonic()
            self._flush(final=True)
        finally:
            group.stop()
            if on_tick is not None:
                on_tick(self)

    def step(self, group: SourceGroup, timeout_s: float = 0.25, max_events: int = 256) -> None:
        """One pass: drain up to ``max_events`` source events, decide and commit what is ready."""
        events, conn_events = [], []
        event = group.get(timeout_s)
        while event is not None:
            events.append(event)
            if len(events) >= max_events:
                break
            event = group.get(0.0) if not group.events.empty() else None
        for ev in events:
            rx = self.receivers[ev.source]
            if ev.kind == "data":
                self._take(ev.source, self.decoders[ev.source].decode(ev.data))
            else:
                if ev.kind == "up":
                    for each in self._of_source(ev.source):
                        each.connected = True
                elif ev.kind in ("down", "end"):
                    if rx.connected and ev.kind == "down":
                        rx.outages += 1
                    for each in self._of_source(ev.source):
                        each.connected = False
                    if ev.kind == "end":
                        self._take(ev.source, self.decoders[ev.source].finish())
                        for each in self._of_source(ev.source):
                            for record in each.close():
                                self._add(record)
                        self._ended.add(ev.source)
                detail = ev.data if isinstance(ev.data, str) else ""
                conn_events.append((ev.source, time.time(), ev.kind, detail))
                if self.on_event is not None:
                    self.on_event(ev.source, ev.kind, detail)
        self._flush(final=False, events=conn_events)

    def _of_source(self, source: str) -> list[ReceiverMonitor]:
        return [rx for name, rx in self.receivers.items() if self._source_of[name] == source]

    def _take(self, source: str, parts: list) -> None:
        """Decoded record chunks of ``source``, each for its receiver (``key`` None: the source's own; else a
        station of a replayed clock product, created when first met)."""
        for key, record in parts:
            name = source if key is None else f"{source}/{key}"
            rx = self.receivers.get(name)
            if rx is None:
                rx = self.receivers[name] = ReceiverMonitor(name, self.settings)
                rx.connected = self.receivers[source].connected
                self._source_of[name] = source
            for row in rx.take(record):
                self._add(row)

    def _add(self, record: dict) -> None:
        record["utc"] = _utc_label(record["gps_ns"], record["leap_s"])
        self._pending[record["gps_ns"]].append(record)
        self._pending_since.setdefault(record["gps_ns"], time.monotonic())

    def _flush(self, final: bool, events=()) -> None:
        now = time.monotonic()
        live = [rx for name, rx in self.receivers.items() if rx.connected and self._source_of[name] not in self._ended]
        horizon = min((rx.horizon_ns for rx in live if rx.horizon_ns is not None), default=None)
        ready = []
        for gps_ns in sorted(self._pending):
            old = now - self._pending_since[gps_ns] >= self.hold_s
            if final or old or horizon is None or gps_ns <= horizon:
                ready.append(gps_ns)
        records = []
        for gps_ns in ready:
            group = self._pending.pop(gps_ns)
            self._pending_since.pop(gps_ns)
            decide_second(group, self.settings.jump_s, self._previous_bias)
            records += group
        if self.log is not None:
            self.log.append(records, list(events))
        if records:
            self.acknowledged += len(records)
            if self.on_ack is not None:
                self.on_ack(records)

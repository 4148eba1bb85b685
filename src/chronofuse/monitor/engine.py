"""The monitor loop: sources -> live decoders (record chunks) -> per-receiver decisions (qualification and
the detection pipeline) -> cross-receiver decisions -> the durable log -> acknowledgements (and the live
table, the web page, the time server feed).

Each pass drains the source events that arrived, decodes them per receiver, groups the epochs of all
receivers by GPS time (an epoch is decided once every connected receiver within ``near_s`` (60 s) of it
on GPS time has passed it, or after ``hold_s`` of wall time), commits the decided records to the log in one transaction and only then
hands them to ``on_ack`` (the ``--json-lines`` printer): what was acknowledged is on disk.

Freshness: each record carries ``received_unix_ns``, the system clock when the first bytes of its epoch
arrived (the start of the chunk in which the receiver began that epoch: an epoch closes when the next one
starts, so the chunk that closes epoch k is the one in which epoch k+1 began; a gpsd source gives gpsd's
own receipt time, its TOFF report). An epoch the decoder's reorder buffer holds (:mod:`chronofuse.io.arrival`)
keeps that arrival and is released after at most :data:`~chronofuse.io.arrival.REORDER_HOLD_S` of wall time
since it closed. A receiver whose last epoch is older than ``stale_s`` is stale (an
event, and a reason in its verdict) until epochs come again; one whose link is up but that has not given a
first epoch (garbage bytes, a silent port) is stale ``stale_s`` after its link came up.

Time dissent on arrival: the UTC/leap consensus compares the receivers' epochs of one GPS time; a receiver
labelling every epoch whole seconds off has no epoch at the others' GPS times to be compared with. So each
receiver's UTC label is also compared with its epochs' arrival: live receivers on the system clock, replays
sharing a start on their schedule (times their speed); one whose label minus arrival is more than
:data:`TIME_DISSENT_S` from the others' (the median of all, or the other one's when there are two) dissents
(``dissent_s``: by how many seconds). A file read as fast as it can be has no arrival to compare.

Sources that cannot be had: a source that has not come up within ``connect_timeout_s`` of the start
(0: at its first failure; a missing file, a serial port that does not exist, a refused connection), or
whose link has been down for longer than ``reconnect_timeout_s`` (None: retried for ever, with backoff),
ends the run with :class:`SourceUnavailable` naming it, after what was decided has been committed.
Every outage is one ``link_down`` event with its reason and one ``link_up`` with its duration
(:mod:`chronofuse.monitor.events`).
"""

from __future__ import annotations

import statistics
import time
from collections import defaultdict, deque
from datetime import datetime, timedelta

from chronofuse.discipline.verdict import ReceiverVerdict, reasons
from chronofuse.io.arrival import REORDER_HOLD_S
from chronofuse.io.record_streams import decoder_for
from chronofuse.io.sources import SourceGroup
from chronofuse.monitor.decisions import MonitorSettings, ReceiverMonitor, decide_second
from chronofuse.monitor.events import EventTracker, MonitorEvent
from chronofuse.monitor.log import EpochLog
from chronofuse.validation import InputDataError

__all__ = ["Monitor", "SourceUnavailable"]


class SourceUnavailable(InputDataError):
    """A source that could not be opened (or stayed down) within the retry policy; names the source."""


_GPS_EPOCH = datetime(1980, 1, 6)
#: A receiver whose labelled time, against its epochs' arrival, is this far from the others' dissents (s):
#: whole seconds apart less the receivers' different output latencies (well under half a second).
TIME_DISSENT_S = 0.5
#: Dropped frames are reported at most this often per source (s).
_DROPPED_EVERY_S = 10.0
#: Other receivers' epochs compared with one are those that arrived within this much wall time of it (s).
_COMPARE_WITHIN_S = 10.0


def _timeline(source):
    """Which receivers' arrivals can be compared: live ones on the system clock (speed 1); replays sharing a
    start on their schedule (times their speed); a file read as fast as it can be: none (None)."""
    from chronofuse.io.replay import ReplaySource
    from chronofuse.io.sources import FileSource

    if isinstance(source, ReplaySource):
        start = source.start_at
        return ("replay", id(start) if start is not None else source.name), source.speed
    if isinstance(source, FileSource):
        return None if source.rate_bytes_s is None else (("file", source.name), 1.0)
    return ("live",), 1.0


def _utc_label(gps_ns: int, leap_s: int) -> str:
    """The receiver's UTC label of an epoch in ISO 8601 with ``Z``, to the millisecond, or to the nanosecond
    when the epoch has a part of a millisecond (a gpsd TPV time written to the ns keeps its digits); what
    ``numpy.datetime_as_string`` gives with unit "ms" or "ns", computed in integers without numpy."""
    utc_ns = int(gps_ns) - int(leap_s) * 1_000_000_000
    seconds, rest_ns = divmod(utc_ns, 1_000_000_000)
    stamp = _GPS_EPOCH + timedelta(seconds=seconds)
    fraction = f"{rest_ns // 1_000_000:03d}" if rest_ns % 1_000_000 == 0 else f"{rest_ns:09d}"
    return f"{stamp:%Y-%m-%dT%H:%M:%S}.{fraction}Z"


class Monitor:
    """Watch ``sources`` (see :mod:`chronofuse.io.sources`), log to ``log`` (an :class:`EpochLog` or
    None), call ``on_ack(records)`` after each commit and ``on_event(event)`` with each
    :class:`~chronofuse.monitor.events.MonitorEvent` (connection, freshness, alarm and dissent edges),
    after it is in the log. ``stale_s``: silence after which a receiver is stale; ``connect_timeout_s``
    and ``reconnect_timeout_s``: the retry policy (module docstring)."""

    def __init__(self, sources, settings: MonitorSettings = MonitorSettings(), log: EpochLog | None = None,
                 on_ack=None, on_event=None, hold_s: float = 2.0, stale_s: float = 5.0,
                 connect_timeout_s: float | None = None, reconnect_timeout_s: float | None = None) -> None:
        self.sources = list(sources)
        self.settings = settings
        self.log = log
        self.on_ack = on_ack
        self.on_event = on_event
        self.hold_s = hold_s
        self.stale_s = stale_s
        self.connect_timeout_s = connect_timeout_s
        self.reconnect_timeout_s = reconnect_timeout_s
        self.receivers = {s.name: ReceiverMonitor(s.name, settings) for s in self.sources}
        self.sources_by_name = {s.name: s for s in self.sources}
        self.decoders = {s.name: decoder_for(s) for s in self.sources}
        self.tracker = EventTracker()
        self._verdict_stage = ReceiverVerdict(settings.gdop_max, settings.min_sats)
        self.decided: dict[str, dict] = {}  # receiver -> its last decided record (what the operator is shown)
        self._source_of = {s.name: s.name for s in self.sources}  # receiver -> its source (a product: many)
        self._arrivals: dict[tuple[str, int], int] = {}  # (receiver, gps_ns) -> arrival of its first bytes
        self._pending: dict[int, list] = defaultdict(list)
        self._pending_since: dict[int, float] = {}
        self._previous_bias: dict[str, float] = {}
        self._ended: set[str] = set()
        self._ever_up: set[str] = set()
        self._epoch_start_ns: dict[str, int] = {}  # receiver -> arrival (UNIX ns) of the epoch in progress
        self._chunk_wall: dict[str, dict[int, int]] = defaultdict(dict)  # source -> decoder chunk -> UNIX ns
        self._last_arrival_s: dict[str, float] = {}  # receiver -> monotonic arrival of its last epoch
        self._up_since_s: dict[str, float] = {}  # source -> monotonic time its link (last) came up
        self._timelines = {s.name: _timeline(s) for s in self.sources}
        self._origins: dict = {}  # timeline -> its first arrival (UNIX ns)
        self._label_offsets: dict[str, deque] = {}  # receiver -> recent (arrival ns, label - arrival ns)
        self._dropped_seen: dict[str, int] = {}  # source -> frames its decoder dropped, reported
        self._dropped_at: dict[str, float] = {}  # source -> when that was last reported (UNIX s)
        self._started_s = time.monotonic()
        self._last_checks_s = self._last_flush_s = 0.0
        self.check_s = 0.1  # freshness and retry checks, s
        self.flush_s = 0.05  # commits of decided records (each an fsync), s apart at most this often
        self.near_s = 60.0  # receivers further behind on GPS time than this are not waited for, s
        self.acknowledged = 0

    def age_s(self, receiver: str, now_s: float | None = None) -> float | None:
        """Seconds since the receiver's last epoch arrived (None: none yet)."""
        last = self._last_arrival_s.get(receiver)
        return None if last is None else (time.monotonic() if now_s is None else now_s) - last

    def silent_s(self, receiver: str, now_s: float | None = None) -> float | None:
        """Seconds without an epoch: since its last epoch, or, before its first, since its link came up (a
        receiver that connects and sends nothing decodable is silent too); None: no epoch and no link."""
        age = self.age_s(receiver, now_s)
        if age is not None:
            return age
        up = self._up_since_s.get(receiver)
        return None if up is None else (time.monotonic() if now_s is None else now_s) - up

    def is_stale(self, receiver: str) -> bool:
        return self.tracker.is_stale(receiver)

    def run(self, duration_s: float | None = None, on_tick=None, tick_s: float = 0.25) -> None:
        """Run until every source has ended (files) or ``duration_s`` has passed; ``on_tick(self)`` is
        called about every ``tick_s`` (the live table's refresh). Raises :class:`SourceUnavailable`
        (after committing what was decided) when the retry policy gives up on a source."""
        group = SourceGroup(self.sources).start()
        start = last_tick = self._started_s = time.monotonic()
        try:
            try:
                while len(self._ended) < len(self.sources):
                    if duration_s is not None and time.monotonic() - start >= duration_s:
                        break
                    self.step(group, timeout_s=min(tick_s, 0.25))
                    if on_tick is not None and time.monotonic() - last_tick >= tick_s:
                        on_tick(self)
                        last_tick = time.monotonic()
            except KeyboardInterrupt:
                self._finish()
                raise
            self._finish()
        except SourceUnavailable:
            self._flush(final=True)
            raise
        finally:
            group.stop()
            if on_tick is not None:
                on_tick(self)

    def _finish(self) -> None:
        """The end of the run (every source ended, ``duration_s`` passed, Ctrl-C): the epochs still in a
        decoder or held for a verdict are decided and logged, not dropped."""
        for source in self.sources_by_name:
            if source not in self._ended:
                self._drain(source, time.time_ns(), time.monotonic(), close=True)
        self._flush(final=True)

    def step(self, group: SourceGroup, timeout_s: float = 0.25, max_events: int = 256) -> None:
        """One pass: drain up to ``max_events`` source events, decide and commit what is ready."""
        events = []
        event = group.get(timeout_s)
        while event is not None:
            events.append(event)
            if len(events) >= max_events:
                break
            event = group.get(0.0) if not group.events.empty() else None
        notices: list[MonitorEvent] = []
        wall_s = time.time()
        for ev in events:
            rx = self.receivers[ev.source]
            if ev.kind == "data":
                parts = self.decoders[ev.source].decode(ev.data)
                self._received(ev.source, parts, ev.wall_ns or time.time_ns(), ev.time_s or time.monotonic())
                self._take(ev.source, parts)
                notices += self._dropped_frames(ev.source, wall_s)
                continue
            reason = ev.data if isinstance(ev.data, str) else ""
            if ev.kind == "up":
                for each in self._of_source(ev.source):
                    each.connected = True
                self._ever_up.add(ev.source)
                self._up_since_s[ev.source] = ev.time_s or time.monotonic()
            elif ev.kind in ("down", "end"):
                self._up_since_s.pop(ev.source, None)
                if rx.connected and ev.kind == "down":
                    rx.outages += 1
                    self._drain(ev.source, ev.wall_ns or time.time_ns(), ev.time_s or time.monotonic(),
                                close=False)
                for each in self._of_source(ev.source):
                    each.connected = False
                if ev.kind == "end":
                    parts = self.decoders[ev.source].finish()
                    self._received(ev.source, parts, ev.wall_ns or time.time_ns(), ev.time_s or time.monotonic())
                    self._take(ev.source, parts)
                    for each in self._of_source(ev.source):
                        for record in each.close():
                            self._add(record)
                    self._ended.add(ev.source)
            notices += self.tracker.link(ev.source, ev.kind, reason, wall_s)
            if ev.kind in ("down", "end") and ev.source not in self._ever_up:
                self._check_connect(ev.source, reason, final=ev.kind == "end")
        self._release_held()
        now = time.monotonic()
        if now - self._last_checks_s >= self.check_s:  # freshness and the retry policy: a few times a second
            self._last_checks_s = now
            notices += self._freshness(wall_s)
            self._check_reconnect(wall_s)
        if notices or now - self._last_flush_s >= self.flush_s:  # one commit per flush interval, not per chunk
            self._last_flush_s = now
            self._flush(final=False, notices=notices)

    def _dropped_frames(self, source: str, wall_s: float) -> list[MonitorEvent]:
        """A ``frame_dropped`` event when the source's decoder dropped frames it could not read (a corrupt
        week or date, a payload pyubx2 refuses): at most one every :data:`_DROPPED_EVERY_S`, with the count
        since the last and the latest reason; the other frames, and the other receivers, go on."""
        stats = getattr(self.decoders[source], "ubx_stats", None)
        if stats is None or stats.parse_errors <= self._dropped_seen.get(source, 0):
            return []
        last = self._dropped_at.get(source)
        if last is not None and wall_s - last < _DROPPED_EVERY_S:
            return []
        n = stats.parse_errors - self._dropped_seen.get(source, 0)
        self._dropped_seen[source], self._dropped_at[source] = stats.parse_errors, wall_s
        why = stats.errors[-1][1] if stats.errors else "unreadable frame"
        return [MonitorEvent(source, "frame_dropped", wall_s, f"{n} frame(s) dropped, the latest: {why}")]

    def _drain(self, source: str, wall_ns: int, mono_s: float, close: bool) -> None:
        """Everything of ``source`` received but not yet handed on, handed on now: the epoch its decoder has
        in progress and the epochs its receivers hold for their verdicts (a link that went down, the end of
        the run). ``close``: the end (the grid closed, its last verdicts given); else the link is down and
        the grid goes on after it, the epochs released without a verdict not yet decided (untested)."""
        parts = self.decoders[source].finish()
        self._received(source, parts, wall_ns, mono_s)
        self._take(source, parts)
        for each in self._of_source(source):
            for record in (each.close() if close else each.flush()):
                self._add(record)

    def _of_source(self, source: str) -> list[ReceiverMonitor]:
        return [rx for name, rx in self.receivers.items() if self._source_of[name] == source]

    def source_of(self, receiver: str) -> str:
        """The source a receiver's epochs come from (itself, or the replayed product holding it)."""
        return self._source_of.get(receiver, receiver)

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

    def _release_held(self) -> None:
        """Epochs a decoder's reorder buffer has held for :data:`~chronofuse.io.arrival.REORDER_HOLD_S` of
        wall time since they closed are released (module docstring): live, an epoch waits for a late one at
        most that long, not for the epochs after it."""
        now_ns = time.time_ns()
        for source, decoder in self.decoders.items():
            chunk = getattr(decoder, "oldest_held_chunk", None)
            if chunk is None or source in self._ended:
                continue
            closed_ns = self._chunk_wall[source].get(chunk)
            if closed_ns is not None and now_ns - closed_ns < REORDER_HOLD_S * 1e9:
                continue
            record = decoder.release_held()
            parts = [] if record is None else [(None, record)]
            self._received(source, parts, now_ns, time.monotonic())
            self._take(source, parts)

    def _received(self, source: str, parts: list, wall_ns: int, mono_s: float) -> None:
        """Note the arrival of each epoch decoded from this chunk (module docstring): epoch k began in the
        chunk that closed epoch k-1 (a decoder that counts its chunks says which chunk that was, so an epoch
        its reorder buffer released later keeps its own arrival)."""
        decoder = self.decoders[source]
        began_in = getattr(decoder, "began_in", None)
        if began_in is not None:
            self._arrived(source, decoder, began_in, parts, wall_ns, mono_s)
            return
        if not parts:
            self._epoch_start_ns.setdefault(source, wall_ns)
            return
        timing = getattr(decoder, "timing", None)  # gpsd: its TOFF receipt and PPS edge per epoch
        for key, record in parts:
            name = source if key is None else f"{source}/{key}"
            for t in record.t_ns.tolist():
                told = timing.pop(t, None) if timing is not None else None
                if told is not None and told.get("received_unix_ns") is not None:
                    self._arrivals[(name, t)] = told["received_unix_ns"]
                else:
                    self._arrivals[(name, t)] = self._epoch_start_ns.get(source, wall_ns)
                if told is not None and told.get("pps_unix_ns") is not None:
                    self._arrivals[(name, t, "pps")] = told["pps_unix_ns"]
                self._epoch_start_ns[source] = wall_ns
            self._last_arrival_s[name] = mono_s
        self._last_arrival_s[source] = mono_s

    def _arrived(self, source: str, decoder, began_in: dict, parts: list, wall_ns: int, mono_s: float) -> None:
        walls = self._chunk_wall[source]
        walls.setdefault(decoder.n_chunks, wall_ns)  # the chunk just fed (a release adds no chunk)
        for key, record in parts:
            name = source if key is None else f"{source}/{key}"
            for t in record.t_ns.tolist():
                chunk = began_in.pop(t, None)
                self._arrivals[(name, t)] = walls.get(chunk, wall_ns)
            # its age counts from its bytes, not from the buffer's release
            last = mono_s - (wall_ns - self._arrivals[(name, record.t_ns[-1].item())]) / 1e9
            self._last_arrival_s[name] = self._last_arrival_s[source] = max(last, self._last_arrival_s.get(name, last))
        if len(walls) > 256:  # forget chunks no held or open epoch began or closed in
            keep = min(list(began_in.values()) + [decoder.n_chunks])
            for chunk in [c for c in walls if c < keep]:
                del walls[chunk]

    def _freshness(self, wall_s: float) -> list[MonitorEvent]:
        now = time.monotonic()
        out = []
        for name in self.receivers:
            if self._source_of[name] in self._ended:
                continue  # a recording read to its end is not silent
            out += self.tracker.freshness(name, self.silent_s(name, now), self.stale_s, wall_s,
                                          first=self.age_s(name, now) is None)
        return out

    def _check_connect(self, name: str, reason: str, final: bool) -> None:
        waited = time.monotonic() - self._started_s
        limit = self.connect_timeout_s
        if limit is None:
            return
        if final or waited >= limit:
            raise SourceUnavailable(f"cannot be read: {reason or 'no data'}"
                                    + (f" (retried for {waited:.0f} s)" if limit > 0 else ""), self._where(name))

    def _check_reconnect(self, wall_s: float) -> None:
        now = time.monotonic()
        for name in self.sources_by_name:
            if name in self._ended:
                continue
            if name not in self._ever_up:
                if self.connect_timeout_s is not None and now - self._started_s >= self.connect_timeout_s > 0 \
                        and self.tracker.states.get(name) is not None:
                    st = self.tracker.states[name]
                    raise SourceUnavailable(f"cannot be read: {st.down_reason or 'no data'} (retried for "
                                            f"{now - self._started_s:.1f} s)", self._where(name))
                continue
            down = self.tracker.outage_s(name, wall_s)
            if self.reconnect_timeout_s is not None and down is not None and down > self.reconnect_timeout_s:
                reason = self.tracker.states[name].down_reason
                raise SourceUnavailable(f"down for {down:.0f} s ({reason}); giving up after "
                                        f"{self.reconnect_timeout_s:g} s", self._where(name))

    def _verdict(self, r: dict) -> None:
        """The receiver verdict (:mod:`chronofuse.discipline.verdict`): ``qualified`` keeps the
        qualification alone, ``usable`` becomes every condition, ``reasons`` says which failed."""
        bits = self._verdict_stage.step({"t_ns": r["gps_ns"], "fix_mode": r["fix_mode"], "time_valid": r["time_valid"],
                                         "gdop": r["gdop"], "n_sats": r["n_sats"], "leap_s": r["leap_s"],
                                         "state": r.get("state", "alarm" if r.get("alarm") else "ok"),
                                         "dissent": r["dissent"], "jump": r["jump"],
                                         "leap_pending": r.get("leap_pending", 0)})["unusable_bits"]
        r["qualified"] = bool(r["usable"])
        r["usable"] = bits == 0
        r["reasons"] = reasons(bits, r, gdop_max=self.settings.gdop_max, min_sats=self.settings.min_sats)

    def _training_reasons(self, receiver: str) -> tuple[str, ...]:
        rx = self.receivers.get(receiver)
        return () if rx is None else tuple(rx.watch.reasons)

    def _where(self, name: str) -> str:
        """A source as the user named it: a recording's path, else its name (``serial port``, host:port)."""
        source = next(s for s in self.sources if s.name == name)
        path = getattr(source, "path", None)
        return f"{name} ({path})" if path is not None and str(path) != name else name

    def _add(self, record: dict) -> None:
        record["utc"] = _utc_label(record["gps_ns"], record["leap_s"])
        key = (record["receiver"], record["gps_ns"])
        record["received_unix_ns"] = self._arrivals.pop(key, None)
        pps = self._arrivals.pop(key + ("pps",), None)
        if pps is not None:
            record["pps_unix_ns"] = pps
        self._note_label(record)
        self._pending[record["gps_ns"]].append(record)
        self._pending_since.setdefault(record["gps_ns"], time.monotonic())

    def _note_label(self, record: dict) -> None:
        """The receiver's UTC label against its epoch's arrival, on its timeline (see :func:`_timeline`)."""
        timeline = self._timelines.get(self._source_of.get(record["receiver"], record["receiver"]))
        arrival = record.get("received_unix_ns")
        if timeline is None or arrival is None:
            return
        key, speed = timeline
        origin = self._origins.setdefault(key, int(arrival))
        label = int(record["gps_ns"]) - int(record["leap_s"]) * 1_000_000_000
        offsets = self._label_offsets.setdefault(record["receiver"], deque(maxlen=5))
        offsets.append((int(arrival), label - int(round((int(arrival) - origin) * speed))))

    def _time_dissent(self, r: dict) -> None:
        """Compare ``r``'s labelled time with the other receivers' on arrival (module docstring): a receiver
        whose labels are whole seconds from the others' dissents, though no epoch of it shares a GPS time
        with theirs."""
        name = r["receiver"]
        timeline = self._timelines.get(self._source_of.get(name, name))
        mine = self._label_offsets.get(name)
        if timeline is None or not mine or r.get("received_unix_ns") is None:
            return
        arrival = int(r["received_unix_ns"])
        within = int(_COMPARE_WITHIN_S * 1e9)
        own = statistics.median(d for _, d in mine)
        others = []
        for other, offsets in self._label_offsets.items():
            if other == name or not offsets or \
                    self._timelines.get(self._source_of.get(other, other)) != timeline:
                continue
            if abs(offsets[-1][0] - arrival) <= within:
                others.append(statistics.median(d for _, d in offsets))
        if not others:
            return
        ref = others[0] if len(others) == 1 else statistics.median(others + [own])
        off_s = (own - ref) / 1e9
        if abs(off_s) > TIME_DISSENT_S:
            r["dissent"] = True
            r["dissent_s"] = int(round(off_s)) or (1 if off_s > 0 else -1)

    def _flush(self, final: bool, notices: list[MonitorEvent] = ()) -> None:
        now = time.monotonic()
        live = [rx for name, rx in self.receivers.items() if rx.connected and self._source_of[name] not in self._ended]
        marks = sorted(rx.horizon_ns for rx in live if rx.horizon_ns is not None)
        near_ns = int(max(self.hold_s, self.near_s) * 1e9)
        ready = []
        for gps_ns in sorted(self._pending):
            old = now - self._pending_since[gps_ns] >= self.hold_s
            # waited for: the receivers not past this epoch yet but within ``near_s`` of it on GPS time; one
            # further behind (a replay of another day beside live receivers) would only make every epoch
            # wait the whole hold
            waiting = any(gps_ns - near_ns <= mark < gps_ns for mark in marks)
            if final or old or not waiting:
                ready.append(gps_ns)
        records = []
        for gps_ns in ready:
            group = self._pending.pop(gps_ns)
            self._pending_since.pop(gps_ns)
            decide_second(group, self.settings.jump_s, self._previous_bias)
            for r in group:
                self._time_dissent(r)
                self._verdict(r)
                self.decided[r["receiver"]] = r
            records += group
        notices = list(notices) + self.tracker.records(records, time.time(), self._training_reasons)
        if self.log is not None:
            self.log.append(records, notices)
        if records:
            self.acknowledged += len(records)
            if self.on_ack is not None:
                self.on_ack(records)
        if self.on_event is not None:
            for notice in notices:
                self.on_event(notice)

"""Live decoding of one receiver's byte stream into epochs as they close (the streaming twin of
:func:`chronofuse.io.inspect.read_bytes`).

:meth:`StreamDecoder.feed` takes bytes in any split and returns the epochs that closed (an epoch closes
when the receiver starts the next one), each as a dict of ``gps_ns`` and the per-epoch fields of
:class:`chronofuse.epochs.ReceiverEpochs`. A stream carrying both NMEA and UBX (one receiver on one port)
gives the merged epochs the batch reader gives (:func:`chronofuse.io.inspect.merge_epochs`).
"""

from __future__ import annotations

import json
import math

import numpy as np

from chronofuse.io.arrival import ArrivalOrder, in_arrival_order
from chronofuse.io.epoch_offsets import EpochOffsets
from chronofuse.io.frames import FrameScanner
from chronofuse.io.inspect import EPOCH_FIELDS, merge_epochs, strictly_increasing
from chronofuse.io.nmea import NmeaDecodeStats, NmeaEpochBuilder, decode_nmea
from chronofuse.io.ubx_epochs import UbxDecodeStats, UbxEpochBuilder, decode_ubx
from chronofuse.record import RECEIVER_UNITS, EpochRecord
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns, gps_minus_utc_s, utc_to_gps_ns

__all__ = ["StreamDecoder", "GpsdJsonDecoder", "split_rows", "rows_record", "record_rows", "dicts_record"]

_NEVER = int(np.iinfo(np.int64).min)
_ROW_NAMES = ("gps_ns",) + EPOCH_FIELDS + ("time_acc_s",)
_DTYPES = {"gps_ns": np.int64, "fix_mode": np.int8, "time_valid": np.bool_, "n_sats": np.int16, "leap_s": np.int16,
           "leap_pending": np.int8}
_GPS_EPOCH_UNIX_S = 315_964_800  # 1980-01-06T00:00:00 UTC


def split_rows(rows: dict | None) -> list[dict]:
    """Column arrays -> one dict of Python scalars per epoch (``gps_ns``, :data:`EPOCH_FIELDS` and
    ``time_acc_s`` when the rows have it)."""
    if rows is None or rows["gps_ns"].size == 0:
        return []
    names = ("gps_ns",) + EPOCH_FIELDS + (("time_acc_s",) if "time_acc_s" in rows else ())
    cols = {k: rows[k].tolist() for k in names}
    return [{k: cols[k][i] for k in cols} for i in range(len(cols["gps_ns"]))]


def rows_record(rows: dict, source: str, offsets=None) -> EpochRecord | None:
    """Decoded epochs (column arrays: ``gps_ns`` and the receiver fields) as one record chunk, provenance the
    byte offsets given (else unknown); None when there are none."""
    if rows is None or rows["gps_ns"].size == 0:
        return None
    columns = {k: rows[k] for k in EPOCH_FIELDS + ("time_acc_s",) if k in rows}
    n = rows["gps_ns"].size
    return EpochRecord.from_arrays(rows["gps_ns"], columns, {k: RECEIVER_UNITS[k] for k in columns}, source=source,
                                   valid=np.asarray(rows["fix_mode"]) != 1,
                                   position=np.full(n, -1, dtype=np.int64) if offsets is None else offsets,
                                   position_unit="byte")


def dicts_record(epochs: list[dict], source: str) -> EpochRecord | None:
    """Epoch dicts (``gps_ns`` and the receiver fields) as one record chunk; None when there are none."""
    if not epochs:
        return None
    rows = {k: np.array([e[k] for e in epochs]) for k in ("gps_ns",) + EPOCH_FIELDS}
    rows["gps_ns"] = rows["gps_ns"].astype(np.int64)
    return rows_record(rows, source)


def record_rows(record: EpochRecord | None) -> list[dict]:
    """A receiver record chunk as one dict of Python scalars per epoch (what the monitor logs)."""
    if record is None:
        return []
    return split_rows({"gps_ns": np.asarray(record.t_ns), **record.columns})


class _OneReceiverStream:
    """``decode``/``finish`` of a stream that carries one receiver: its record chunks as ``[(None, record)]``."""

    def decode(self, data: bytes) -> list:
        """:meth:`feed_record` as ``[(None, record)]`` (the one receiver of the stream), or ``[]``."""
        record = self.feed_record(data)
        return [] if record is None else [(None, record)]

    def finish(self) -> list:
        """:meth:`close_record` as ``[(None, record)]``, or ``[]``."""
        record = self.close_record()
        return [] if record is None else [(None, record)]


class StreamDecoder(_OneReceiverStream):
    """One receiver's live decoder (framer + pynmeagps/pyubx2 + epoch assembly), kept across reconnects.

    A stream carrying both NMEA and UBX is one receiver, merged as the batch reader merges it
    (:func:`chronofuse.io.inspect.merge_epochs`: UBX fields first, NMEA filling the rest and adding the
    epochs UBX did not report). An epoch is released once every protocol of the stream has closed an
    epoch at or after it, so the other protocol's report of the same instant is never missed; a protocol
    that falls silent (more than ``max_wait_s`` of the other's time behind) stops holding the stream back.
    """

    def __init__(self, reference_gps_ns: int | None = None, max_wait_s: float = 3.0, source: str = "<stream>") -> None:
        self.source = source
        self.offsets = EpochOffsets()
        self.scanner = FrameScanner()
        self.nmea_stats, self.ubx_stats = NmeaDecodeStats(), UbxDecodeStats()
        self._nmea = NmeaEpochBuilder(reference_gps_ns)
        self._ubx = UbxEpochBuilder()
        self.max_wait_ns = int(round(max_wait_s * NS_PER_S))
        self.protocols: tuple[str, ...] = ()  # "ubx", "nmea": navigation seen in the stream, in order met
        self._pending = {"ubx": [], "nmea": []}  # closed epochs (row arrays) not yet released
        self._closed: dict[str, int | None] = {}  # protocol -> gps_ns of its last closed epoch (None: none yet)
        self._first_closed: int | None = None  # the first epoch any protocol closed
        self._last_gps_ns = _NEVER
        # each protocol's epochs put in time order as the batch reader puts them (io/arrival.py)
        self._order = {"ubx": ArrivalOrder(), "nmea": ArrivalOrder()}
        self._columns: dict[str, dict] = {}
        # chunks counted as fed (close counts as one): where each epoch began and closed, for a live driver
        # that stamps arrivals by the chunk's wall time and releases what the buffer holds after a wall time
        self.n_chunks = 0
        self._open_chunk: int | None = None  # the chunk in which the epoch now in progress began
        self.began_in: dict[int, int] = {}  # gps_ns -> the chunk in which its first bytes came
        self._closed_in: dict[int, int] = {}  # gps_ns -> the chunk that closed it (while the buffer holds it)

    @property
    def n_reordered(self) -> int:
        """Epochs that came after a later one and were put back in order (:mod:`chronofuse.io.arrival`)."""
        return sum(o.n_reordered for o in self._order.values())

    @property
    def n_late(self) -> int:
        """Epochs that came too late to be put back in order, left out (:mod:`chronofuse.io.arrival`)."""
        return sum(o.n_late for o in self._order.values())

    def feed(self, data: bytes) -> list[dict]:
        """Decode ``data``; return the epochs that closed, in time order (an epoch that repeats or runs
        behind the last one returned is dropped, as the batch reader drops duplicates)."""
        return record_rows(self.feed_record(data))

    def close(self) -> list[dict]:
        """End of stream: flush the epochs in progress."""
        return record_rows(self.close_record())

    def feed_record(self, data: bytes) -> EpochRecord | None:
        """:meth:`feed`, the epochs as one record chunk (with ``time_acc_s`` and each epoch's byte offset)."""
        self._count_chunk()
        return self._decode(self.scanner.feed(data), final=False)

    def close_record(self) -> EpochRecord | None:
        """:meth:`close`, as one record chunk."""
        self._count_chunk()
        return self._decode(self.scanner.close(), final=True)

    def release_held(self) -> EpochRecord | None:
        """Release every epoch the reorder buffer holds (a live driver's call once the oldest has waited its
        wall time, :attr:`oldest_held_chunk`): an epoch that comes behind them afterwards is late and left
        out, as one more than :data:`~chronofuse.io.arrival.REORDER_EPOCHS` epochs late is."""
        if self.protocols == ("ubx",) and not self._pending["ubx"]:
            return self._ubx_only(final=False, flush=True)
        for name in ("ubx", "nmea"):
            if self._order[name].n_held:
                self._take(name, None, final=True)
        return self._release(self._horizon())

    @property
    def oldest_held_chunk(self) -> int | None:
        """The chunk that closed the oldest epoch the reorder buffer holds (None: it holds none)."""
        held = set().union(*(o.held for o in self._order.values()))
        self._closed_in = {g: c for g, c in self._closed_in.items() if g in held}  # not dropped ones
        return min(self._closed_in.values()) if self._closed_in else None

    def _count_chunk(self) -> None:
        self.n_chunks += 1
        if self._open_chunk is None:
            self._open_chunk = self.n_chunks

    def _closing(self, times) -> None:
        """Note the epochs closed in this chunk: each began in the chunk that closed the one before it."""
        for g in times:
            g = int(g)
            if g not in self.began_in:
                self.began_in[g] = self._open_chunk
                self._closed_in[g] = self.n_chunks
            self._open_chunk = self.n_chunks
        if len(self.began_in) > 4096:  # a driver that never asks: keep the newest
            for g in sorted(self.began_in)[:2048]:
                del self.began_in[g]

    def _released(self, times) -> None:
        for g in times:
            self._closed_in.pop(int(g), None)


    @property
    def n_damaged(self) -> int:
        """Frames lost to damage so far: UBX checksum failures, truncated frames, frames pyubx2 refused."""
        return int(self.scanner.stats.ubx_bad_checksum + self.scanner.stats.truncated + self.ubx_stats.parse_errors)

    def _decode(self, frames, final: bool) -> EpochRecord | None:
        self.offsets.feed(frames)
        decode_ubx(frames, self._ubx, self.ubx_stats)
        decode_nmea(frames, self._nmea, self.nmea_stats)
        for name, stats in (("ubx", self.ubx_stats), ("nmea", self.nmea_stats)):
            if name not in self.protocols and sum(stats.decoded.values()):
                self.protocols += (name,)
                self._closed.setdefault(name, None)
        if self.protocols == ("ubx",) and not self._pending["ubx"]:
            return self._ubx_only(final)
        self._take("ubx", self._ubx.pop_complete(self.ubx_stats))
        self._take("nmea", self._nmea.pop_complete())
        if final:
            self._take("ubx", self._ubx.pop_all(self.ubx_stats), final=True)
            self._take("nmea", self._nmea.pop_all(), final=True)
        return self._release(np.iinfo(np.int64).max if final else self._horizon())

    def _ubx_only(self, final: bool, flush: bool = False) -> EpochRecord | None:
        """A stream of UBX alone: the epochs straight from the builder's scalar path (no merge to wait for,
        no arrays to set up per column for the one or two epochs a chunk closes), as one record chunk."""
        records = [] if flush else self._ubx.pop_complete_records(self.ubx_stats)
        if final:
            records += self._ubx.pop_all_records(self.ubx_stats)
        order = self._order["ubx"]
        self._closing(r["gps_ns"] for r in records)
        records = order.push([r["gps_ns"] for r in records], records) + (order.flush() if final or flush else [])
        self._released(r["gps_ns"] for r in records)
        kept = []
        for epoch in records:
            if epoch["gps_ns"] > self._last_gps_ns:
                kept.append(epoch)
                self._last_gps_ns = epoch["gps_ns"]
        if not kept:
            return None
        last = kept[-1]["gps_ns"]
        previous = self._closed.get("ubx")
        self._closed["ubx"] = last if previous is None else max(previous, last)
        if self._first_closed is None:
            self._first_closed = kept[0]["gps_ns"]
        rows = {k: np.array([e[k] for e in kept], dtype=_DTYPES.get(k, np.float64)) for k in _ROW_NAMES}
        offsets = self.offsets.of(rows["gps_ns"])
        self.offsets.forget_before(self._last_gps_ns)
        return rows_record(rows, self.source, offsets)

    def _take(self, name: str, rows: dict | None, final: bool = False) -> None:
        order = self._order[name]
        if rows is not None and rows["gps_ns"].size:
            self._columns[name] = {k: v[:0] for k, v in rows.items()}  # the columns of what the buffer holds
            self._closing(rows["gps_ns"].tolist())
            rows = in_arrival_order(rows, order, final=final)
        elif final and order.n_held:
            rows = in_arrival_order(self._columns[name], order, final=True)
        if rows is not None and rows["gps_ns"].size:
            self._released(rows["gps_ns"].tolist())
            self._pending[name].append(rows)
            last = int(rows["gps_ns"].max())
            previous = self._closed.get(name)
            self._closed[name] = last if previous is None else max(previous, last)
            if self._first_closed is None:
                self._first_closed = last

    def _horizon(self) -> int:
        """The latest epoch every live protocol has closed: the slowest protocol's mark, leaving out one
        that is more than ``max_wait_ns`` behind the fastest (silent, or not on this port any more); a
        protocol that has closed no epoch yet stands just before the stream's first closed epoch."""
        if self._first_closed is None:
            return _NEVER
        marks = [self._first_closed - 1 if t is None else t for t in self._closed.values()]
        lead = max(marks)
        return min(t for t in marks if lead - t <= self.max_wait_ns)

    def _release(self, horizon: int) -> EpochRecord | None:
        parts = {}
        for name in ("ubx", "nmea"):
            rows = _joined(self._pending[name])
            if rows is None:
                parts[name], self._pending[name] = {"gps_ns": np.zeros(0, np.int64)}, []
                continue
            ready = rows["gps_ns"] <= horizon
            parts[name] = {k: v[ready] for k, v in rows.items()}
            self._pending[name] = [] if ready.all() else [{k: v[~ready] for k, v in rows.items()}]
        if parts["ubx"]["gps_ns"].size + parts["nmea"]["gps_ns"].size == 0:
            return None
        merged = merge_epochs(parts["ubx"], parts["nmea"])
        tacc = np.full(merged["gps_ns"].size, np.nan)  # as the batch reader: every UBX epoch is among the merged
        if parts["ubx"]["gps_ns"].size:
            tacc[np.searchsorted(merged["gps_ns"], parts["ubx"]["gps_ns"])] = parts["ubx"]["time_acc_s"]
        merged["time_acc_s"] = tacc
        merged, _ = strictly_increasing(merged)
        keep = merged["gps_ns"] > self._last_gps_ns  # sorted and unique: only a repeat of what was released goes
        merged = {k: v[keep] for k, v in merged.items()}
        if merged["gps_ns"].size == 0:
            return None
        self._last_gps_ns = int(merged["gps_ns"][-1])
        offsets = self.offsets.of(merged["gps_ns"]) if "ubx" in self.protocols else None
        self.offsets.forget_before(self._last_gps_ns)
        return rows_record(merged, self.source, offsets)


def _joined(parts: list[dict]) -> dict | None:
    if not parts:
        return None
    if len(parts) == 1:
        return parts[0]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


class GpsdJsonDecoder(_OneReceiverStream):
    """A gpsd server's JSON reports (gpsd_json(5)) to epochs: a TPV with a ``time`` opens an epoch
    (UTC label, ``mode``, ``leapseconds`` when gpsd knows it, else the leap-second table), a SKY adds its
    DOPs and ``uSat``; an epoch closes when the next TPV time arrives.

    Timing reports (sent when the watch asks for ``"pps":true``): ``TOFF`` is gpsd's receipt of the
    receiver's time message (``real`` the UTC second it names, ``clock`` the system time it arrived): it
    becomes the epoch's ``received_unix_ns``. ``PPS`` is a 1PPS edge timed by the system (kernel PPS or
    a modem-control line): ``clock`` is the edge, ``real`` the second it marks; it becomes
    ``pps_unix_ns`` (and its ``qErr``, ps, the epoch's ``qerr_s``). Neither carries the receiver's clock
    bias or drift, which gpsd does not report."""

    def __init__(self) -> None:
        self._buffer = b""
        self._current: dict | None = None
        self._last_gps_ns = np.iinfo(np.int64).min
        self._toff: dict[int, int] = {}  # UTC UNIX s -> system receipt, UNIX ns
        self._pps: dict[int, tuple[int, float]] = {}  # UTC UNIX s -> (edge, UNIX ns; qErr s)
        #: gps_ns -> {"received_unix_ns", "pps_unix_ns"} of the epochs given, for a caller that keeps
        #: only the receiver fields (the monitor pops them); the epoch dicts carry them too
        self.timing: dict[int, dict] = {}
        self.bad_lines = 0
        self.timing_reports = 0
        self.protocol = "gpsd"

    def feed(self, data: bytes) -> list[dict]:
        self._buffer += data
        *lines, self._buffer = self._buffer.split(b"\n")
        out: list[dict] = []
        for line in lines:
            self._line(line.strip(), out)
        return out

    def feed_record(self, data: bytes) -> EpochRecord | None:
        """:meth:`feed`, the epochs as one record chunk (no byte offsets: gpsd's reports are not the receiver's)."""
        return dicts_record(self.feed(data), "<gpsd>")

    def close_record(self) -> EpochRecord | None:
        return dicts_record(self.close(), "<gpsd>")


    def close(self) -> list[dict]:
        out: list[dict] = []
        if self._buffer.strip():
            self._line(self._buffer.strip(), out)
        self._buffer = b""
        self._emit(out)
        return out

    def _line(self, line: bytes, out: list) -> None:
        if not line:
            return
        try:
            doc = json.loads(line)
        except ValueError:
            self.bad_lines += 1
            return
        if not isinstance(doc, dict):
            self.bad_lines += 1
            return
        cls = doc.get("class")
        if cls == "TPV" and "time" in doc:
            try:
                utc = np.datetime64(str(doc["time"]).rstrip("Z"), "ns")
            except ValueError:
                self.bad_lines += 1
                return
            utc_ns = int(datetime64_to_gps_ns(utc))
            # gpsd's "leapseconds" is GPS - UTC (18 since 2017); absent, the table's value at that date
            leap = int(doc["leapseconds"]) if "leapseconds" in doc else int(gps_minus_utc_s(utc_to_gps_ns(utc)))
            gps_ns = utc_ns + leap * NS_PER_S
            if self._current is not None and self._current["gps_ns"] != gps_ns:
                self._emit(out)
            if self._current is None:
                self._current = _absent_epoch(gps_ns, leap)
            self._current["fix_mode"] = int(doc.get("mode", 0))
            self._current["time_valid"] = int(doc.get("mode", 0)) >= 2
        elif cls in ("TOFF", "PPS"):
            try:
                real_s = int(doc["real_sec"]) + (1 if int(doc.get("real_nsec", 0)) >= 500_000_000 else 0)
                clock_ns = int(doc["clock_sec"]) * NS_PER_S + int(doc.get("clock_nsec", 0))
            except (KeyError, TypeError, ValueError):
                self.bad_lines += 1
                return
            self.timing_reports += 1
            if cls == "TOFF":
                self._toff[real_s] = clock_ns
            else:
                qerr = doc.get("qErr")
                self._pps[real_s] = (clock_ns, math.nan if qerr is None else float(qerr) * 1e-12)
            for table in (self._toff, self._pps):
                while len(table) > 16:
                    table.pop(min(table))
        elif cls == "SKY" and self._current is not None:
            for name in ("gdop", "pdop", "hdop", "vdop", "tdop"):
                if name in doc:
                    self._current[name] = float(doc[name])
            if "uSat" in doc:
                self._current["n_sats"] = int(doc["uSat"])

    def _emit(self, out: list) -> None:
        if self._current is not None and self._current["gps_ns"] > self._last_gps_ns:
            utc_s = (self._current["gps_ns"] - self._current["leap_s"] * NS_PER_S) // NS_PER_S + _GPS_EPOCH_UNIX_S
            if utc_s in self._toff:
                self._current["received_unix_ns"] = self._toff.pop(utc_s)
            if utc_s in self._pps:
                edge, qerr = self._pps.pop(utc_s)
                self._current["pps_unix_ns"] = edge
                if math.isfinite(qerr):
                    self._current["qerr_s"] = qerr
            told = {k: self._current[k] for k in ("received_unix_ns", "pps_unix_ns") if k in self._current}
            if told:
                self.timing[self._current["gps_ns"]] = told
                while len(self.timing) > 64:
                    self.timing.pop(min(self.timing))
            out.append(self._current)
            self._last_gps_ns = self._current["gps_ns"]
        self._current = None


def _absent_epoch(gps_ns: int, leap_s: int) -> dict:
    return {"gps_ns": gps_ns, "fix_mode": 0, "time_valid": False, "n_sats": -1, "gdop": math.nan,
            "pdop": math.nan, "hdop": math.nan, "vdop": math.nan, "tdop": math.nan, "leap_s": leap_s,
            "leap_pending": 0, "qerr_s": math.nan, "clock_bias_s": math.nan, "clock_drift_s_per_s": math.nan}

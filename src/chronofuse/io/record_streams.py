"""Byte and text streams (standard input, a pipe, a FIFO, a file still being written) as record chunks.

:func:`open_stream` looks at a stream's first bytes (gzip decompressed as it arrives) and returns the reader
its format needs, each turning what arrives into :class:`~chronofuse.record.EpochRecord` chunks the moment
an epoch is complete, with the provenance of each epoch:

* :class:`ReceiverBytes`: NMEA and UBX bytes (mixed with RTCM and noise), through the live decoder the
  monitor uses (:class:`chronofuse.io.sources_decode.StreamDecoder`; the batch reader's epochs whatever
  the split): receiver columns on GPS time, each epoch's byte offset;
* :class:`ClockProductLines`: a RINEX clock product's ``AR`` records, one chunk per station as its epochs
  arrive (GPS time, the record's line);
* :class:`TextLines`: a time-and-value CSV/text stream (the file's own axis, each epoch's line), read with
  the naming rules of :func:`chronofuse.io.records.read_record` (a header names the columns; the time
  column is the first named ``t``, ``time``, ``t_s``, ``mjd``..., or the first; a ``_ns``/``_us``/``_ms``
  suffix or ``mjd`` gives its unit, a value column's suffix scales it to seconds) and its exact conversion
  of decimal time text to integer nanoseconds (:func:`chronofuse.io.columns.decimal_text_to_ns`), so a
  time tag keeps its odd nanoseconds.

Each reader has ``feed(data) -> chunks`` and ``close() -> chunks`` (a list of ``(key, record)`` pairs:
``key`` the station of a clock product, else None).
"""

from __future__ import annotations

import zlib
from collections.abc import Iterable, Iterator

import numpy as np
import pyarrow as pa

from chronofuse.io.columns import decimal_text_to_ns
from chronofuse.io.formats import LOG_FORMATS, format_of_head
from chronofuse.io.record_columns import TIME_NAMES, time_ns_per_unit
from chronofuse.io.units import column_unit
from chronofuse.io.rinex_clock import is_rinex_clock, parse_ar_line
from chronofuse.io.sources_decode import StreamDecoder
from chronofuse.record import EpochRecord
from chronofuse.validation import InputDataError, InputError

__all__ = ["ReceiverBytes", "ClockProductLines", "ClockProductReceivers", "TextLines", "open_stream", "read_chunks",
           "decoder_for", "SNIFF_BYTES"]

#: Bytes looked at to tell a stream's format (fewer when it ends or two whole lines have come).
SNIFF_BYTES = 4096
_GZIP_MAGIC = b"\x1f\x8b"


class ReceiverBytes:
    """NMEA/UBX bytes to receiver record chunks (module docstring)."""

    kind = "receiver"

    def __init__(self, source: str):
        self.decoder = StreamDecoder(source=source)
        self.source = source

    def feed(self, data: bytes) -> list:
        record = self.decoder.feed_record(data)
        return [] if record is None else [(None, record)]

    def close(self) -> list:
        record = self.decoder.close_record()
        return [] if record is None else [(None, record)]

    @property
    def n_damaged(self) -> int:
        return self.decoder.n_damaged


class _Lines:
    """Complete text lines of a byte stream, with their 1-based numbers."""

    def __init__(self):
        self._pending = b""
        self._number = 0

    def lines(self, data: bytes, final: bool = False) -> Iterator[tuple[int, str]]:
        buf = self._pending + data
        *whole, self._pending = buf.split(b"\n")
        if final and self._pending:
            whole.append(self._pending)
            self._pending = b""
        for raw in whole:
            self._number += 1
            yield self._number, raw.decode("utf-8", errors="replace").rstrip("\r")


class ClockProductLines(_Lines):
    """A RINEX clock product's ``AR`` records to one record chunk per station (module docstring); the header
    is passed over up to ``END OF HEADER``; an unreadable ``AR`` line is counted in ``n_bad_lines``."""

    kind = "rinex-clock"

    def __init__(self, source: str):
        super().__init__()
        self.source = source
        self.in_header = True
        self.n_bad_lines = 0
        self.stations: list[str] = []

    def feed(self, data: bytes, final: bool = False) -> list:
        rows: dict[str, list] = {}
        for number, line in self.lines(data, final):
            if number == 1 and not is_rinex_clock(line):
                raise InputDataError("not a RINEX clock file (no 'C' in the RINEX VERSION / TYPE line)", self.source, 1)
            if self.in_header:
                self.in_header = "END OF HEADER" not in line
                continue
            try:
                parsed = parse_ar_line(line)
            except ValueError:
                self.n_bad_lines += 1
                continue
            if parsed is not None:
                if parsed[0] not in self.stations:
                    self.stations.append(parsed[0])
                rows.setdefault(parsed[0], []).append((parsed[1], parsed[2], number))
        out = []
        for name, epochs in rows.items():
            out.append((name, EpochRecord.from_arrays(
                np.array([e[0] for e in epochs], dtype=np.int64), {"clock_bias_s": np.array([e[1] for e in epochs])},
                {"clock_bias_s": "s"}, source=self.source, position=np.array([e[2] for e in epochs], dtype=np.int64),
                position_unit="line", info={"station": name})))
        return out

    def close(self) -> list:
        return self.feed(b"", final=True)


class ClockProductReceivers:
    """A RINEX clock product's stations as receivers for the monitor: :class:`ClockProductLines` chunks with
    every receiver field (a clock product reports only the bias: no fix report, ``fix_mode`` 0 and NaN DOPs,
    as :func:`chronofuse.io.rinex_epochs.read_rinex_clock_epochs` gives them; the leap count of the header's
    leap records as its version defines them (:func:`chronofuse.io.rinex_epochs.header_leap`), else the table). ``decode``/``finish`` give ``[(station, record)]``."""

    def __init__(self, source: str):
        self.lines = ClockProductLines(source)
        self._leap: int | None = None
        self._header = ""

    def _receivers(self, parts: list) -> list:
        from chronofuse.epochs import ReceiverEpochs
        from chronofuse.timescale import gps_minus_utc_s

        out = []
        for station, record in parts:
            leap = self._leap if self._leap is not None else gps_minus_utc_s(record.t_ns)
            fields = ReceiverEpochs.absent(record.t_ns, 1, 1, leap_s=leap)
            fields["clock_bias_s"] = record.columns["clock_bias_s"][None, None, :]
            epochs = ReceiverEpochs(**fields)
            full = epochs.to_record(record.source, position=record.provenance.position, position_unit="line")
            out.append((station, full.select(0, 0)))
        return out

    def decode(self, data: bytes) -> list:
        if self.lines.in_header and self._leap is None:
            from chronofuse.io.rinex_epochs import header_leap

            self._header += data.decode("ascii", errors="replace")
            if "END OF HEADER" in self._header:  # the leap records read as the file's version defines them
                self._leap = header_leap(self._header.splitlines())
        return self._receivers(self.lines.feed(data))

    def finish(self) -> list:
        return self._receivers(self.lines.close())


def decoder_for(source):
    """The decoder a monitor source's bytes need: gpsd JSON, a replayed RINEX clock product (each station a
    receiver), or raw NMEA/UBX. Each has ``decode(data)`` and ``finish()`` giving ``[(key, record)]`` (``key``
    a station, or None for the source's one receiver)."""
    from chronofuse.io.sources_decode import GpsdJsonDecoder

    if getattr(source, "kind", "raw") == "gpsd":
        return GpsdJsonDecoder()
    path = getattr(source, "path", None)
    if path is not None:
        from chronofuse.io.formats import sniff_format

        try:
            if sniff_format(path) == "rinex-clock":
                return ClockProductReceivers(str(path))
        except InputDataError:
            pass  # the source itself says what is wrong with the file when it reads it
    return StreamDecoder(source=getattr(source, "name", "<stream>"))


class TextLines(_Lines):
    """A time-and-value text stream to record chunks (module docstring): ``column`` names (or numbers, from
    1) the value column; ``rate_hz`` gives the interval of a one-column stream (its epochs then count from 0).
    The value column becomes ``name`` (unit ``s``)."""

    kind = "text"

    def __init__(self, source: str, *, column: str | None = None, rate_hz: float | None = None,
                 name: str = "clock_bias_s", prefer: str = "clock_bias"):
        super().__init__()
        self.source = source
        self.column, self.rate_hz, self.name, self.prefer = column, rate_hz, name, prefer
        self._layout = None  # (time index or None, value index, value scale, time ns per unit, width)
        self._sample = 0
        self._last_t_ns: int | None = None  # the stream's last time tag, to refuse one that does not increase

    def _choose(self, header: list[str] | None, width: int, number: int) -> tuple:
        names = header if header is not None else [str(i + 1) for i in range(width)]
        lowered = [n.lower() for n in names]
        time_idx = None
        if width >= 2:
            time_idx = next((i for i, n in enumerate(lowered) if n in TIME_NAMES or n.startswith(("t_", "mjd"))), 0)
        if self.column is not None:
            if self.column in names:
                value_idx = names.index(self.column)
            elif self.column.isdigit() and 1 <= int(self.column) <= width:
                value_idx = int(self.column) - 1
            else:
                raise InputDataError(f"column {self.column!r} not found; columns are {names} (or 1..{width})",
                                     self.source, number)
        else:
            value_idx = next((i for i, n in enumerate(lowered) if header is not None and n.startswith(self.prefer)),
                             None)
            if value_idx is None:
                if width == 1:
                    value_idx = 0
                elif width == 2:
                    value_idx = 1 - time_idx
                else:
                    raise InputError(f"{width} columns {names}: choose the value column ({{column}})",
                                     self.source, number, fields=("column",))
        if value_idx == time_idx:
            time_idx = None
        if time_idx is None and self.rate_hz is None:
            raise InputError("one-column stream: give the sample rate ({rate_hz}, Hz)", self.source, number,
                             fields=("rate_hz",))
        unit = column_unit(names[value_idx]) if header is not None else None
        scale = unit.scale if unit is not None and unit.quantity in ("time", "factor") else 1.0
        per_unit = time_ns_per_unit(names[time_idx]) if (header is not None and time_idx is not None) else None
        unit_ns = 1_000_000_000 if per_unit is None else per_unit
        return time_idx, value_idx, scale, unit_ns, width

    def feed(self, data: bytes, final: bool = False) -> list:
        t_text, values, lines = [], [], []
        for number, raw in self.lines(data, final):
            line = raw.split("#", 1)[0].strip()
            if not line or line.startswith(";"):
                continue
            fields = [f.strip() for f in line.replace(";", ",").replace("\t", ",").split(",")] if (
                "," in line or ";" in line or "\t" in line) else line.split()
            if self._layout is None:
                numeric = _numeric(fields[0]) and all(_numeric(f) for f in fields)
                self._layout = self._choose(None if numeric else fields, len(fields), number)
                if not numeric:
                    continue
            time_idx, value_idx, scale, _, width = self._layout
            if len(fields) != width:
                raise InputDataError(f"{len(fields)} values where the stream has {width} columns", self.source, number)
            try:
                value = float(fields[value_idx]) * scale
            except ValueError:
                raise InputDataError(f"cannot read {fields[value_idx]!r} as a number", self.source, number) from None
            if np.isinf(value):
                raise InputDataError("infinite value", self.source, number)
            t_text.append(fields[time_idx] if time_idx is not None else None)
            values.append(value)
            lines.append(number)
        if not values:
            return []
        time_idx, _, _, unit_ns, _ = self._layout
        if time_idx is None:
            interval = int(round(1e9 / self.rate_hz))
            t_ns = (self._sample + np.arange(len(values), dtype=np.int64)) * interval
        else:
            t_ns, bad = decimal_text_to_ns(pa.array(t_text, type=pa.string()), unit_ns)
            if bad >= 0:
                raise InputDataError(f"cannot read {t_text[bad]!r} as a time", self.source, lines[bad])
        self._sample += len(values)
        t_ns = np.asarray(t_ns, dtype=np.int64)
        before = t_ns if self._last_t_ns is None else np.concatenate(([self._last_t_ns], t_ns))
        back = np.flatnonzero(np.diff(before) <= 0)
        if back.size:  # what the file reader refuses, with the same words (an input error, not a bug)
            k = int(back[0])
            raise InputDataError(f"time is not increasing ({int(before[k])} ns then {int(before[k + 1])} ns on the "
                                 "file's scale)", self.source, lines[k + 1 if self._last_t_ns is None else k])
        self._last_t_ns = int(t_ns[-1])
        record = EpochRecord.from_arrays(t_ns, {self.name: np.array(values)},
                                         {self.name: "s"}, source=self.source, time_scale="file",
                                         position=np.array(lines, dtype=np.int64), position_unit="line")
        return [(None, record)]

    def close(self) -> list:
        return self.feed(b"", final=True)


def _numeric(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


class _Gunzip:
    def __init__(self):
        self._z = zlib.decompressobj(wbits=31)

    def __call__(self, data: bytes) -> bytes:
        try:
            return self._z.decompress(data)
        except zlib.error as err:
            raise InputDataError(f"broken gzip stream: {err}") from None


def read_chunks(stream, size: int = 65536, *, idle_s: float | None = None) -> Iterator[bytes]:
    """The bytes of a binary stream as they arrive (a pipe's or a FIFO's read returns what is there).

    ``idle_s``: a stream with a file descriptor also yields ``b""`` after each ``idle_s`` seconds without
    bytes, a tick on which a live reader can release what it holds (:mod:`chronofuse.io.arrival`)."""
    fileno = getattr(stream, "fileno", None)
    try:
        fd = fileno() if idle_s is not None and fileno is not None else None
    except (OSError, ValueError):  # an in-memory stream: no descriptor to wait on
        fd = None
    if fd is not None:
        import os
        import select

        while True:
            ready, _, _ = select.select([fd], [], [], idle_s)
            if not ready:
                yield b""
                continue
            data = os.read(fd, size)
            if not data:
                return
            yield data
    read = getattr(stream, "read1", stream.read)
    while True:
        data = read(size)
        if not data:
            return
        yield data


def open_stream(chunks: Iterable[bytes], source: str, *, column: str | None = None, rate_hz: float | None = None
                ) -> tuple[object, Iterator[bytes]]:
    """``(reader, chunks)``: the reader the stream's format needs (module docstring) and its (decompressed)
    bytes from the start. The format is told from the first bytes (up to :data:`SNIFF_BYTES`, or two whole
    lines, or the end); a RINEX observation or navigation stream, or an empty one, is refused naming the source."""
    it = iter(chunks)
    head = b""
    gunzip = None
    for data in it:
        if gunzip is None and not head and data[:2] == _GZIP_MAGIC:
            gunzip = _Gunzip()
        head += gunzip(data) if gunzip is not None else data
        if len(head) >= SNIFF_BYTES or head.count(b"\n") >= 2 or b"\xb5\x62" in head:
            break
    if not head:
        raise InputDataError("empty stream", source)
    kind = format_of_head(head[:SNIFF_BYTES])

    def rest() -> Iterator[bytes]:
        yield head
        for data in it:
            yield gunzip(data) if gunzip is not None else data

    if kind in ("ubx", "nmea"):
        return ReceiverBytes(source), rest()
    if kind == "rinex-clock":
        return ClockProductLines(source), rest()
    if kind in ("rinex-obs", "rinex-nav"):
        raise InputDataError(f"a {kind} stream holds no receiver clock bias: identification mode reads a RINEX "
                             "observation file with its navigation file", source)
    if kind in LOG_FORMATS:  # its clocks are told apart over the whole log: read from a file
        raise InputDataError(f"a {kind} log is read from a file (detect FILE), not from a stream", source)
    return TextLines(source, column=column, rate_hz=rate_hz), rest()

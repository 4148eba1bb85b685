"""Clock-bias detection on a stream, epoch by epoch: standard input, a pipe, a FIFO, a file still being written.

:class:`StreamDetection` reads a byte stream of any format ``chronofuse inspect`` reads for a clock bias
(UBX alone or with NMEA, a RINEX clock product, a time-and-value CSV; gzip or not;
:func:`chronofuse.io.record_streams.open_stream`) and yields one
:class:`~chronofuse.integrity.streaming.EpochVerdict` per epoch as it is decided, through the same steps
``detect FILE`` takes: the epochs carrying a clock bias (:func:`chronofuse.io.capture_series.clock_epochs`),
their grid (:class:`chronofuse.io.grid.GridPlacer`, the batch reader's placement) and the detection pipeline's
live driver (:class:`chronofuse.integrity.watch.ClockWatch`). Nothing is read ahead: what has arrived is
decided before more is read (a grid waits for its first epochs to learn the interval, unless a rate is
given; a training stretch is reported ``unavailable`` while it arrives). At the end,
:meth:`StreamDetection.document` is the document ``detect FILE`` gives for the same data.

A clock product without ``station`` watches every station (verdicts ``(station, verdict)``).
:func:`stream_verdicts` is the same for ``time,clock_bias`` text lines.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator

import numpy as np

from chronofuse.integrity.document import check_length, detection_document
from chronofuse.integrity.products import product_document, station_row
from chronofuse.integrity.streaming import EpochVerdict
from chronofuse.integrity.watch import DetectionSettings, ClockWatch
from chronofuse.io.arrival import REORDER_HOLD_S, arrival_warnings
from chronofuse.io.capture_series import clock_epochs, clock_grid, no_bias_reason
from chronofuse.io.formats import check_applies
from chronofuse.io.grid import GridPlacer
from chronofuse.io.record_streams import ClockProductLines, ReceiverBytes, TextLines, open_stream
from chronofuse.io.rinex_clock import CLOCK_TOLERANCE
from chronofuse.record import EpochRecord
from chronofuse.validation import InputDataError, InputError

__all__ = ["StreamDetection", "stream_verdicts", "follow_lines"]

# A text stream's time tags may sit this fraction of an interval off their slot (the record reader's rule).
_TEXT_TOLERANCE = 0.25


class _Clock:
    """One clock of the stream: its grid, its watch and what was placed (for the closing document)."""

    def __init__(self, placer: GridPlacer, settings: DetectionSettings, *, lone_epoch_ok: bool = False):
        self.placer = placer
        self.watch = ClockWatch(settings)
        self.placed: list[EpochRecord] = []
        self.n_raw = 0
        self.lone_epoch_ok = lone_epoch_ok  # a clock product's station with one epoch: a row, not an error

    def push(self, record) -> list[EpochVerdict]:
        if record is None:
            return []
        self.n_raw += record.n_epochs
        gridded = self.placer.push(record)
        return self._watch(gridded)

    def close(self) -> list[EpochVerdict]:
        if self.lone_epoch_ok and self.n_raw < 2 and self.placer.interval_ns is None:
            return []
        out = self._watch(self.placer.close())
        self.watch.close()
        return out

    def _watch(self, gridded) -> list[EpochVerdict]:
        if gridded is None:
            return []
        self.placed.append(gridded)
        return self.watch.push(gridded)

    def record(self) -> EpochRecord | None:
        return EpochRecord.concat(self.placed) if self.placed else None


class StreamDetection:
    """Detection on a byte stream (module docstring). Iterate to get ``(station or None, verdict)`` pairs as
    epochs are decided; then :meth:`document`."""

    def __init__(self, chunks: Iterable[bytes], settings: DetectionSettings, *, source: str = "<stdin>",
                 rate_hz: float | None = None, column: str | None = None, station: str | None = None,
                 live: bool = False):
        self.settings, self.source, self.rate_hz, self.station = settings, source, rate_hz, station
        self.reader, self._chunks = open_stream(chunks, source, column=column, rate_hz=rate_hz)
        check_applies(self.reader.kind, source, column=column, rate_hz=rate_hz)  # as detect FILE refuses them
        if station is not None and not isinstance(self.reader, ClockProductLines):
            raise InputError("{station} needs a RINEX clock product (.clk)", source, fields=("station",))
        self.clocks: dict[str | None, _Clock] = {}
        self._done = False
        #: Live (a reader that ticks when idle, :func:`~chronofuse.io.record_streams.read_chunks`): a receiver's
        #: epochs held for a late one are released after :data:`~chronofuse.io.arrival.REORDER_HOLD_S` of wall
        #: time, as the monitor releases them; a file or a pipe written faster than that reads as in batch.
        self.live = live
        self._chunk_wall: dict[int, float] = {}

    def _release_held(self, data: bytes) -> list:
        decoder = getattr(self.reader, "decoder", None)
        if decoder is None or not hasattr(decoder, "oldest_held_chunk"):
            return []
        now = time.monotonic()
        if data:
            self._chunk_wall[decoder.n_chunks] = now
        chunk = decoder.oldest_held_chunk
        if chunk is None:
            self._chunk_wall.clear()
            return []
        closed = self._chunk_wall.get(chunk)
        if closed is None or now - closed < REORDER_HOLD_S:
            return []
        self._chunk_wall = {c: t for c, t in self._chunk_wall.items() if c > chunk}
        record = decoder.release_held()
        return [] if record is None else [(None, record)]

    def _placer(self) -> GridPlacer:
        if isinstance(self.reader, ReceiverBytes):
            return clock_grid(self.rate_hz)
        if isinstance(self.reader, ClockProductLines):
            return GridPlacer(tolerance=CLOCK_TOLERANCE)
        interval = None if self.rate_hz is None or self.reader._layout is None or self.reader._layout[0] is not None \
            else int(round(1e9 / self.rate_hz))
        return GridPlacer(interval, tolerance=_TEXT_TOLERANCE)

    def _take(self, parts: list) -> Iterator[tuple[str | None, EpochVerdict]]:
        for key, record in parts:
            if isinstance(self.reader, ReceiverBytes):
                record = clock_epochs(record)
                if record is None:
                    continue
            elif isinstance(self.reader, ClockProductLines) and self.station is not None and key != self.station:
                continue
            clock = self.clocks.get(key)
            if clock is None:
                clock = self.clocks[key] = _Clock(self._placer(), self.settings,
                                                  lone_epoch_ok=isinstance(self.reader, ClockProductLines))
            for verdict in clock.push(record):
                yield key, verdict

    def __iter__(self) -> Iterator[tuple[str | None, EpochVerdict]]:
        for data in self._chunks:
            if data:
                yield from self._take(self.reader.feed(data))
            if self.live:
                yield from self._take(self._release_held(data))
        yield from self._take(self.reader.close())
        for key, clock in self.clocks.items():
            for verdict in clock.close():
                yield key, verdict
        self._done = True

    def document(self) -> dict:
        """The ``detect FILE`` document of what the stream held (iterate the stream to its end first)."""
        if not self._done:
            raise RuntimeError("read the stream to its end before asking for its document")
        if isinstance(self.reader, ClockProductLines):
            return self._product_document()
        clock = self.clocks.get(None)
        if clock is None:
            if isinstance(self.reader, ReceiverBytes):
                protocols = self.reader.decoder.protocols
                raise InputDataError(no_bias_reason(protocols, self.reader.decoder.ubx_stats.decoded), self.source)
            raise InputDataError("no data lines (empty stream, or only comments and a header)", self.source)
        record = clock.record()
        check_length(record.n_epochs, self.settings.window, self.source)
        arrival = []
        if isinstance(self.reader, ReceiverBytes):  # the grid's gaps and the frames lost to damage
            n_skipped = int(record.info.get("n_gaps", 0)) + self.reader.n_damaged
            arrival = arrival_warnings(self.reader.decoder.n_reordered, self.reader.decoder.n_late)
        else:  # the grid's gaps and the missing values (NaN)
            n_skipped = int(np.isnan(record.column("clock_bias_s")).sum())
        doc = detection_document(clock.watch.result(), self.settings, n_skipped=n_skipped,
                                 time_scale=record.time_scale)
        doc["warnings"] += arrival  # as detect FILE says it (chronofuse.integrity.modes.detect_record)
        return doc

    def _product_document(self) -> dict:
        if self.station is not None:
            clock = self.clocks.get(self.station)
            if clock is None:
                raise InputError(f"{{station}} == {self.station!r} is not in the stream "
                                 f"({len(self.reader.stations)} stations)", self.source, fields=("station",))
            record = clock.record()
            check_length(record.n_epochs, self.settings.window, self.source)
            doc = detection_document(clock.watch.result(), self.settings, n_skipped=int(record.info["n_gaps"]),
                                     time_scale="gps")
            doc["station"] = self.station
            return doc
        if not self.clocks:
            raise InputDataError("no AR (receiver clock) record in the stream", self.source)
        rows = []
        for name in self.reader.stations:
            clock = self.clocks[name]
            record = clock.record()
            watched = clock.watch.result() if record is not None else None
            rows.append(station_row(name, record, self.settings, watched, source=self.source))
        return product_document(rows, self.settings, n_bad_lines=self.reader.n_bad_lines, source=self.source)


def stream_verdicts(
    lines: Iterable[str],
    *,
    rate_hz: float | None = None,
    column: str | None = None,
    window: int = 20,
    pfa: float = 1e-3,
    h0: float | None = None,
    hm2: float | None = None,
    sigma_rho_m: float | None = None,
    train_s: float | None = None,
    detector: str = "chi-square",
) -> Iterator[EpochVerdict]:
    """One verdict per epoch of ``time,clock_bias`` text ``lines`` as they arrive (:class:`StreamDetection`);
    ``detector`` a name of :data:`chronofuse.integrity.registry.DETECTORS`."""
    from chronofuse.integrity.modes import detection_settings

    settings = detection_settings(detector, window=window, pfa=pfa, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho_m,
                                  train_s=train_s)
    chunks = (line.encode() + (b"" if line.endswith("\n") else b"\n") for line in lines)
    for _, verdict in StreamDetection(chunks, settings, source="<stream>", rate_hz=rate_hz, column=column):
        yield verdict


def follow_lines(stream, *, idle_s: float = 10.0, poll_s: float = 0.2) -> Iterator[str]:
    """The complete lines of a file that is still being written (``tail -f``): at the end of the file wait
    ``poll_s`` and read again; stop when nothing new has come for ``idle_s`` seconds. A last line without
    its newline is held back until it is complete (or the stream ends)."""
    import time

    pending = ""
    quiet_since = time.monotonic()
    while True:
        chunk = stream.readline()
        if chunk:
            quiet_since = time.monotonic()
            pending += chunk
            if pending.endswith("\n"):
                yield pending
                pending = ""
            continue
        if time.monotonic() - quiet_since >= idle_s:
            if pending:
                yield pending
            return
        time.sleep(poll_s)

"""A recording replayed at its own pace: each receiver burst is sent when its epoch comes, as the receiver
sent it.

A byte-paced replay (bytes spread evenly over the recording's span) drifts from the epochs by seconds
whenever a recording's bursts differ in size (a NAV-SAT or RXM-RAWX every few epochs, a block of
configuration messages at the start), so a live consumer that cares about arrival times (the chrony
feed, freshness) would be fed a wrong timing. Here the schedule comes from the frames themselves
(:func:`frame_schedule`): a u-blox navigation frame (class NAV, and RXM-RAWX) carries its epoch's GPS
time of week in its first payload bytes (``iTOW``, ms; RAWX ``rcvTow``, s as a float), an NMEA GGA, RMC,
GLL, GNS or ZDA its UTC time of day; a frame without a time is sent with the frame before it. Times are
taken from one scale (UBX when the recording has any navigation frame, else NMEA), unwrapped across the
week or the day, and held to a running maximum so a late message never moves the schedule back. The
bytes between two epochs' first frames go out together at the later epoch's time divided by ``speed``.
"""

from __future__ import annotations

import struct
import threading
import time
from pathlib import Path

import numpy as np

from chronofuse.io.formats import open_data
from chronofuse.io.frames import scan_bytes
from chronofuse.io.sources import FileSource

__all__ = ["ReplaySource", "SharedStart", "frame_schedule"]

_WEEK_S = 604_800.0
_DAY_S = 86_400.0
_NMEA_TIMED = ("GGA", "RMC", "GLL", "GNS", "ZDA")


def _ubx_time_s(frame) -> float | None:
    raw = frame.raw
    if len(raw) < 14 or raw[2] not in (0x01, 0x02):
        return None
    if raw[2] == 0x01:  # NAV: iTOW (U4, ms) first in every payload
        return int.from_bytes(raw[6:10], "little") / 1000.0
    if raw[3] == 0x15 and len(raw) >= 22:  # RXM-RAWX: rcvTow (R8, s)
        return round(struct.unpack_from("<d", raw, 6)[0], 3)
    return None


def _nmea_time_s(frame) -> float | None:
    if frame.name[-3:] not in _NMEA_TIMED:
        return None
    fields = frame.raw.split(b",")
    if len(fields) < 2:
        return None
    index = 5 if frame.name.endswith("GLL") else 1
    if len(fields) <= index:
        return None
    text = fields[index].split(b"*")[0]
    if len(text) < 6 or not text[:6].isdigit():
        return None
    try:
        return int(text[0:2]) * 3600 + int(text[2:4]) * 60 + float(text[4:])
    except ValueError:
        return None


def frame_schedule(data: bytes) -> list[tuple[int, float]]:
    """``[(byte offset, seconds after the first epoch)]``: where each epoch's first frame starts and when
    it is due (module docstring); the bytes before the first timed frame are due at 0."""
    frames, _ = scan_bytes(data)
    ubx = [(f.offset, _ubx_time_s(f)) for f in frames if f.kind == "ubx"]
    ubx = [(o, t) for o, t in ubx if t is not None]
    timed, period = (ubx, _WEEK_S) if ubx else (
        [(f.offset, t) for f in frames if f.kind == "nmea" for t in [_nmea_time_s(f)] if t is not None], _DAY_S)
    if not timed:
        return [(0, 0.0)]
    offsets = np.array([o for o, _ in timed], dtype=np.int64)
    times = np.array([t for _, t in timed])
    steps = np.diff(times)
    steps = np.where(steps < -period / 2, steps + period, np.where(steps > period / 2, steps - period, steps))
    times = np.maximum.accumulate(np.concatenate([[0.0], np.cumsum(steps)]))
    schedule = [(0, 0.0)]
    for offset, due in zip(offsets.tolist(), times.tolist()):
        if due > schedule[-1][1]:
            schedule.append((offset, due))
    return schedule


class SharedStart:
    """One start instant for several replays: fixed by the first replay to start (plus ``lead_s``, the
    time the others' threads need to come up), so their epochs go out together."""

    def __init__(self, lead_s: float = 0.2) -> None:
        self.lead_s = lead_s
        self._at: float | None = None
        self._lock = threading.Lock()

    def at(self) -> float:
        with self._lock:
            if self._at is None:
                self._at = time.monotonic() + self.lead_s
            return self._at


_SCHEDULES: dict[tuple, list] = {}
_SCHEDULES_LOCK = threading.Lock()


def _cached_schedule(path: Path, data: bytes) -> list[tuple[int, float]]:
    """:func:`frame_schedule` of a file, computed once per file version (many replays of one recording)."""
    stat = path.stat()
    key = (str(path.resolve()), stat.st_size, stat.st_mtime_ns)
    with _SCHEDULES_LOCK:
        if key not in _SCHEDULES:
            _SCHEDULES[key] = frame_schedule(data)
        return _SCHEDULES[key]


class ReplaySource(FileSource):
    """A recording sent burst by burst at its own epochs' pace times ``speed`` (module docstring).
    ``start_at``: the monotonic instant of its first epoch, or a :class:`SharedStart` (replays given one
    start send their epochs together, as receivers locked to GPS time do); None: when its thread starts."""

    def __init__(self, path, name: str | None = None, speed: float = 1.0, start_at=None) -> None:
        super().__init__(path, name=name or Path(path).name)
        self.speed = float(speed)
        self.start_at = start_at

    def run(self, emit, stop: threading.Event) -> None:
        try:
            with open_data(self.path) as stream:
                data = stream.read()
        except OSError as err:
            emit("down", f"{type(err).__name__}: {err}")
            emit("end")
            return
        emit("up")
        schedule = _cached_schedule(self.path, data) + [(len(data), None)]
        if self.start_at is None:
            start = time.monotonic()
        else:
            start = self.start_at.at() if isinstance(self.start_at, SharedStart) else float(self.start_at)
        for (offset, due), (following, _) in zip(schedule[:-1], schedule[1:]):
            wait = start + due / self.speed - time.monotonic()
            if wait > 0 and stop.wait(wait):
                break
            if following > offset:  # stamped with its due instant: replays sharing a start arrive together
                emit("data", data[offset:following], start + due / self.speed)
        emit("end")

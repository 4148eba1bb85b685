"""u-blox UBX NAV-CLOCK reader: the receiver clock bias and drift, through pyubx2 (the field's parser).

UBX-NAV-CLOCK (u-blox interface description, message class 0x01 id 0x22) carries ``iTOW`` (ms, GPS time of
week), ``clkB`` (ns, clock bias), ``clkD`` (ns/s, clock drift), ``tAcc`` (ns) and ``fAcc`` (ps/s).

Corrupt input is skipped and counted, never fatal: a frame with a bad checksum, a frame cut short at the end
of the file, an unknown header or an undecodable NMEA line in a mixed stream becomes one entry of
:attr:`NavClockRecord.skipped` (the byte offset in the file where the reader stood after the bad frame, and
pyubx2's reason). A file that ends inside a frame header (where pyubx2 itself stops quietly) is counted too.
A capture compressed with gzip (told by its content) is read as it is, byte offsets then counting uncompressed bytes.
Limits, from pyubx2's byte scanning: bytes that start no frame (line noise between frames) are passed
over uncounted, and a corrupt length field can make one bad frame swallow the next: that counts as one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pyubx2 import ERR_LOG, UBX_PROTOCOL, UBXReader

from chronofuse.io.formats import open_data
from chronofuse.timescale import MS_PER_WEEK
from chronofuse.validation import InputDataError


_NS = 1e-9

# A UBX frame header: sync 0xB5 0x62, class, id, 2-byte length.
_UBX_SYNC = b"\xb5\x62"
_UBX_HEADER_BYTES = 6


def _cut_header_offset(tail: bytes, size: int) -> int | None:
    """Offset of a UBX header cut by the end of the file (``tail`` = the file's last <= 6 bytes), or None."""
    start = size - len(tail)
    for i in range(len(tail)):
        if tail[i : i + 2] == _UBX_SYNC[: len(tail[i : i + 2])]:
            return start + i
    return None


@dataclass(frozen=True)
class NavClockRecord:
    """Clock solution of a u-blox receiver, one row per NAV-CLOCK message, in file order.

    Attributes
    ----------
    itow_ms : ndarray of int64, shape (n,)
        GPS time of week of each solution (ms), as sent (wraps at the week rollover).
    t_s : ndarray of float64, shape (n,)
        Seconds since the first epoch, continuous over a week rollover of ``itow_ms``.
    clock_bias_s, clock_drift_s_per_s, time_acc_s : ndarray of float64, shape (n,)
        ``clkB`` (s), ``clkD`` (s/s) and the time accuracy estimate ``tAcc`` (s).
    n_skipped_frames : int
        Corrupt frames skipped by the reader.
    fix_ok : ndarray of bool, shape (n,)
        The receiver's own fix status at each solution, from the NAV-SOL, NAV-PVT or NAV-STATUS message of the
        same iTOW: ``gpsFixOk`` set and a fix type of 2D or better (u-blox interface description: ``gpsFix``
        2, 3, 4 = 2D, 3D, GNSS + dead reckoning; 5 = time only, also accepted). True where the capture
        has no status message for that iTOW (nothing says it is bad).
    skipped : list of (int, str)
        ``(byte_offset, reason)`` of every skipped frame.
    source : str
        The file read.
    """

    itow_ms: np.ndarray
    t_s: np.ndarray
    clock_bias_s: np.ndarray
    clock_drift_s_per_s: np.ndarray
    time_acc_s: np.ndarray
    n_skipped_frames: int
    skipped: list[tuple[int, str]] = field(default_factory=list)
    source: str = ""
    fix_ok: np.ndarray | None = None


def unwrap_itow_ms(itow_ms: np.ndarray) -> np.ndarray:
    """Milliseconds since the first epoch from GPS time-of-week values, adding a week at each rollover.

    A backwards step of more than half a week is a rollover (iTOW restarts at 0 on Sunday 00:00 GPS time);
    a smaller backwards step is kept as it is (a receiver restart), so it shows in the data. Shape (n,).
    """
    itow = np.asarray(itow_ms, dtype=np.int64)
    if itow.size == 0:
        return itow.copy()
    step = np.diff(itow)
    weeks = np.concatenate(([0], np.cumsum(step < -MS_PER_WEEK // 2)))
    return itow - itow[0] + weeks * MS_PER_WEEK


def open_capture(path: Path):
    """The capture's bytes as a binary stream: gzip-decompressed when its content is gzip."""
    return open_data(path)


def read_nav_clock(path) -> NavClockRecord:
    """Read every UBX-NAV-CLOCK message of a UBX (or mixed UBX/NMEA/RTCM) capture, plain or gzipped.

    Raises :class:`InputDataError` naming the file when it is empty, not valid gzip, or holds no NAV-CLOCK
    message.
    """
    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise InputDataError("no such file", source)
    if path.stat().st_size == 0:
        raise InputDataError("the file is empty", source)
    try:
        return _read_nav_clock(path, source)
    except (OSError, EOFError) as exc:  # gzip.BadGzipFile is an OSError
        raise InputDataError(f"cannot read file: {exc}", source) from exc


def _read_nav_clock(path: Path, source: str) -> NavClockRecord:
    itow, bias, drift, tacc = [], [], [], []
    status: dict[int, bool] = {}
    skipped: list[tuple[int, str]] = []
    consumed = 0
    with open_capture(path) as stream:

        def on_error(err: Exception) -> None:
            skipped.append((stream.tell(), f"{type(err).__name__}: {err}"))

        reader = UBXReader(stream, protfilter=UBX_PROTOCOL, quitonerror=ERR_LOG, errorhandler=on_error)
        while True:
            try:
                _, msg = reader.read()
            except (UnicodeDecodeError, ValueError, TypeError, IndexError) as err:
                # pyubx2 lets a few errors of mixed streams escape (e.g. binary bytes after '$G' decoded as
                # NMEA text); the stream has moved past them, so skip, count and go on.
                on_error(err)
                continue
            if msg is None:
                break
            consumed = stream.tell()
            identity = getattr(msg, "identity", None)
            if identity in ("NAV-SOL", "NAV-PVT", "NAV-STATUS"):
                fix_type = int(getattr(msg, "gpsFix", getattr(msg, "fixType", 0)))
                fix_flag = next((getattr(msg, n) for n in ("gpsfixOK", "gpsFixOk", "gnssFixOk") if hasattr(msg, n)), 0)
                status[int(msg.iTOW)] = bool(fix_flag) and fix_type in (2, 3, 4, 5)
                continue
            if identity != "NAV-CLOCK":
                continue
            itow.append(int(msg.iTOW))
            bias.append(float(msg.clkB) * _NS)
            drift.append(float(msg.clkD) * _NS)
            tacc.append(float(msg.tAcc) * _NS)
        size = stream.tell()
        stream.seek(max(size - _UBX_HEADER_BYTES, 0))
        tail = stream.read()
    if size == 0:
        raise InputDataError("the file is empty", source)
    if skipped:
        consumed = max(consumed, skipped[-1][0])
    cut = _cut_header_offset(tail, size)
    if cut is not None and cut >= consumed:
        # pyubx2 ends quietly when the file ends inside a frame header (e.g. a lone 0xB5): count it too
        skipped.append((cut, f"truncated frame: the file ends {size - cut} byte(s) into a UBX header"))
    if not itow:
        raise InputDataError(
            f"no UBX NAV-CLOCK message ({len(skipped)} corrupt frame(s) skipped)", source
        )
    itow_ms = np.asarray(itow, dtype=np.int64)
    return NavClockRecord(
        itow_ms=itow_ms,
        t_s=unwrap_itow_ms(itow_ms).astype(np.float64) / 1000.0,
        clock_bias_s=np.asarray(bias),
        clock_drift_s_per_s=np.asarray(drift),
        time_acc_s=np.asarray(tacc),
        n_skipped_frames=len(skipped),
        skipped=skipped,
        source=source,
        fix_ok=np.array([status.get(int(k), True) for k in itow_ms], dtype=bool),
    )

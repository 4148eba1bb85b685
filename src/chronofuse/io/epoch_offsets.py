"""Where each receiver epoch starts in its byte stream: the provenance of a UBX epoch.

Every UBX navigation message (class NAV, 0x01) opens with ``iTOW`` (U4, GPS time of week in ms; u-blox
interface description, "UBX-NAV"), the epoch it belongs to. :class:`EpochOffsets` keeps, for each ``iTOW``,
the stream offset of the first navigation frame carrying it, read from the checksummed frames the framer
gives (bytes 6-9 of the frame), so an epoch's provenance is the byte where its messages begin. NMEA
sentences carry only a time of day (no frame-level key to an epoch): their epochs get -1 (unknown), as do
epochs of a recording longer than a week whose ``iTOW`` repeats (the first week's offset is kept).
"""

from __future__ import annotations

import numpy as np

from chronofuse.timescale import NS_PER_WEEK

__all__ = ["EpochOffsets"]

_NAV_CLASS = 0x01


class EpochOffsets:
    """The stream offset of each ``iTOW``'s first UBX navigation frame (module docstring)."""

    def __init__(self) -> None:
        self._first: dict[int, int] = {}

    def feed(self, frames) -> None:
        """Note the navigation frames among ``frames`` (:class:`chronofuse.io.frames.Frame`)."""
        first = self._first
        for frame in frames:
            raw = frame.raw
            if frame.kind == "ubx" and len(raw) >= 12 and raw[2] == _NAV_CLASS:
                first.setdefault(int.from_bytes(raw[6:10], "little"), frame.offset)

    def of(self, gps_ns) -> np.ndarray:
        """Offsets (int64, -1 unknown) of the epochs at ``gps_ns`` (int64 array)."""
        tow_ms = (np.asarray(gps_ns, dtype=np.int64) % NS_PER_WEEK) // 1_000_000
        first = self._first
        return np.array([first.get(int(t), -1) for t in tow_ms], dtype=np.int64)

    def forget_before(self, gps_ns: int) -> None:
        """Drop the offsets of epochs before ``gps_ns`` (a live stream releases epochs in time order)."""
        tow_ms = (int(gps_ns) % NS_PER_WEEK) // 1_000_000
        if len(self._first) > 4096:
            self._first = {t: o for t, o in self._first.items() if t >= tow_ms - 60_000}

"""Live decoding of one receiver's byte stream into epochs as they close (the streaming twin of
:func:`chronofuse.io.inspect.read_bytes`).

:meth:`StreamDecoder.feed` takes bytes in any split and returns the epochs that closed (an epoch closes
when the receiver starts the next one), each as a dict of ``gps_ns`` and the per-epoch fields of
:class:`chronofuse.epochs.ReceiverEpochs`. A stream that carries UBX navigation messages is decoded from
them (its NMEA then only counted), otherwise from NMEA: the batch reader merges both, the live path
takes the richer protocol to keep one epoch clock.
"""

from __future__ import annotations

import json
import math

import numpy as np

from chronofuse.io.frames import FrameScanner
from chronofuse.io.inspect import EPOCH_FIELDS
from chronofuse.io.nmea import NmeaDecodeStats, NmeaEpochBuilder, decode_nmea
from chronofuse.io.ubx_epochs import UBX_TYPES, UbxDecodeStats, UbxEpochBuilder, decode_ubx
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns, gps_minus_utc_s, utc_to_gps_ns

__all__ = ["StreamDecoder", "GpsdJsonDecoder", "decoder_for", "split_rows"]


def split_rows(rows: dict | None) -> list[dict]:
    """Column arrays -> one dict of Python scalars per epoch (``gps_ns`` and :data:`EPOCH_FIELDS`)."""
    if rows is None or rows["gps_ns"].size == 0:
        return []
    cols = {k: rows[k].tolist() for k in ("gps_ns",) + EPOCH_FIELDS}
    return [{k: cols[k][i] for k in cols} for i in range(len(cols["gps_ns"]))]


class StreamDecoder:
    """One receiver's live decoder (framer + pynmeagps/pyubx2 + epoch assembly), kept across reconnects."""

    def __init__(self, reference_gps_ns: int | None = None) -> None:
        self.scanner = FrameScanner()
        self.nmea_stats, self.ubx_stats = NmeaDecodeStats(), UbxDecodeStats()
        self._nmea = NmeaEpochBuilder(reference_gps_ns)
        self._ubx = UbxEpochBuilder()
        self.protocol: str | None = None  # "ubx" once UBX navigation is seen, else "nmea" once NMEA is
        self._last_gps_ns = np.iinfo(np.int64).min

    def feed(self, data: bytes) -> list[dict]:
        """Decode ``data``; return the epochs that closed, in time order (an epoch that repeats or runs
        behind the last one returned is dropped, as the batch reader drops duplicates)."""
        return self._decode(self.scanner.feed(data), final=False)

    def close(self) -> list[dict]:
        """End of stream: flush the epoch in progress."""
        return self._decode(self.scanner.close(), final=True)

    def _decode(self, frames, final: bool) -> list[dict]:
        if self.protocol != "ubx" and any(f.kind == "ubx" and f.name in UBX_TYPES for f in frames):
            self.protocol = "ubx"
        if self.protocol is None and any(f.kind == "nmea" for f in frames):
            self.protocol = "nmea"
        decode_ubx(frames, self._ubx, self.ubx_stats)
        decode_nmea(frames, self._nmea, self.nmea_stats)
        if self.protocol == "ubx":
            rows = self._ubx.pop_complete(self.ubx_stats)
            out = split_rows(rows)
            if final:
                out += split_rows(self._ubx.pop_all(self.ubx_stats))
        elif self.protocol == "nmea":
            out = split_rows(self._nmea.pop_complete())
            if final:
                out += split_rows(self._nmea.pop_all())
        else:
            return []
        kept = []
        for epoch in out:
            if epoch["gps_ns"] > self._last_gps_ns:
                kept.append(epoch)
                self._last_gps_ns = epoch["gps_ns"]
        return kept


class GpsdJsonDecoder:
    """A gpsd server's JSON reports (gpsd_json(5)) to epochs: a TPV with a ``time`` opens an epoch
    (UTC label, ``mode``, ``leapseconds`` when gpsd knows it, else the leap-second table), a SKY adds its
    DOPs and ``uSat``; an epoch closes when the next TPV time arrives."""

    def __init__(self) -> None:
        self._buffer = b""
        self._current: dict | None = None
        self._last_gps_ns = np.iinfo(np.int64).min
        self.bad_lines = 0
        self.protocol = "gpsd"

    def feed(self, data: bytes) -> list[dict]:
        self._buffer += data
        *lines, self._buffer = self._buffer.split(b"\n")
        out: list[dict] = []
        for line in lines:
            self._line(line.strip(), out)
        return out

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
        elif cls == "SKY" and self._current is not None:
            for name in ("gdop", "pdop", "hdop", "vdop", "tdop"):
                if name in doc:
                    self._current[name] = float(doc[name])
            if "uSat" in doc:
                self._current["n_sats"] = int(doc["uSat"])

    def _emit(self, out: list) -> None:
        if self._current is not None and self._current["gps_ns"] > self._last_gps_ns:
            out.append(self._current)
            self._last_gps_ns = self._current["gps_ns"]
        self._current = None


def _absent_epoch(gps_ns: int, leap_s: int) -> dict:
    return {"gps_ns": gps_ns, "fix_mode": 0, "time_valid": False, "n_sats": -1, "gdop": math.nan,
            "pdop": math.nan, "hdop": math.nan, "vdop": math.nan, "tdop": math.nan, "leap_s": leap_s,
            "leap_pending": 0, "qerr_s": math.nan, "clock_bias_s": math.nan, "clock_drift_s_per_s": math.nan}


def decoder_for(source) -> StreamDecoder | GpsdJsonDecoder:
    """The decoder a source's bytes need: gpsd JSON or raw NMEA/UBX."""
    return GpsdJsonDecoder() if getattr(source, "kind", "raw") == "gpsd" else StreamDecoder()

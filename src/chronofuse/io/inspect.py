"""Read a receiver recording (NMEA, UBX, or both mixed with RTCM and noise) into per-epoch reports, and
say what it holds: message counts, time span, gaps, checksum failures, unknown talkers.

One pass: :class:`chronofuse.io.frames.FrameScanner` frames the bytes (checksums verified for whole
chunks at once), pynmeagps and pyubx2 decode the frames we use, :mod:`chronofuse.io.nmea` and
:mod:`chronofuse.io.ubx_epochs` assemble epochs. A stream carrying both protocols is one receiver: its
UBX epochs are taken first and NMEA fills the fields UBX did not send (and epochs UBX did not report):
:func:`merge_epochs`, which the live decoder (:mod:`chronofuse.io.sources_decode`) uses too.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from chronofuse.epochs import EXPORT_COLUMNS, ReceiverEpochs
from chronofuse.io.arrival import sorted_on_arrival
from chronofuse.io.epoch_offsets import EpochOffsets
from chronofuse.io.formats import open_data
from chronofuse.io.frames import FrameScanner, FrameStats
from chronofuse.record import RECEIVER_UNITS, EpochRecord
from chronofuse.io.rinex_epochs import read_rinex_clock_epochs, read_rinex_observation_epochs, rinex_kind
from chronofuse.io.nmea import NmeaDecodeStats, NmeaEpochBuilder, decode_nmea
from chronofuse.io.ubx_epochs import UbxDecodeStats, UbxEpochBuilder, decode_ubx
from chronofuse.timescale import NS_PER_S, gps_ns_to_datetime64
from chronofuse.validation import InputDataError

__all__ = ["Capture", "read_capture", "read_bytes", "summarize", "merge_epochs", "strictly_increasing", "EPOCH_FIELDS"]

#: Per-epoch fields (besides ``gps_ns``), as :class:`chronofuse.epochs.ReceiverEpochs` names them.
EPOCH_FIELDS = ("fix_mode", "time_valid", "n_sats", "gdop", "pdop", "hdop", "vdop", "tdop", "leap_s",
                "leap_pending", "qerr_s", "clock_bias_s", "clock_drift_s_per_s")
_CHUNK = 1 << 22


@dataclass(frozen=True)
class Capture:
    """What one recording holds. ``rows``: ``gps_ns`` (int64, strictly increasing) and
    :data:`EPOCH_FIELDS`, one entry per epoch. ``frames``: the framer's counts; ``nmea``/``ubx``: the
    decoders' counts; ``time_marks_gps_ns``: TIM-TM2 rising edges; ``duplicate_epochs``: epochs dropped
    because their time repeats an earlier one; ``reordered_epochs`` and ``late_epochs``: epochs that came
    after a later one, put back in order or left out (:mod:`chronofuse.io.arrival`); ``time_acc_s``: the receiver's time accuracy estimate per
    epoch of ``rows`` (UBX NAV-CLOCK ``tAcc``, s; NaN where not reported), None for RINEX; ``offsets``: the
    byte offset where each epoch's UBX messages begin (:class:`chronofuse.io.epoch_offsets.EpochOffsets`; -1
    unknown), None for RINEX."""

    source: str
    rows: dict
    frames: FrameStats
    nmea: NmeaDecodeStats
    ubx: UbxDecodeStats
    time_marks_gps_ns: np.ndarray
    duplicate_epochs: int = 0
    reordered_epochs: int = 0
    late_epochs: int = 0
    protocols: tuple = field(default=())
    receivers: tuple = field(default=())  # names, for files holding several (RINEX clock: stations)
    time_acc_s: np.ndarray | None = None
    offsets: np.ndarray | None = None

    @property
    def n_epochs(self) -> int:
        return int(self.rows["gps_ns"].size)

    def utc_ns(self) -> np.ndarray:
        """The receiver's UTC label of each epoch (``gps_ns - leap_s``), int64 ns on the UTC count."""
        return self.rows["gps_ns"] - self.rows["leap_s"].astype(np.int64) * NS_PER_S

    @property
    def epochs(self) -> ReceiverEpochs | None:
        """The epochs as the one per-epoch record, shape ``(1, 1, epochs)``; None when there are none."""
        if self.n_epochs == 0:
            return None
        return ReceiverEpochs(gps_ns=self.rows["gps_ns"],
                              **{name: self.rows[name][None, None, :] for name in EPOCH_FIELDS})

    @property
    def n_damaged(self) -> int:
        """Frames lost to damage: UBX checksum failures, truncated frames, frames pyubx2 refused."""
        return int(self.frames.ubx_bad_checksum + self.frames.truncated + self.ubx.parse_errors)

    def record(self) -> EpochRecord:
        """The capture as the one epoch record (:class:`chronofuse.record.EpochRecord`, one stream): every
        per-epoch field as a column on GPS time, ``time_acc_s`` where the capture has it, ``valid`` where the
        receiver did not report "no fix", provenance the byte offset of each epoch's UBX messages (RINEX:
        the epoch's index), ``info`` the damaged-frame count (``n_damaged``) and the epochs that came out of
        time order (``n_reordered``, ``n_late``)."""
        rows = self.rows
        columns = {name: rows[name] for name in EPOCH_FIELDS}
        if self.time_acc_s is not None:
            columns["time_acc_s"] = self.time_acc_s
        unit = "index" if self.offsets is None else "byte"
        return EpochRecord.from_arrays(rows["gps_ns"], columns, {n: RECEIVER_UNITS[n] for n in columns},
                                       source=self.source, valid=rows["fix_mode"] != 1, position=self.offsets,
                                       position_unit=unit, info={"n_damaged": self.n_damaged,
                                                                 "n_reordered": self.reordered_epochs,
                                                                 "n_late": self.late_epochs})

    def to_frame(self) -> pd.DataFrame:
        """One row per epoch, columns :data:`chronofuse.epochs.EXPORT_COLUMNS` (see
        :meth:`ReceiverEpochs.to_frame`); an empty table with those columns when there are no epochs."""
        epochs = self.epochs
        if epochs is None:
            return pd.DataFrame({name: [] for name in EXPORT_COLUMNS})
        return epochs.to_frame()

    def gaps(self, factor: float = 1.5) -> list[tuple[int, int]]:
        """``(gps_ns_before, gps_ns_after)`` of every interval longer than ``factor`` x the median one."""
        t = self.rows["gps_ns"]
        if t.size < 3:
            return []
        step = np.diff(t)
        median = np.median(step)
        idx = np.flatnonzero(step > factor * median)
        return [(int(t[i]), int(t[i + 1])) for i in idx]


def read_bytes(chunks, source: str = "<bytes>", reference_gps_ns: int | None = None) -> Capture:
    """Read an iterable of byte chunks (any split) into a :class:`Capture`."""
    scanner = FrameScanner()
    nmea_b, nmea_s = NmeaEpochBuilder(reference_gps_ns), NmeaDecodeStats()
    ubx_b, ubx_s = UbxEpochBuilder(), UbxDecodeStats()
    offsets = EpochOffsets()
    for chunk in chunks:
        frames = scanner.feed(chunk)
        offsets.feed(frames)
        decode_nmea(frames, nmea_b, nmea_s)
        decode_ubx(frames, ubx_b, ubx_s)
    frames = scanner.close()
    offsets.feed(frames)
    decode_nmea(frames, nmea_b, nmea_s)
    decode_ubx(frames, ubx_b, ubx_s)
    # each protocol's epochs in file order through the live decoder's reorder buffer (io/arrival.py)
    ubx_rows, ubx_order = sorted_on_arrival(ubx_b.rows(ubx_s))
    nmea_rows, nmea_order = sorted_on_arrival(nmea_b.rows())
    rows = merge_epochs(ubx_rows, nmea_rows)
    rows, dup = strictly_increasing(rows)
    dup += ubx_order.n_repeated + nmea_order.n_repeated
    time_acc_s = np.full(rows["gps_ns"].size, np.nan)  # every UBX epoch's time is among the merged rows'
    time_acc_s[np.searchsorted(rows["gps_ns"], ubx_rows["gps_ns"])] = ubx_rows["time_acc_s"]
    protocols = tuple(p for p, n in (("nmea", sum(nmea_s.decoded.values())), ("ubx", sum(ubx_s.decoded.values())))
                      if n)
    return Capture(source=source, rows=rows, frames=scanner.stats, nmea=nmea_s, ubx=ubx_s,
                   time_marks_gps_ns=np.asarray(ubx_b.marks_gps_ns, dtype=np.int64), duplicate_epochs=dup,
                   reordered_epochs=ubx_order.n_reordered + nmea_order.n_reordered,
                   late_epochs=ubx_order.n_late + nmea_order.n_late,
                   protocols=protocols, time_acc_s=time_acc_s,
                   offsets=offsets.of(rows["gps_ns"]) if "ubx" in protocols else np.full(rows["gps_ns"].size, -1))


def read_capture(path, reference_gps_ns: int | None = None, receiver: str | None = None) -> Capture:
    """Read a recording file (plain, or gzip told by its content): NMEA/UBX, or a RINEX
    observation or clock file (:mod:`chronofuse.io.rinex_epochs`; ``receiver`` picks a clock file's
    station, the first by default).

    ``reference_gps_ns``: a trusted epoch near the recording (for receivers with the GPS week-rollover
    bug, see :mod:`chronofuse.io.nmea`). Raises :class:`InputDataError` naming the file when it is
    missing or empty, or a RINEX navigation file (no receiver epochs); corrupt content is counted in
    the result, never raised.
    """
    path = Path(path)
    if not path.is_file():
        raise InputDataError("no such file", str(path))
    if path.stat().st_size == 0:
        raise InputDataError("the file is empty", str(path))
    kind = rinex_kind(path)
    if kind is not None:
        return _read_rinex(path, kind, receiver)
    try:
        with open_data(path) as stream:
            return read_bytes(iter(lambda: stream.read(_CHUNK), b""), str(path), reference_gps_ns)
    except (OSError, EOFError) as exc:  # gzip.BadGzipFile is an OSError; a gzip stream cut short: EOFError
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc


def _read_rinex(path: Path, kind: tuple[str, str], receiver: str | None) -> Capture:
    version, what = kind
    names: tuple = ()
    if what == "obs":
        epochs, j = read_rinex_observation_epochs(path), 0
    elif what == "clock":
        names, epochs, _ = read_rinex_clock_epochs(path)
        if receiver is not None and receiver not in names:
            raise InputDataError(f"no station {receiver!r} (the file has {len(names)}: {', '.join(names[:8])}...)",
                                 str(path))
        j = names.index(receiver) if receiver is not None else 0
    else:
        raise InputDataError(f"a RINEX {version} {what} file holds no receiver epochs", str(path))
    rows = {"gps_ns": np.asarray(epochs.gps_ns)}
    rows.update({name: np.asarray(getattr(epochs, name))[0, j].copy() for name in EPOCH_FIELDS})
    stats = FrameStats(n_bytes=path.stat().st_size)
    stats.messages[f"RINEX {version} {what}"] = int(rows["gps_ns"].size)
    return Capture(source=str(path), rows=rows, frames=stats, nmea=NmeaDecodeStats(), ubx=UbxDecodeStats(),
                   time_marks_gps_ns=np.zeros(0, np.int64), protocols=(f"rinex-{what}",), receivers=names)


def _absent(name: str, v: np.ndarray) -> np.ndarray:
    if v.dtype.kind == "f":
        return np.isnan(v)
    if name == "fix_mode":
        return v == 0
    if name == "n_sats":
        return v < 0
    if name == "time_valid":
        return ~v
    return np.zeros(v.shape, dtype=bool)


def merge_epochs(ubx: dict, nmea: dict) -> dict:
    """UBX epochs first; NMEA epochs at the same GPS ns fill UBX's absent fields; other NMEA epochs join.
    (A leap count the UBX receiver sent wins over NMEA's table value.)"""
    if ubx["gps_ns"].size == 0:
        return {k: nmea[k] for k in ("gps_ns",) + EPOCH_FIELDS}
    if nmea["gps_ns"].size == 0:
        return {k: ubx[k] for k in ("gps_ns",) + EPOCH_FIELDS}
    t = np.union1d(ubx["gps_ns"], nmea["gps_ns"])
    iu = np.searchsorted(t, ubx["gps_ns"])
    inm = np.searchsorted(t, nmea["gps_ns"])
    out = {"gps_ns": t}
    for name in EPOCH_FIELDS:
        from_nmea = np.zeros(t.size, dtype=ubx[name].dtype)
        from_nmea[inm] = nmea[name]
        col = from_nmea.copy()
        col[iu] = ubx[name]
        ubx_has = np.zeros(t.size, dtype=bool)
        ubx_has[iu] = True if name == "leap_s" else ~_absent(name, ubx[name])
        nmea_has = np.zeros(t.size, dtype=bool)
        nmea_has[inm] = True
        out[name] = np.where(nmea_has & ~ubx_has, from_nmea, col)
    return out


def strictly_increasing(rows: dict) -> tuple[dict, int]:
    """The rows in time order with a repeated ``gps_ns`` kept once (its first row), and how many were dropped."""
    t = rows["gps_ns"]
    order = np.argsort(t, kind="stable")
    t_sorted = t[order]
    keep = np.ones(t.size, dtype=bool)
    keep[1:] = np.diff(t_sorted) > 0
    idx = order[keep]
    return {k: v[idx] for k, v in rows.items()}, int((~keep).sum())


def _iso(utc_ns: int) -> str:
    return str(np.datetime_as_string(gps_ns_to_datetime64(np.int64(utc_ns)), unit="ms")) + "Z"


def summarize(capture: Capture, max_gaps: int = 20) -> dict:
    """What the recording holds, as a JSON-ready document: protocols, message counts per type, epochs,
    time span (the receiver's UTC labels), the interval, gaps (up to ``max_gaps`` listed), damage
    (checksum failures, truncated frames, unframed bytes, parser refusals) and unknown talkers."""
    f = capture.frames
    utc = capture.utc_ns()
    gaps = capture.gaps()
    step_s = float(np.median(np.diff(capture.rows["gps_ns"]))) / NS_PER_S if capture.n_epochs > 1 else None
    rows = capture.rows
    return {
        "file": capture.source,
        "receivers": len(capture.receivers) or (1 if capture.protocols else 0),
        "receiver_names": list(capture.receivers[:50]),
        "protocols": list(capture.protocols),
        "bytes": f.n_bytes,
        "messages": dict(sorted(f.messages.items())),
        "epochs": capture.n_epochs,
        "start_utc": _iso(utc[0]) if capture.n_epochs else None,
        "end_utc": _iso(utc[-1]) if capture.n_epochs else None,
        "span_s": float(utc[-1] - utc[0]) / NS_PER_S if capture.n_epochs else 0.0,
        "interval_s": step_s,
        "gaps": {"count": len(gaps),
                 "listed": [{"after_utc": _iso(a - int(rows["leap_s"][0]) * NS_PER_S),
                             "length_s": (b - a) / NS_PER_S} for a, b in gaps[:max_gaps]]},
        "fix_modes": {str(m): int((rows["fix_mode"] == m).sum()) for m in (0, 1, 2, 3)},
        "leap_s": sorted({int(v) for v in rows["leap_s"]}),
        "leap_pending_epochs": int((rows["leap_pending"] != 0).sum()),
        "time_marks": int(capture.time_marks_gps_ns.size),
        "damage": {
            "nmea_bad_checksum": f.nmea_bad_checksum,
            "nmea_no_checksum": f.nmea_no_checksum,
            "nmea_malformed": f.nmea_malformed,
            "ubx_bad_checksum": f.ubx_bad_checksum,
            "rtcm3_bad_crc": f.rtcm3_bad_crc,
            "truncated_frames": f.truncated,
            "unframed_bytes": f.unframed_bytes,
            "comment_lines": f.comment_lines,
            "parser_refused": capture.nmea.parse_errors + capture.ubx.parse_errors,
            "undated_epochs": capture.ubx.undated_epochs,
            "pulses_without_epoch": capture.ubx.pulses_without_epoch,
            "duplicate_epochs": capture.duplicate_epochs,
            "reordered_epochs": capture.reordered_epochs,
            "late_epochs": capture.late_epochs,
        },
        "unknown_talkers": dict(sorted(f.unknown_talkers.items())),
        "problems": [{"offset": o, "reason": r} for o, r in f.problems[:max_gaps]],
    }

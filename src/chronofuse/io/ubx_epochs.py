"""u-blox UBX messages to per-epoch receiver reports, decoded by pyubx2 (the field's parser).

Messages used (u-blox 8 / M8 and F9 interface descriptions; field names as pyubx2 gives them):

* NAV-PVT: ``fixType``, ``numSV``, ``pDOP``, UTC date and time with ``validDate``/``validTime``/
  ``fullyResolved``; NAV-SOL and NAV-STATUS (older receivers): ``gpsFix``, ``week``, ``numSV``.
* NAV-TIMEGPS: ``week`` and ``leapS`` (with their valid bits); NAV-TIMEUTC: UTC date and ``validUTC``.
* NAV-TIMELS: ``currLs`` (GPS - UTC, s) and ``lsChange``/``timeToLsEvent`` (the announced leap second).
* NAV-DOP: ``gDOP`` ... ``hDOP`` (pyubx2 applies the 0.01 scale); NAV-SAT: satellites with ``svUsed``
  (read by the frame layout, :func:`nav_sat_used`).
* NAV-CLOCK: ``clkB`` (ns) and ``clkD`` (ns/s): the receiver clock bias and drift.
* TIM-TP: ``qErr`` (ps) of the NEXT time pulse, whose time is ``towMS``/``week`` in ``timeBase`` (0 GNSS,
  1 UTC): it is paired with the epoch of that pulse, not with the epoch it arrives in.
* TIM-TM2: time marks on the EXTINT input (rising-edge times kept as GPS ns).
* RXM-RAWX: ``rcvTow``, ``week`` and ``leapS`` (valid when ``recStat.leapSec``).
* NAV-EOE (protocol 18 and later): the end of the navigation epoch ``iTOW``. A live stream closes that
  epoch at once instead of waiting for the next epoch's first message (one epoch interval later).

Every navigation message carries ``iTOW`` (GPS time of week, ms) of its epoch; messages with the same
``iTOW`` are one epoch. The full epoch is ``week * 604800 s + iTOW``; the week comes from a message that
sends it (NAV-SOL, NAV-TIMEGPS, RXM-RAWX, TIM-TP) or, failing those, from a valid UTC date (NAV-PVT,
NAV-TIMEUTC) placed on the GPS scale; epochs between dated ones get the week of their neighbours
(iTOW rollover included). GPS - UTC is taken from the receiver: NAV-TIMELS ``currLs``, NAV-TIMEGPS or
RXM-RAWX ``leapS`` when flagged valid, or the difference of NAV-PVT's UTC and GPS time once fully
resolved; the leap-second table only where the receiver never says. pyubx2's own UTC helper (a fixed
18 s offset) is never used.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from datetime import date

import numpy as np
from pyubx2 import UBXReader
from pyubx2.ubxhelpers import calc_checksum

from chronofuse.io.ubx_layouts import decode_fixed
from chronofuse.io.ubx_pulses import attach_pulses, pulse_gps_ns
from chronofuse.timescale import (
    MS_PER_WEEK,
    NS_PER_S,
    NS_PER_WEEK,
    datetime64_to_gps_ns,
    gps_minus_utc_s,
)
from chronofuse.validation import InputError

__all__ = ["UBX_TYPES", "UbxDecodeStats", "UbxEpochBuilder", "decode_ubx", "GPSD_FIX_MODE"]

UBX_TYPES = frozenset({"NAV-PVT", "NAV-SOL", "NAV-STATUS", "NAV-TIMEGPS", "NAV-TIMEUTC", "NAV-TIMELS",
                       "NAV-DOP", "NAV-SAT", "NAV-CLOCK", "TIM-TP", "TIM-TM2", "RXM-RAWX", "NAV-EOE"})

#: u-blox ``fixType``/``gpsFix`` -> gpsd TPV mode: 0 no fix, 1 dead reckoning only, 2 2-D, 3 3-D,
#: 4 GNSS + dead reckoning, 5 time only (a surveyed timing receiver: 3, as gpsd reports it).
GPSD_FIX_MODE = {0: 1, 1: 2, 2: 2, 3: 3, 4: 3, 5: 3}
_RAW_TOL_MS = 25
_NEAR_EPOCHS = 16  # how far back a late message may still find its epoch


#: The latest time a frame may carry (int64 nanoseconds on the GPS scale end in 2262): a later week or
#: date is a corrupt frame, dropped.
MAX_YEAR = 2200
MAX_WEEK = (date(MAX_YEAR, 1, 1) - date(1980, 1, 6)).days // 7


@dataclass
class UbxDecodeStats:
    """Messages decoded per type, frames pyubx2 refused (first reasons kept), epochs that could not be
    dated (no week and no valid UTC date anywhere in the stream), and TIM-TP pulses whose epoch never
    came (not made epochs: see :func:`chronofuse.io.ubx_pulses.attach_pulses`)."""

    decoded: Counter = field(default_factory=Counter)
    parse_errors: int = 0
    undated_epochs: int = 0
    pulses_without_epoch: int = 0
    errors: list = field(default_factory=list)


class _Epoch:
    __slots__ = ("itow_ms", "week", "utc_ns", "mode", "time_valid", "n_sats", "n_used_sat", "gdop", "pdop",
                 "hdop", "vdop", "tdop", "leap_s", "leap_pending", "clock_bias_s", "clock_drift_s_per_s",
                 "time_acc_s", "leap_from_utc", "raw_only", "ended")

    def __init__(self, itow_ms: int) -> None:
        self.itow_ms = itow_ms
        self.raw_only = False
        self.ended = False  # NAV-EOE seen: nothing more will come for this epoch
        self.week = -1
        self.utc_ns: int | None = None  # a valid UTC label (UTC count since the GPS epoch)
        self.leap_from_utc = False
        self.mode = 0
        self.time_valid = False
        self.n_sats = -1
        self.n_used_sat = -1
        self.gdop = self.pdop = self.hdop = self.vdop = self.tdop = math.nan
        self.leap_s: int | None = None
        self.leap_pending = 0
        self.clock_bias_s = self.clock_drift_s_per_s = self.time_acc_s = math.nan


#: NAV-DOP's "no value": 9999 in units of 0.01 (a timing receiver in fixed-position mode sends it for
#: pDOP/hDOP/vDOP, having no position solution to dilute). gpsd treats it as missing; so do we.
_DOP_INVALID = 99.99


def _dop(value) -> float:
    """A NAV-DOP value (pyubx2 has applied the 0.01 scale), NaN for u-blox's invalid 99.99."""
    value = float(value)
    return math.nan if value >= _DOP_INVALID - 1e-6 else value


def _utc_label_ns(year, month, day, hour, minute, second, nano) -> int | None:
    try:
        stamp = np.datetime64(f"{int(year):04d}-{int(month):02d}-{int(day):02d}T{int(hour):02d}:"
                              f"{int(minute):02d}:00", "ns")
    except ValueError:
        return None
    return int(datetime64_to_gps_ns(stamp)) + int(second) * NS_PER_S + int(nano)


class UbxEpochBuilder:
    """Streaming assembly of UBX epochs: :meth:`push` decoded messages, :meth:`rows` gives arrays."""

    def __init__(self) -> None:
        self._epochs: list[_Epoch] = []
        self._pulses: list[tuple[int, int, int, float]] = []  # (week, tow_ms, time base, qerr_s)
        self._anchor: tuple[int, int] | None = None  # (iTOW ms, full week) of the last epoch popped
        self._last_leap: int | None = None
        self.marks_gps_ns: list[int] = []

    def _epoch(self, itow_ms: int, raw: bool = False) -> _Epoch:
        """The epoch of ``itow_ms`` among the recent ones, or a new one. RXM-RAWX's ``rcvTow`` is the
        receiver's own measurement time, up to a clock bias (<= 1 ms when steered, tens of ms free-running)
        off the navigation epoch's rounded iTOW: a RAWX and a navigation epoch within 25 ms are one."""
        for ep in reversed(self._epochs[-_NEAR_EPOCHS:]):
            if ep.itow_ms == itow_ms:
                return ep
            if (raw or ep.raw_only) and abs(ep.itow_ms - itow_ms) <= _RAW_TOL_MS:
                if ep.raw_only and not raw:
                    ep.itow_ms, ep.raw_only = itow_ms, False
                return ep
        ep = _Epoch(itow_ms)
        ep.raw_only = raw
        self._epochs.append(ep)
        return ep

    def push_nav_sat(self, raw: bytes) -> None:
        """A NAV-SAT frame (checksum verified): its used-satellite count (:func:`nav_sat_used`) joins the
        epoch of its iTOW (payload bytes 0-3). Raises ValueError when the frame is shorter than it says."""
        used = nav_sat_used(raw)
        self._epoch(int.from_bytes(raw[6:10], "little")).n_used_sat = used

    def push(self, name: str, m) -> None:
        """One decoded message into its epoch; raises ValueError (the frame is dropped and counted, see
        :func:`decode_ubx`) for a week or a date beyond :data:`MAX_WEEK` / :data:`MAX_YEAR`: a corrupt frame
        whose time the nanosecond scale cannot hold."""
        week = getattr(m, "wnR" if name == "TIM-TM2" else "week", None)
        if week is not None and int(week) > MAX_WEEK:
            raise ValueError(f"GPS week {int(week)} is beyond week {MAX_WEEK} (year {MAX_YEAR}): a corrupt frame")
        if name in ("NAV-PVT", "NAV-TIMEUTC") and int(m.year) > MAX_YEAR:
            raise ValueError(f"UTC year {int(m.year)} is beyond {MAX_YEAR}: a corrupt frame")
        if name == "TIM-TP":
            qerr = math.nan if getattr(m, "qErrInvalid", 0) else m.qErr * 1e-12
            self._pulses.append((int(m.week), int(m.towMS), int(m.timeBase), qerr))
            return
        if name == "TIM-TM2":
            if m.newRisingEdge and m.time:
                self.marks_gps_ns.append(int(m.wnR) * NS_PER_WEEK + int(m.towMsR) * 1_000_000 + int(m.towSubMsR))
            return
        if name == "RXM-RAWX":
            ep = self._epoch(int(round(m.rcvTow * 1000.0)) % MS_PER_WEEK, raw=True)
            ep.week = int(m.week)
            if m.leapSec:
                ep.leap_s = int(m.leapS)
            return
        ep = self._epoch(int(m.iTOW))
        if name == "NAV-EOE":
            ep.ended = True
        elif name == "NAV-PVT":
            ep.mode = GPSD_FIX_MODE.get(int(m.fixType), 0)
            ep.n_sats = int(m.numSV)
            ep.pdop = float(m.pDOP)
            if m.validDate and m.validTime and m.fullyResolved:
                ep.time_valid = True
                ep.utc_ns = _utc_label_ns(m.year, m.month, m.day, m.hour, m.min, m.second, m.nano)
                ep.leap_from_utc = True
        elif name == "NAV-SOL" or name == "NAV-STATUS":
            fix_ok = m.gpsfixOK if name == "NAV-SOL" else m.gpsFixOk
            fix = GPSD_FIX_MODE.get(int(m.gpsFix), 0) if fix_ok or m.gpsFix == 0 else 1
            if ep.mode == 0:
                ep.mode = fix
            if name == "NAV-SOL":
                if ep.n_sats < 0:
                    ep.n_sats = int(m.numSV)
                if math.isnan(ep.pdop):
                    ep.pdop = float(m.pDOP)
                if m.wknSet and m.towSet:
                    ep.week = int(m.week)
            elif m.wknSet and m.towSet:
                ep.time_valid = ep.time_valid or bool(fix_ok)
        elif name == "NAV-TIMEGPS":
            if m.weekValid and m.towValid:
                ep.week = int(m.week)
            if m.leapSValid:
                ep.leap_s = int(m.leapS)
        elif name == "NAV-TIMEUTC":
            if m.validUTC and m.validTOW and m.validWKN:
                ep.time_valid = True
                ep.utc_ns = _utc_label_ns(m.year, m.month, m.day, m.hour, m.min, m.sec, m.nano)
                ep.leap_from_utc = True
        elif name == "NAV-TIMELS":
            if m.validCurrLs:
                ep.leap_s = int(m.currLs)
            if m.validTimeToLsEvent and m.lsChange and 0 < m.timeToLsEvent <= 86_400:
                ep.leap_pending = int(np.sign(m.lsChange))
        elif name == "NAV-DOP":
            ep.gdop, ep.pdop, ep.hdop = _dop(m.gDOP), _dop(m.pDOP), _dop(m.hDOP)
            ep.vdop, ep.tdop = _dop(m.vDOP), _dop(m.tDOP)
        elif name == "NAV-CLOCK":
            ep.clock_bias_s = m.clkB * 1e-9
            ep.clock_drift_s_per_s = m.clkD * 1e-9
            ep.time_acc_s = m.tAcc * 1e-9

    def pop_complete(self, stats: UbxDecodeStats | None = None, max_undated: int = 64) -> dict | None:
        """Streaming: the epochs before the one in progress as arrays, removed from the builder. The last
        dated epoch and the receiver's last leap count carry over to later calls, so an epoch without a
        week of its own is placed from its predecessors; TIM-TP pulses wait for their epoch. Epochs
        before anything dates them wait (at most ``max_undated``); an epoch whose NAV-EOE has come is
        complete even while it is the last one. None when nothing is ready."""
        ended = [i for i, ep in enumerate(self._epochs) if ep.ended]
        cut = max(len(self._epochs) - 1, ended[-1] + 1 if ended else 0)
        closed = self._epochs[:cut]
        if not closed:
            return None
        rows = self._rows_of(closed, stats, streaming=True, final=len(closed) > max_undated)
        if rows is None:
            return None
        self._epochs = self._epochs[len(closed):]
        return rows

    def pop_complete_records(self, stats: UbxDecodeStats | None = None, max_undated: int = 64) -> list[dict]:
        """:meth:`pop_complete` as one dict per epoch, computed without arrays: the live path's twin for a
        receiver that sends UBX only (a few epochs per call, where array set-up costs more than the work;
        :func:`_records_of` is the scalar twin of :meth:`_rows_of`, and the tests compare the two)."""
        ended = [i for i, ep in enumerate(self._epochs) if ep.ended]
        cut = max(len(self._epochs) - 1, ended[-1] + 1 if ended else 0)
        closed = self._epochs[:cut]
        if not closed:
            return []
        records = _records_of(self, closed, stats, final=len(closed) > max_undated)
        if records is None:
            return []
        self._epochs = self._epochs[len(closed):]
        return records

    def pop_all_records(self, stats: UbxDecodeStats | None = None) -> list[dict]:
        """:meth:`pop_all` as one dict per epoch (see :meth:`pop_complete_records`)."""
        self._epochs.append(_Epoch(-1))
        records = self.pop_complete_records(stats, max_undated=0)
        self._epochs = []
        if self._pulses:
            unmatched = _attach_pulses_records(records, self._pulses)
            if stats is not None:
                stats.pulses_without_epoch += unmatched
        self._pulses = []
        return records

    def pop_all(self, stats: UbxDecodeStats | None = None) -> dict | None:
        """Streaming, at the end of the stream: every epoch left (the one in progress too)."""
        self._epochs.append(_Epoch(-1))  # a sentinel "next epoch" so that every real one is closed
        rows = self.pop_complete(stats, max_undated=0)
        self._epochs = []
        if self._pulses:
            if rows is not None:
                rows, unmatched = attach_pulses(rows, self._pulses)
            else:
                unmatched = len(self._pulses)
            if stats is not None:
                stats.pulses_without_epoch += unmatched
        self._pulses = []
        return rows

    def rows(self, stats: UbxDecodeStats | None = None) -> dict[str, np.ndarray]:
        """The dated epochs in time order as arrays: ``gps_ns`` and the per-epoch fields of
        :class:`chronofuse.epochs.ReceiverEpochs` (plus ``leap_from_receiver``: the leap count is the
        receiver's own, not the table's)."""
        return self._rows_of(self._epochs, stats, streaming=False, final=True)

    def _rows_of(self, eps: list, stats, streaming: bool, final: bool) -> dict | None:
        has_anchor = streaming and self._anchor is not None
        if has_anchor:
            anchor = _Epoch(self._anchor[0])
            anchor.week = self._anchor[1]
            anchor.leap_s = self._last_leap
            eps = [anchor] + list(eps)
        n = len(eps)
        itow = np.array([e.itow_ms for e in eps], dtype=np.int64)
        approx = np.full(n, np.iinfo(np.int64).min, dtype=np.int64)
        for i, e in enumerate(eps):
            if e.week >= 0:
                approx[i] = e.week * NS_PER_WEEK + e.itow_ms * 1_000_000
            elif e.utc_ns is not None:
                leap = e.leap_s if e.leap_s is not None else int(gps_minus_utc_s(e.utc_ns))
                approx[i] = e.utc_ns + leap * NS_PER_S
        gps_ns = _place_on_weeks(itow, approx)
        dated = gps_ns != np.iinfo(np.int64).min
        if streaming and not dated.any() and not final:
            return None
        # GPS - UTC: the receiver's own where it says (directly, or as its GPS minus its UTC label)
        leap = np.full(n, -1, dtype=np.int64)
        own = np.zeros(n, dtype=bool)
        pending = np.zeros(n, dtype=np.int8)
        for i, e in enumerate(eps):
            if e.leap_s is not None:
                leap[i], own[i] = e.leap_s, True
            elif e.utc_ns is not None and dated[i]:
                leap[i], own[i] = round((int(gps_ns[i]) - e.utc_ns) / NS_PER_S), True
            pending[i] = e.leap_pending
        leap = _fill_leap(leap, own, gps_ns, dated)
        rows = {
            "gps_ns": gps_ns,
            "fix_mode": np.array([e.mode for e in eps], dtype=np.int8),
            "time_valid": np.array([e.time_valid for e in eps], dtype=bool),
            "n_sats": np.array([e.n_sats if e.n_sats >= 0 else e.n_used_sat for e in eps], dtype=np.int16),
            "gdop": np.array([e.gdop for e in eps]),
            "pdop": np.array([e.pdop for e in eps]),
            "hdop": np.array([e.hdop for e in eps]),
            "vdop": np.array([e.vdop for e in eps]),
            "tdop": np.array([e.tdop for e in eps]),
            "leap_s": leap.astype(np.int16),
            "leap_pending": pending,
            "qerr_s": np.full(n, np.nan),
            "clock_bias_s": np.array([e.clock_bias_s for e in eps]),
            "clock_drift_s_per_s": np.array([e.clock_drift_s_per_s for e in eps]),
            "time_acc_s": np.array([e.time_acc_s for e in eps]),  # NAV-CLOCK tAcc (not a ReceiverEpochs field)
            "leap_from_receiver": own,
        }
        rows = {k: v.reshape(n) if v.ndim else v for k, v in rows.items()}
        if streaming:
            if dated.any():
                last = int(np.flatnonzero(dated)[-1])
                self._anchor = (int(itow[last]), int(gps_ns[last] // NS_PER_WEEK))
            if own.any():
                self._last_leap = int(leap[np.flatnonzero(own)[-1]])
        if stats is not None:
            stats.undated_epochs += int((~dated).sum())
        if has_anchor:
            dated[0] = False  # the carried anchor is no epoch of this batch
        rows = {k: v[dated] for k, v in rows.items()}
        if not streaming:
            rows, unmatched = attach_pulses(rows, self._pulses)
            if stats is not None:
                stats.pulses_without_epoch += unmatched
            return rows
        if rows["gps_ns"].size == 0:
            return rows
        latest = int(np.argmax(rows["gps_ns"]))  # the stream's order may not be time order (io/arrival.py)
        last_gps = int(rows["gps_ns"][latest])
        ready = [p for p in self._pulses if pulse_gps_ns(p, int(rows["leap_s"][latest])) <= last_gps]
        self._pulses = [p for p in self._pulses if p not in ready]
        rows, unmatched = attach_pulses(rows, ready)
        if stats is not None:
            stats.pulses_without_epoch += unmatched
        return rows


_MISSING = int(np.iinfo(np.int64).min)


def _records_of(builder: UbxEpochBuilder, eps: list, stats, final: bool) -> list[dict] | None:
    """Scalar twin of :meth:`UbxEpochBuilder._rows_of` in its streaming use: the same placement on weeks
    (:func:`_place_on_weeks`), leap filling (:func:`_fill_leap`) and pulse pairing, one epoch at a time."""
    has_anchor = builder._anchor is not None
    if has_anchor:
        anchor = _Epoch(builder._anchor[0])
        anchor.week = builder._anchor[1]
        anchor.leap_s = builder._last_leap
        eps = [anchor] + list(eps)
    n = len(eps)
    approx = []
    for e in eps:
        if e.week >= 0:
            approx.append(e.week * NS_PER_WEEK + e.itow_ms * 1_000_000)
        elif e.utc_ns is not None:
            leap = e.leap_s if e.leap_s is not None else int(gps_minus_utc_s(e.utc_ns))
            approx.append(e.utc_ns + leap * NS_PER_S)
        else:
            approx.append(_MISSING)
    have = [i for i, a in enumerate(approx) if a != _MISSING]
    if not have:
        if stats is not None and final:
            stats.undated_epochs += n - (1 if has_anchor else 0)
        return None if not final else []
    gps = []
    for i, e in enumerate(eps):
        # nearest dated epoch in stream order (the left one on a tie), as _place_on_weeks
        j = min(have, key=lambda h: (abs(h - i), h > i))
        step_ms = e.itow_ms - eps[j].itow_ms
        step_ms = (step_ms + MS_PER_WEEK // 2) % MS_PER_WEEK - MS_PER_WEEK // 2
        estimate = approx[j] + step_ms * 1_000_000
        week = int(np.rint((estimate - e.itow_ms * 1_000_000) / NS_PER_WEEK))
        gps.append(week * NS_PER_WEEK + e.itow_ms * 1_000_000)
    own = []
    leap = []
    for i, e in enumerate(eps):
        if e.leap_s is not None:
            leap.append(e.leap_s)
            own.append(True)
        elif e.utc_ns is not None:
            leap.append(round((gps[i] - e.utc_ns) / NS_PER_S))
            own.append(True)
        else:
            leap.append(-1)
            own.append(False)
    if any(own):  # carry the last own count forward, the first one backward (_fill_leap)
        first = next(v for v, o in zip(leap, own) if o)
        current = first
        for i in range(n):
            if own[i]:
                current = leap[i]
            else:
                leap[i] = current
    else:
        leap = [int(gps_minus_utc_s(g)) for g in gps]
    records = []
    for i, e in enumerate(eps):
        if has_anchor and i == 0:
            continue
        records.append({
            "gps_ns": gps[i], "fix_mode": e.mode, "time_valid": bool(e.time_valid),
            "n_sats": e.n_sats if e.n_sats >= 0 else e.n_used_sat, "gdop": e.gdop, "pdop": e.pdop,
            "hdop": e.hdop, "vdop": e.vdop, "tdop": e.tdop, "leap_s": int(leap[i]), "leap_pending": e.leap_pending,
            "qerr_s": math.nan, "clock_bias_s": e.clock_bias_s, "clock_drift_s_per_s": e.clock_drift_s_per_s,
            "time_acc_s": e.time_acc_s})
    builder._anchor = (eps[-1].itow_ms, gps[-1] // NS_PER_WEEK)  # every epoch is placed once one is dated
    owned = [i for i in range(n) if own[i]]
    if owned:
        builder._last_leap = int(leap[owned[-1]])
    if not records:
        return records
    latest = max(records, key=lambda r: r["gps_ns"])  # the stream's order may not be time order (io/arrival.py)
    last_gps = latest["gps_ns"]
    ready = [p for p in builder._pulses if pulse_gps_ns(p, latest["leap_s"]) <= last_gps]
    builder._pulses = [p for p in builder._pulses if p not in ready]
    unmatched = _attach_pulses_records(records, ready)
    if stats is not None:
        stats.pulses_without_epoch += unmatched
    return records


def _attach_pulses_records(records: list[dict], pulses: list) -> int:
    """:func:`~chronofuse.io.ubx_pulses.attach_pulses` on records (in stream order, kept); returns the unmatched."""
    import bisect

    by_time = sorted(records, key=lambda r: r["gps_ns"])
    times = [r["gps_ns"] for r in by_time]
    unmatched = 0
    for week, tow_ms, base, qerr in pulses:
        t = week * NS_PER_WEEK + tow_ms * 1_000_000
        if base == 1:
            j = bisect.bisect_right(times, t) - 1
            leap = by_time[max(j, 0)]["leap_s"] if times else int(gps_minus_utc_s(t))
            t += leap * NS_PER_S
        j = bisect.bisect_left(times, t)
        if j < len(times) and times[j] == t:
            by_time[j]["qerr_s"] = qerr
        else:
            unmatched += 1
    return unmatched


def nav_sat_used(raw: bytes) -> int:
    """Satellites used in the navigation solution, from a whole UBX-NAV-SAT frame read by its layout (u-blox
    8 / M8 and F9 interface descriptions, UBX-NAV-SAT): payload ``iTOW`` U4, ``version`` U1, ``numSvs`` U1,
    2 reserved bytes, then ``numSvs`` blocks of 12 bytes whose byte 8 starts the ``flags`` X4, bit 3 being
    ``svUsed``. Read directly rather than through pyubx2, whose per-satellite bitfield decoding made NAV-SAT
    the costliest message of a timing receiver's stream. Raises ValueError for a frame shorter than it says."""
    n_svs = raw[11] if len(raw) >= 16 else -1
    if n_svs < 0 or len(raw) < 6 + 8 + 12 * n_svs + 2:
        raise InputError(f"NAV-SAT frame of {len(raw)} bytes is shorter than its satellite count says")
    return sum((raw[22 + 12 * k] >> 3) & 1 for k in range(n_svs))


def _rawx_header_frame(raw: bytes) -> bytes:
    """The RXM-RAWX frame with its measurement blocks left out (``numMeas`` 0, the 16-byte header kept,
    checksum recomputed): pyubx2 then decodes only the header fields we use (``rcvTow``, ``week``,
    ``leapS``, ``recStat``) instead of 32 bytes x 20 fields per measurement."""
    header = bytearray(raw[6:22])
    header[11] = 0  # numMeas
    body = raw[2:4] + b"\x10\x00" + bytes(header)
    return b"\xb5\x62" + body + calc_checksum(body)


def _place_on_weeks(itow_ms: np.ndarray, approx_gps_ns: np.ndarray) -> np.ndarray:
    """Full GPS ns of each epoch: the instant with time of week ``itow_ms`` nearest an estimate, the
    estimate being the epoch's own (``approx_gps_ns``) or, for epochs without one, the nearest dated
    epoch's plus the iTOW step (wrapped to +- half a week)."""
    n = itow_ms.size
    missing = np.iinfo(np.int64).min
    out = np.full(n, missing, dtype=np.int64)
    have = np.flatnonzero(approx_gps_ns != missing)
    if n == 0 or have.size == 0:
        return out
    # nearest dated epoch in file order, for each epoch
    pos = np.searchsorted(have, np.arange(n))
    left = have[np.clip(pos - 1, 0, have.size - 1)]
    right = have[np.clip(pos, 0, have.size - 1)]
    idx = np.where(np.abs(np.arange(n) - left) <= np.abs(right - np.arange(n)), left, right)
    step_ms = itow_ms - itow_ms[idx]
    step_ms = (step_ms + MS_PER_WEEK // 2) % MS_PER_WEEK - MS_PER_WEEK // 2
    estimate = approx_gps_ns[idx] + step_ms * 1_000_000
    week = np.rint((estimate - itow_ms * 1_000_000) / NS_PER_WEEK).astype(np.int64)
    return week * NS_PER_WEEK + itow_ms * 1_000_000


def _fill_leap(leap: np.ndarray, own: np.ndarray, gps_ns: np.ndarray, dated: np.ndarray) -> np.ndarray:
    """Carry the receiver's last leap count forward (and its first one backward); the table elsewhere."""
    out = leap.copy()
    idx = np.flatnonzero(own)
    if idx.size:
        pos = np.searchsorted(idx, np.arange(leap.size), side="right") - 1
        src = idx[np.clip(pos, 0, None)]
        out = np.where(own, leap, leap[src])
    elif dated.any():
        out[dated] = gps_minus_utc_s(gps_ns[dated])
    return out


def decode_ubx(frames, builder: UbxEpochBuilder, stats: UbxDecodeStats) -> None:
    """Decode the UBX frames we use among ``frames`` with pyubx2 (checksums already verified by the
    framer) and push them into ``builder``; a frame pyubx2 refuses is counted, never fatal."""
    for frame in frames:
        if frame.kind != "ubx" or frame.name not in UBX_TYPES:
            continue
        try:
            if frame.name == "NAV-SAT":
                builder.push_nav_sat(frame.raw)  # read by its layout, see nav_sat_used
                stats.decoded[frame.name] += 1
                continue
            msg = decode_fixed(frame.name, frame.raw)  # pyubx2's layout, compiled (io/ubx_layouts.py)
            if msg is None:
                raw = _rawx_header_frame(frame.raw) if frame.name == "RXM-RAWX" and len(frame.raw) >= 24 else frame.raw
                msg = UBXReader.parse(raw, validate=0)
            builder.push(frame.name, msg)
        except Exception as err:  # pyubx2 raises several types on short or odd payloads; count, go on
            stats.parse_errors += 1
            if len(stats.errors) < 50:
                stats.errors.append((frame.offset, f"{frame.name}: {type(err).__name__}: {err}"))
            continue
        stats.decoded[frame.name] += 1

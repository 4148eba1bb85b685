"""NMEA 0183 sentences to per-epoch receiver reports, decoded by pynmeagps (the field's parser).

Sentences used (NMEA 0183 v4.11; talkers GP, GN, GL, GA, BD/GB (BeiDou), GQ, GI):

* GGA: UTC time of day, quality (0 = no fix), satellites used, HDOP, altitude.
* RMC: UTC time, status (``A`` valid / ``V`` void), date ``ddmmyy``.
* ZDA: UTC time and a four-digit year.
* GSA: fix mode (1 none, 2 2-D, 3 3-D), the satellites used, PDOP/HDOP/VDOP. NMEA 4.10 sends one GSA per
  constellation, each with a system ID (field 18); they describe ONE solution, so their satellites are
  pooled and their (identical) DOPs taken once.
* GSV: satellites in view, with elevation and azimuth: GSA carries no GDOP or TDOP, so they are computed
  from the geometry of the satellites GSA lists as used (:func:`chronofuse.io.dop.geometry_dops`, as gpsd does).
* GST: pseudorange error statistics (counted by the framer, not decoded: no field of the record).
* GNS: fix mode per constellation and satellites used (a GGA substitute of multi-GNSS receivers).
* GLL: UTC time and status, like RMC without the date (some receivers close their burst with it).

Epochs: a receiver sends its sentences of one navigation epoch as a burst, after the 1PPS edge the
epoch's time labels; GGA, RMC, ZDA, GNS and GST carry the epoch's UTC time of day (GLL too), GSA and GSV carry
none (nor does a timed sentence with an empty time field) and belong to the burst in progress. A new time of day opens a new epoch. The burst of second
``k`` therefore labels the pulse at ``k``, however late after that pulse it arrives.

Dates: RMC's two-digit year is placed in 1980-2079 (the GPS era; pynmeagps pivots earlier), ZDA's
year is taken as sent. A time of day that steps back by more than 12 h is the next UTC day. Epochs
before the first date take it from the first dated epoch. A receiver with the GPS week-rollover bug
(dates 1024 weeks early, e.g. 1999-08-22 for 2019-04-07) is corrected only when the caller passes a
trusted ``reference_gps_ns`` (:func:`chronofuse.timescale.resolve_week`); by default dates are kept as
the receiver sent them.

Fix mode follows gpsd's TPV ``mode``: GSA's mode when the burst has one, else GGA/GNS (quality 0: no
fix, 1; otherwise 3 with an altitude, 2 without), the highest of them when several are sent, and RMC or GLL
(``V``: 1, ``A``: a fix of the previous epoch's dimension, 2 at first).
"""

from __future__ import annotations

import datetime as dt
import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
from pynmeagps import NMEAReader

from chronofuse.io.dop import geometry_dops  # noqa: F401 (re-exported: callers import it from here)
from chronofuse.io.frames import KNOWN_TALKERS
from chronofuse.timescale import (
    NS_PER_S,
    datetime64_to_gps_ns,
    gps_ns_from_week_tow,
    gps_minus_utc_s,
    resolve_week,
    week_tow,
)

__all__ = ["NMEA_TYPES", "NmeaDecodeStats", "NmeaEpochBuilder", "decode_nmea"]

#: Sentence types decoded (others are counted by the framer and not parsed).
NMEA_TYPES = frozenset({"GGA", "RMC", "ZDA", "GSA", "GSV", "GST", "GNS", "GLL"})
_TIMED = frozenset({"GGA", "RMC", "ZDA", "GNS", "GST", "GLL"})
_MS_PER_DAY = 86_400_000
_SKY_EPOCHS = 10
_HALF_DAY_MS = _MS_PER_DAY // 2


@dataclass
class NmeaDecodeStats:
    """Sentences decoded per type, sentences pynmeagps refused (with the first reasons), sentences of
    talkers we do not use, and epochs dropped because their UTC label repeats or runs backwards."""

    decoded: Counter = field(default_factory=Counter)
    parse_errors: int = 0
    unknown_talker: int = 0
    out_of_order_epochs: int = 0
    errors: list = field(default_factory=list)


class _Epoch:
    __slots__ = ("tod_ms", "date", "gsa_mode", "gga_mode", "rmc_mode", "rmc_valid", "gga_sats",
                 "gsa_svids", "pdop", "hdop", "vdop", "gga_hdop", "visible", "gsv_seen", "sky")

    def __init__(self, tod_ms: int | None) -> None:
        self.tod_ms = tod_ms
        self.date: dt.date | None = None
        self.gsa_mode = 0
        self.gga_mode = 0
        self.rmc_mode = 0
        self.rmc_valid = False
        self.gga_sats = -1
        self.gsa_svids: set = set()
        self.pdop = self.hdop = self.vdop = self.gga_hdop = math.nan
        self.visible = 0
        self.gsv_seen: set = set()
        self.sky: dict = {}  # (system, svid) -> (elevation deg, azimuth deg), from GSV

    def mode(self) -> int:
        return max(self.gsa_mode, self.gga_mode, self.rmc_mode)

    def n_sats(self) -> int:
        if self.gga_sats >= 0 and (self.gga_sats > 0 or not self.gsa_svids):
            return self.gga_sats
        return len(self.gsa_svids) if self.gsa_svids else -1


#: NMEA 4.10 GSA system IDs: 1 GPS, 2 GLONASS, 3 Galileo, 4 BeiDou, 5 QZSS, 6 NavIC.
_SYSTEM_IDS = (1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
_TALKER_SYSTEM = {"GP": 1, "GL": 2, "GA": 3, "GB": 4, "BD": 4, "GQ": 5, "GI": 6}


def _system(talker: str, svid: int) -> int:
    """The constellation of a satellite number: from the talker, or for ``GN`` from NMEA's number ranges
    (1-32 GPS, 33-64 SBAS (counted with GPS), 65-96 GLONASS, 193-202 QZSS, 201-264 BeiDou, 301-336 Galileo)."""
    system = _TALKER_SYSTEM.get(talker)
    if system is not None:
        return system
    if 65 <= svid <= 96:
        return 2
    if 301 <= svid <= 336:
        return 3
    if 193 <= svid <= 200:
        return 5
    if 201 <= svid <= 264:
        return 4
    return 1


def _num(value) -> float:
    if value == "" or value is None:
        return math.nan
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _dop(value) -> float:
    """A DOP as sent; NaN when empty or not positive: a no-fix GSA's ``00.0`` is no DOP (a DOP is never
    zero); gpsd too reports another DOP there (CH-4711, JL-micro JLT; ``tests/io/test_gpsd_oracle.py``)."""
    v = _num(value)
    return v if v > 0 else math.nan


def _tod_ms(t) -> int | None:
    if not isinstance(t, dt.time):
        return None
    return ((t.hour * 60 + t.minute) * 60 + t.second) * 1000 + round(t.microsecond / 1000)


class NmeaEpochBuilder:
    """Streaming assembly of epochs: :meth:`push` one decoded sentence at a time, :meth:`rows` at the
    end (or whenever) gives the epochs closed so far as column lists."""

    def __init__(self, reference_gps_ns: int | None = None) -> None:
        self.reference_gps_ns = reference_gps_ns
        self._epochs: list[_Epoch] = []
        self._current: _Epoch | None = None
        self._prev_mode = 0
        self._sky: dict = {}  # (system, svid) -> (elevation, azimuth, epoch count when seen)
        self._n_opened = 0
        self._day_state: tuple = (None, None)  # (UTC midnight ms, last time of day) carried by pop_complete

    def push(self, msg_type: str, msg) -> None:
        tod = _tod_ms(getattr(msg, "time", None)) if msg_type in _TIMED else None
        if tod is not None:
            if self._current is None or self._current.tod_ms != tod:
                if self._current is not None and self._current.tod_ms is None:
                    self._current.tod_ms = tod  # untimed sentences opened this burst
                else:
                    self._open(_Epoch(tod))
        elif self._current is None:
            self._open(_Epoch(None))
        ep = self._current
        if msg_type == "GGA" or msg_type == "GNS":
            if msg_type == "GGA":
                quality = _num(msg.quality)
                fixed = quality > 0
            else:
                pos = str(msg.posMode)
                quality = 1.0 if pos.strip("N") else (0.0 if pos else math.nan)
                fixed = quality > 0
            if not math.isnan(quality):
                ep.gga_mode = (3 if not math.isnan(_num(msg.alt)) else 2) if fixed else 1
            sats = _num(msg.numSV)
            if not math.isnan(sats):
                ep.gga_sats = max(ep.gga_sats, int(sats))
            if math.isnan(ep.gga_hdop):
                ep.gga_hdop = _dop(msg.HDOP)
        elif msg_type == "RMC" or msg_type == "GLL":
            status = str(msg.status)
            ep.rmc_valid = status == "A"
            ep.rmc_mode = 2 if status == "A" else (1 if status == "V" else 0)
            if isinstance(getattr(msg, "date", None), dt.date):
                date = msg.date
                if date.year < 1980:
                    date = date.replace(year=date.year + 100)
                ep.date = date
        elif msg_type == "ZDA":
            try:
                ep.date = dt.date(int(msg.year), int(msg.month), int(msg.day))
            except (TypeError, ValueError):
                pass
        elif msg_type == "GSA":
            mode = _num(msg.navMode)
            if mode in (1.0, 2.0, 3.0):
                ep.gsa_mode = max(ep.gsa_mode, int(mode))
            system_id = _num(getattr(msg, "systemId", ""))
            for k in range(1, 13):
                sv = _num(getattr(msg, f"svid_{k:02d}", ""))
                if not math.isnan(sv):
                    system = int(system_id) if system_id in _SYSTEM_IDS else _system(msg.talker, int(sv))
                    ep.gsa_svids.add((system, int(sv)))
            if math.isnan(ep.pdop):
                ep.pdop, ep.hdop, ep.vdop = _dop(msg.PDOP), _dop(msg.HDOP), _dop(msg.VDOP)
        elif msg_type == "GSV":
            key = (msg.talker, getattr(msg, "signalID", ""))
            if key not in ep.gsv_seen:
                ep.gsv_seen.add(key)
                n = _num(msg.numSV)
                if not math.isnan(n):
                    ep.visible += int(n)
            for k in range(1, 5):
                sv, el, az = (_num(getattr(msg, f"{f}_{k:02d}", "")) for f in ("svid", "elv", "az"))
                if not (math.isnan(sv) or math.isnan(el) or math.isnan(az)):
                    self._sky[(_system(msg.talker, int(sv)), int(sv))] = (el, az, self._n_opened)

    def pop_complete(self, max_undated: int = 64) -> dict[str, np.ndarray] | None:
        """Streaming: the epochs closed so far (every one before the burst in progress) as arrays, removed
        from the builder; the day carries over to later calls. Epochs before any date wait for one (at
        most ``max_undated``, then they are dropped). None when nothing is ready."""
        closed = self._epochs[:-1] if self._epochs and self._epochs[-1] is self._current else self._epochs[:]
        if not closed:
            return None
        rows = self._rows_of(closed, carry=True)
        if rows is None:
            if len(closed) <= max_undated:
                return None
            rows = None
        self._epochs = self._epochs[len(closed):]
        return rows

    def _open(self, epoch: _Epoch) -> None:
        """Start a new epoch; the one it follows keeps the skyview as it stood at its end (satellites
        seen by a GSV in the last ``_SKY_EPOCHS`` epochs: receivers that rotate their GSV sentences over
        several seconds still give a whole sky)."""
        if self._current is not None:
            self._close_sky(self._current)
        self._n_opened += 1
        self._current = epoch
        self._epochs.append(epoch)

    def _close_sky(self, epoch: _Epoch) -> None:
        if not epoch.sky:
            epoch.sky = {k: (el, az) for k, (el, az, n) in self._sky.items() if self._n_opened - n < _SKY_EPOCHS}

    def pop_all(self) -> dict[str, np.ndarray] | None:
        """Streaming, at the end of the stream: every epoch left (the burst in progress too)."""
        if self._current is not None:
            self._close_sky(self._current)
        self._current = None
        return self.pop_complete(max_undated=0)

    def rows(self) -> dict[str, np.ndarray]:
        """Every epoch with a time of day, as arrays: ``gps_ns`` and the per-epoch fields of
        :class:`chronofuse.epochs.ReceiverEpochs` (``leap_s`` from the leap-second table: NMEA 0183
        carries none) plus ``n_visible``. Epochs whose date cannot be known are dropped."""
        return self._rows_of(self._epochs, carry=False) or _empty_rows()

    def _rows_of(self, epochs_in: list, carry: bool) -> dict[str, np.ndarray] | None:
        if self._current is not None and self._current in epochs_in[-1:]:
            self._close_sky(self._current)
        epochs = [e for e in epochs_in if e.tod_ms is not None]
        state = self._day_state if carry else (None, None)
        day_ms, end_state = _dates_ms(epochs, state)
        if carry:
            if all(d is None for d in day_ms) and epochs:
                return None
            self._day_state = end_state
        keep = [i for i, d in enumerate(day_ms) if d is not None]
        utc_ms = np.array([day_ms[i] + epochs[i].tod_ms for i in keep], dtype=np.int64)
        picked = [epochs[i] for i in keep]
        utc_ns = utc_ms * 1_000_000
        if self.reference_gps_ns is not None and utc_ns.size:
            week, tow = week_tow(utc_ns)
            utc_ns = gps_ns_from_week_tow(resolve_week(week, self.reference_gps_ns), tow)
        leap = gps_minus_utc_s(utc_ns) if utc_ns.size else np.zeros(0, np.int64)
        gps_ns = utc_ns + leap * NS_PER_S
        hdop = np.array([e.hdop if not math.isnan(e.hdop) else e.gga_hdop for e in picked], dtype=np.float64)
        geometry = [geometry_dops([e.sky[s] for s in e.gsa_svids if s in e.sky]) for e in picked]
        modes = _modes(picked, self._prev_mode if carry else 0)
        if carry and modes.size:
            self._prev_mode = int(modes[-1])
        return {
            "gps_ns": gps_ns,
            "fix_mode": modes,
            "time_valid": np.array([e.rmc_valid or e.gga_mode >= 2 for e in picked], dtype=bool),
            "n_sats": np.array([e.n_sats() for e in picked], dtype=np.int16),
            "n_visible": np.array([e.visible if e.gsv_seen else -1 for e in picked], dtype=np.int16),
            "gdop": np.array([g[0] for g in geometry], dtype=np.float64),
            "pdop": np.array([e.pdop for e in picked], dtype=np.float64),
            "hdop": hdop,
            "vdop": np.array([e.vdop for e in picked], dtype=np.float64),
            "tdop": np.array([g[1] for g in geometry], dtype=np.float64),
            "geometry_pdop": np.array([g[2] for g in geometry], dtype=np.float64),
            "leap_s": leap.astype(np.int16),
            "leap_pending": np.zeros(len(picked), dtype=np.int8),
            "qerr_s": np.full(len(picked), np.nan),
            "clock_bias_s": np.full(len(picked), np.nan),
            "clock_drift_s_per_s": np.full(len(picked), np.nan),
        }


def _modes(epochs: list[_Epoch], prev: int = 0) -> np.ndarray:
    """Fix mode per epoch. RMC/GLL status ``A`` alone says "a fix" without its dimension: such an epoch
    keeps the previous epoch's 2-D/3-D mode (gpsd does the same), else 2. ``prev``: the mode before."""
    out = np.zeros(len(epochs), dtype=np.int8)
    for i, e in enumerate(epochs):
        mode = e.mode()
        if mode == 2 and e.rmc_mode == 2 and e.gsa_mode == 0 and e.gga_mode == 0 and prev >= 2:
            mode = prev
        out[i] = mode
        prev = mode
    return out


def _empty_rows() -> dict[str, np.ndarray]:
    ints = {"fix_mode": np.int8, "time_valid": bool, "n_sats": np.int16, "n_visible": np.int16,
            "leap_s": np.int16, "leap_pending": np.int8, "gps_ns": np.int64}
    names = ("gps_ns", "fix_mode", "time_valid", "n_sats", "n_visible", "gdop", "pdop", "hdop", "vdop", "tdop",
             "geometry_pdop", "leap_s", "leap_pending", "qerr_s", "clock_bias_s", "clock_drift_s_per_s")
    return {n: np.zeros(0, dtype=ints.get(n, np.float64)) for n in names}


def _dates_ms(epochs: list[_Epoch], state: tuple = (None, None)) -> tuple[list[int | None], tuple]:
    """The UTC midnight (ms since the GPS epoch, UTC count) of each epoch's day: the last date sent,
    carried forward over midnight (time of day stepping back > 12 h) and backward to earlier epochs.
    ``state`` = (day, last time of day) carried from earlier epochs; the end state is returned too."""
    out: list[int | None] = [None] * len(epochs)
    day, prev_tod = state
    first_dated = 0 if day is not None else None
    for i, e in enumerate(epochs):
        if e.date is not None:
            day = _day_ms(e.date)
            if first_dated is None:
                first_dated = i
        elif day is not None and prev_tod is not None and e.tod_ms < prev_tod - _HALF_DAY_MS:
            day += _MS_PER_DAY
        prev_tod = e.tod_ms
        out[i] = day
    if first_dated is not None:
        day = out[first_dated]
        next_tod = epochs[first_dated].tod_ms
        for i in range(first_dated - 1, -1, -1):
            if epochs[i].tod_ms > next_tod + _HALF_DAY_MS:
                day -= _MS_PER_DAY
            out[i] = day
            next_tod = epochs[i].tod_ms
    end_day = None
    if epochs and out[-1] is not None:
        end_day = out[-1]
    return out, ((end_day, epochs[-1].tod_ms) if end_day is not None else state)


def _day_ms(date: dt.date) -> int:
    return int(datetime64_to_gps_ns(np.datetime64(date.isoformat(), "ns"))) // 1_000_000


def decode_nmea(frames, builder: NmeaEpochBuilder, stats: NmeaDecodeStats) -> None:
    """Decode the NMEA frames among ``frames`` (of :class:`chronofuse.io.frames.Frame`) with pynmeagps and
    push the sentences we use into ``builder``. Checksums were verified by the framer."""
    for frame in frames:
        if frame.kind != "nmea":
            continue
        name = frame.name
        if len(name) != 5 or name[0] == "P":
            continue
        msg_type = name[2:]
        if msg_type not in NMEA_TYPES:
            continue
        if name[:2] not in KNOWN_TALKERS:
            stats.unknown_talker += 1
            continue
        if msg_type == "GST":
            continue  # counted by the framer; no field of the record comes from it
        try:
            msg = NMEAReader.parse(frame.raw, validate=0)
        except Exception as err:  # pynmeagps raises many types on odd fields; count, keep going
            stats.parse_errors += 1
            if len(stats.errors) < 50:
                stats.errors.append((frame.offset, f"{name}: {type(err).__name__}: {err}"))
            continue
        if msg is None:
            stats.parse_errors += 1
            continue
        stats.decoded[msg_type] += 1
        try:
            builder.push(msg_type, msg)
        except (AttributeError, TypeError, ValueError) as err:
            stats.parse_errors += 1
            if len(stats.errors) < 50:
                stats.errors.append((frame.offset, f"{name}: {type(err).__name__}: {err}"))

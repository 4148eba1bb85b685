"""The receiver verdict: "usable" means every condition a timing engineer would check holds, and an
unusable receiver says which failed.

A receiver's 1PPS at an epoch is **usable** only when all of these hold (each failed one is a bit of
``unusable_bits``, and a sentence from :func:`reasons`):

=================  ====================================================================================
``NO_FIX``         a 2-D or 3-D (or time-only) fix (``fix_mode >= 2``)
``TIME_INVALID``   the receiver vouches for its time (``time_valid``)
``NO_GDOP``        a GDOP was reported (a receiver that sends none cannot be qualified on geometry)
``GDOP_HIGH``      GDOP < ``gdop_max``
``FEW_SATS``       at least ``min_sats`` satellites in the solution (a count was reported)
``ALARM``          no clock-bias integrity alarm raised (the latched state of the detection pipeline)
``DISSENT``        its UTC label and leap count agree with the other receivers' majority
``LEAP_TABLE``     its leap count (GPS - UTC) agrees with the leap-second table at that epoch
``JUMP``           no clock-bias jump of its own at this epoch
``STALE``          (live only) its last epoch is not older than the stale time: set by the monitor
``LEAP_PENDING``   a pending leap second it announces is possible: only in the last two days before the
                   end of June or December (a receiver raises the flag within a day of the leap), and, while
                   the table is known complete, only when the table has that leap second
``UNTESTED``       the integrity test tested this epoch (its latched state is ``ok`` or ``alarm``): an epoch
                   of the training stretch, of a receiver whose training failed, one without a clock bias
                   (NMEA, a u-blox stream without NAV-CLOCK) or before the detector's window is full was
                   never checked, so it is not usable (and never fed to a time server), whatever else holds
=================  ====================================================================================

The leap-second table is known up to :data:`LEAP_TABLE_KNOWN_UNTIL_GPS_NS` (IERS Bulletin C 70, July 2025:
no leap second at the end of December 2025). After it, a count one above the table is a leap second the
table cannot know yet and passes; any other disagreement fails at any date (a lone receiver reporting
17 s in 2026 is wrong: there has been no negative leap second).

The stage follows the pipeline interface (:mod:`chronofuse.estimation.pipeline`): ``step`` takes one epoch,
``run`` a frame of arrays (:func:`verdict_bits`); ``step`` uses its scalar twin :func:`verdict_bits_one`,
and the tests hold the two equal.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import ClassVar

import bisect
import math

import numpy as np

from chronofuse.timescale import LEAP_SECONDS, NS_PER_S, TAI_MINUS_GPS_S, gps_minus_utc_s, utc_to_gps_ns
from chronofuse.validation import check_scalar

__all__ = ["ReceiverVerdict", "verdict_bits", "verdict_bits_one", "reasons", "REASON_BITS", "LEAP_TABLE_KNOWN_UNTIL_GPS_NS",
           "TESTED_STATES", "untested_why", "pending_leap_why"]

NO_FIX, TIME_INVALID, NO_GDOP, GDOP_HIGH, FEW_SATS, ALARM, DISSENT, LEAP_TABLE, JUMP, STALE, UNTESTED, LEAP_PENDING = (
    1 << k for k in range(12))
#: name -> bit
REASON_BITS = {"NO_FIX": NO_FIX, "TIME_INVALID": TIME_INVALID, "NO_GDOP": NO_GDOP, "GDOP_HIGH": GDOP_HIGH,
               "FEW_SATS": FEW_SATS, "ALARM": ALARM, "DISSENT": DISSENT, "LEAP_TABLE": LEAP_TABLE, "JUMP": JUMP,
               "STALE": STALE, "UNTESTED": UNTESTED, "LEAP_PENDING": LEAP_PENDING}
#: The latched states of an epoch the integrity test did test.
TESTED_STATES = ("ok", "alarm")
#: The end of the period for which the built-in leap-second table is known complete (module docstring).
LEAP_TABLE_KNOWN_UNTIL_GPS_NS = int(utc_to_gps_ns(np.datetime64("2025-12-31T23:59:59", "ns"))) + NS_PER_S


def verdict_bits(fix_mode, time_valid, gdop, n_sats, leap_s, t_ns, alarm, dissent, jump, untested=False,
                 leap_pending=0, *, gdop_max: float, min_sats: int) -> np.ndarray:
    """The failed conditions (module docstring) as bits, for arrays of any one shape (or scalars)."""
    fix_mode, n_sats = np.asarray(fix_mode), np.asarray(n_sats)
    gdop = np.asarray(gdop, dtype=np.float64)
    t_ns = np.asarray(t_ns, dtype=np.int64)
    leap_s = np.asarray(leap_s, dtype=np.int64)
    table = gps_minus_utc_s(t_ns)
    leap_ok = (leap_s == table) | ((t_ns >= LEAP_TABLE_KNOWN_UNTIL_GPS_NS) & (leap_s == table + 1))
    with np.errstate(invalid="ignore"):
        checks = ((fix_mode < 2, NO_FIX), (~np.asarray(time_valid, dtype=bool), TIME_INVALID),
                  (~np.isfinite(gdop), NO_GDOP), (np.isfinite(gdop) & ~(gdop < gdop_max), GDOP_HIGH),
                  (n_sats < min_sats, FEW_SATS), (np.asarray(alarm, dtype=bool), ALARM),
                  (np.asarray(dissent, dtype=bool), DISSENT), (~leap_ok, LEAP_TABLE),
                  (np.asarray(jump, dtype=bool), JUMP), (np.asarray(untested, dtype=bool), UNTESTED),
                  (_pending_wrong(t_ns, leap_s, leap_pending), LEAP_PENDING))
    bits = np.zeros(np.broadcast(*(c for c, _ in checks)).shape, dtype=np.int64)
    for failed, bit in checks:
        bits = bits | np.where(failed, bit, 0)
    return bits


_STARTS_GPS_NS = [int(utc_to_gps_ns(np.datetime64(day, "ns"))) for day, _ in LEAP_SECONDS]
_GPS_MINUS_UTC = [tai_utc - TAI_MINUS_GPS_S for _, tai_utc in LEAP_SECONDS]
#: the leap seconds of the table: the UTC day after each -> +1 (inserted) or -1 (deleted)
_LEAP_DAYS = {day: now - before for (day, now), (_, before) in zip(LEAP_SECONDS[1:], LEAP_SECONDS[:-1])}
#: a pending leap is possible this long before the end of June or December (a receiver announces it a day ahead)
PENDING_WINDOW_S = 2 * 86_400
_GPS_EPOCH = datetime(1980, 1, 6)


def pending_leap_why(t_ns: int, leap_s: int, pending: int) -> str | None:
    """Why a pending leap second announced at GPS ``t_ns`` (the receiver's GPS - UTC ``leap_s``) cannot be
    (module docstring, ``LEAP_PENDING``), or None when it can (or none is pending)."""
    pending = int(pending)
    if not pending:
        return None
    utc = _GPS_EPOCH + timedelta(seconds=int(t_ns) // NS_PER_S - int(leap_s))
    next_month = datetime(utc.year + (utc.month == 12), utc.month % 12 + 1, 1)
    if next_month.month not in (1, 7) or (next_month - utc).total_seconds() > PENDING_WINDOW_S:
        return (f"pending leap {pending:+d} s on {utc:%Y-%m-%d}: a leap second comes only at the end of June or "
                "December")
    if int(t_ns) < LEAP_TABLE_KNOWN_UNTIL_GPS_NS and _LEAP_DAYS.get(f"{next_month:%Y-%m-%d}") != pending:
        return (f"pending leap {pending:+d} s at the end of {utc:%Y-%m-%d}: not in the leap-second table (known "
                "complete up to the end of 2025)")
    return None


def _pending_wrong(t_ns, leap_s, leap_pending) -> np.ndarray:
    t_ns, leap_s, pend = np.broadcast_arrays(np.asarray(t_ns, dtype=np.int64), np.asarray(leap_s, dtype=np.int64),
                                             np.asarray(leap_pending, dtype=np.int64))
    t, lp, pd = t_ns.reshape(-1), leap_s.reshape(-1), pend.reshape(-1)
    out = np.zeros(t.shape, dtype=bool)
    for k in np.flatnonzero(pd):
        out[k] = pending_leap_why(int(t[k]), int(lp[k]), int(pd[k])) is not None
    return out.reshape(t_ns.shape)


def verdict_bits_one(fix_mode, time_valid, gdop, n_sats, leap_s, t_ns, alarm, dissent, jump, untested=False,
                     leap_pending=0, *, gdop_max: float, min_sats: int) -> int:
    """:func:`verdict_bits` of one epoch in plain Python, the live path's twin (a few microseconds where
    the array version's set-up costs a hundred; the tests compare the two)."""
    t_ns = int(t_ns)
    i = bisect.bisect_right(_STARTS_GPS_NS, t_ns) - 1
    table = _GPS_MINUS_UTC[i] if i >= 0 else None
    leap_ok = table is not None and (leap_s == table or (t_ns >= LEAP_TABLE_KNOWN_UNTIL_GPS_NS and leap_s == table + 1))
    finite = gdop == gdop and gdop not in (math.inf, -math.inf)
    bits = 0
    bits |= NO_FIX if fix_mode < 2 else 0
    bits |= TIME_INVALID if not time_valid else 0
    bits |= NO_GDOP if not finite else 0
    bits |= GDOP_HIGH if finite and not gdop < gdop_max else 0
    bits |= FEW_SATS if n_sats < min_sats else 0
    bits |= ALARM if alarm else 0
    bits |= DISSENT if dissent else 0
    bits |= LEAP_TABLE if not leap_ok else 0
    bits |= JUMP if jump else 0
    bits |= UNTESTED if untested else 0
    bits |= LEAP_PENDING if leap_pending and pending_leap_why(t_ns, leap_s, leap_pending) is not None else 0
    return bits


def untested_why(epoch: dict) -> str:
    """Why the integrity test did not test an epoch: ``training`` (the detector is learning the noise model
    from the first epochs), ``training failed`` (it could not: too few valid epochs in the stretch), ``no
    clock bias`` (the source gives none: NMEA, gpsd, a u-blox stream without NAV-CLOCK) or ``no test
    statistic`` (the window is not full yet, a gap, an epoch the status gate left out)."""
    events = tuple(epoch.get("events") or ())
    if "training failed" in events:
        return "training failed"
    if "training" in events:
        return "training"
    bias = epoch.get("clock_bias_s")
    if bias is None or not (isinstance(bias, (int, float)) and math.isfinite(bias)):
        return "no clock bias"
    return "no test statistic"


def reasons(bits: int, epoch: dict, *, gdop_max: float, min_sats: int, stale_s: float | None = None,
            age_s: float | None = None) -> list[str]:
    """The failed conditions of one epoch in words, with the values that failed them."""
    bits = int(bits)
    out = []
    if bits & NO_FIX:
        out.append(f"no fix (mode {int(epoch.get('fix_mode', 0))})")
    if bits & TIME_INVALID:
        out.append("time not valid")
    if bits & NO_GDOP:
        out.append("no GDOP reported")
    if bits & GDOP_HIGH:
        out.append(f"GDOP {float(epoch['gdop']):.2f} >= {gdop_max:g}")
    if bits & FEW_SATS:
        n = int(epoch.get("n_sats", -1))
        out.append("no satellite count reported" if n < 0 else f"{n} satellites < {min_sats}")
    if bits & ALARM:
        out.append("integrity alarm (latched)")
    if bits & DISSENT:
        off = int(epoch.get("dissent_s") or 0)
        if off:
            out.append(f"time dissent: labelled {off:+d} s from the other receivers' time (on arrival)")
        else:
            out.append(f"UTC/leap dissent: leap {int(epoch['leap_s'])} s against the other receivers")
    if bits & LEAP_TABLE:
        table = int(gps_minus_utc_s(np.int64(epoch["gps_ns"] if "gps_ns" in epoch else epoch["t_ns"])))
        out.append(f"leap {int(epoch['leap_s'])} s disagrees with the leap-second table ({table} s)")
    if bits & JUMP:
        out.append("clock-bias jump")
    if bits & LEAP_PENDING:
        t = epoch["gps_ns"] if "gps_ns" in epoch else epoch["t_ns"]
        out.append(pending_leap_why(t, epoch["leap_s"], epoch.get("leap_pending", 0)) or "impossible pending leap")
    if bits & UNTESTED:
        out.append(f"integrity not tested ({untested_why(epoch)})")
    if bits & STALE:
        out.append(f"stale: no epoch for {age_s:.1f} s (> {stale_s:g} s)" if age_s is not None else "stale")
    return out


@dataclass
class ReceiverVerdict:
    """The verdict stage (module docstring): ``gdop_max``, ``min_sats`` as the qualification's."""

    gdop_max: float = 5.0
    min_sats: int = 4

    needs: ClassVar[tuple[str, ...]] = ("t_ns", "fix_mode", "time_valid", "gdop", "n_sats", "leap_s", "state",
                                        "dissent", "jump", "leap_pending")
    gives: ClassVar[tuple[str, ...]] = ("usable", "unusable_bits")

    def __post_init__(self) -> None:
        check_scalar(self.gdop_max, "gdop_max", min_val=1.0)
        check_scalar(self.min_sats, "min_sats", min_val=1, integer=True)

    def fit(self, frame=None) -> ReceiverVerdict:
        return self

    def reset(self) -> None:
        pass

    def _bits(self, e) -> np.ndarray:
        state = np.asarray(e["state"])
        return verdict_bits(e["fix_mode"], e["time_valid"], e["gdop"], e["n_sats"], e["leap_s"], e["t_ns"],
                            state == "alarm", e["dissent"], e["jump"], ~np.isin(state, TESTED_STATES),
                            e.get("leap_pending", 0), gdop_max=self.gdop_max, min_sats=self.min_sats)

    def step(self, epoch) -> dict:
        e = epoch
        bits = verdict_bits_one(int(e["fix_mode"]), bool(e["time_valid"]), float(e["gdop"]), int(e["n_sats"]),
                                int(e["leap_s"]), int(e["t_ns"]), e["state"] == "alarm", bool(e["dissent"]),
                                bool(e["jump"]), e["state"] not in TESTED_STATES, int(e.get("leap_pending", 0)),
                                gdop_max=self.gdop_max, min_sats=self.min_sats)
        return {"usable": bits == 0, "unusable_bits": bits}

    def run(self, frame) -> dict:
        bits = self._bits(frame)
        return {"usable": bits == 0, "unusable_bits": bits}

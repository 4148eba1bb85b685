"""UTC-second and leap-second consensus across receivers (the GNSSDO paper section 3.2 (1) ②).

The source paper: "compare the UTC times from several modules to make sure UTC is right, and combine and
compare their leap-second information so that the leap second is handled in time". Per second:

* the UTC label (POSIX-style seconds, ``gps_s - leap_s``), the leap count (GPS - UTC, s) and the
  pending-leap flag of every receiver that has a valid time are put to a majority vote; a receiver
  that differs from the majority on any of them is flagged (a dissenter) and is not trusted that
  second. Without a strict majority there is no consensus that second (``quorum`` False).
* a pending leap second is applied at the right second, from the announcement and the calendar, not from
  when receivers happen to raise or drop their flag or update their count: ITU-R TF.460-6 puts a leap second
  at the end of a UTC month, first preference December and June, second March and September (all 27 so far
  were at the end of June or December), and receivers raise the flag anything from hours to months before.
  The leap is therefore applied at the end of the first eligible month end (:data:`LEAP_MONTHS`) reached
  while the consensus flag is up, once: after it the flag must be seen down before it can arm again (a flag
  that lingers after the event inserts nothing more). A positive leap second is inserted after 23:59:59
  (IERS Bulletin C): in GPS seconds ``g`` with the old count ``L``, the inserted 23:59:60 is the second whose
  POSIX label ``g - L`` is the next midnight; it repeats that label, and from the following second on the
  count is ``L + 1`` (the convention of ``models.receiver``). A negative one skips 23:59:59.
* the leap count is checked against the built-in IERS table (:func:`chronofuse.timescale.gps_minus_utc_s`)
  while the table is known to hold (:data:`TABLE_KNOWN_UNTIL`): a receiver reporting another count is a
  dissenter even when it is alone, and a majority disagreeing with the table is overruled by it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.discipline.servo import freeze
from chronofuse.timescale import NS_PER_S, SECONDS_PER_DAY, gps_minus_utc_s, utc_to_gps_ns

__all__ = ["Consensus", "utc_consensus", "LeapSchedule", "apply_leap", "LEAP_MONTHS", "TABLE_KNOWN_UNTIL",
           "table_leap_s", "leap_step"]

#: Months at whose end a leap second may be applied (ITU-R TF.460-6, first preference).
LEAP_MONTHS = (6, 12)
#: The built-in leap-second table holds up to this UTC instant: IERS Bulletin C 70 (July 2025) announced no
#: leap second at the end of December 2025, and the next possible one, at the end of June 2026, is announced
#: only by Bulletin C 71 (January 2026).
TABLE_KNOWN_UNTIL = "2026-06-30T23:59:59"
_TABLE_UNTIL_GPS_NS = int(utc_to_gps_ns(np.datetime64(TABLE_KNOWN_UNTIL)))


def table_leap_s(gps_ns) -> tuple[np.ndarray, np.ndarray]:
    """GPS - UTC from the built-in table at ``gps_ns`` and whether the table is known to hold there."""
    gps = np.asarray(gps_ns, dtype=np.int64)
    known = gps <= _TABLE_UNTIL_GPS_NS
    return np.asarray(gps_minus_utc_s(np.minimum(gps, _TABLE_UNTIL_GPS_NS)), dtype=np.int64), known


@dataclass(frozen=True)
class Consensus:
    """Per second (steps,): majority ``utc_s``, ``leap_s`` (the table's where it holds), ``leap_pending`` (-1, 0,
    +1) and ``quorum``; per receiver and second (receivers, steps): ``dissent`` and ``table_mismatch`` (its leap
    count differs from the table's). Read-only."""

    utc_s: np.ndarray
    leap_s: np.ndarray
    leap_pending: np.ndarray
    quorum: np.ndarray
    dissent: np.ndarray
    table_mismatch: np.ndarray | None = None

    def __post_init__(self):
        freeze(self)


def _majority(values: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Strict-majority value per column of (receivers, steps) int ``values`` among ``valid``; (value, found)."""
    n_valid = valid.sum(axis=0)
    best = np.zeros(values.shape[1], dtype=values.dtype)
    found = np.zeros(values.shape[1], dtype=bool)
    for j in range(values.shape[0]):  # a strict majority, if any, is one of the receivers' values
        cand = values[j]
        votes = ((values == cand[None, :]) & valid).sum(axis=0)
        win = valid[j] & (2 * votes > n_valid) & ~found
        best = np.where(win, cand, best)
        found |= win
    return best, found


def utc_consensus(utc_s, leap_s, leap_pending, valid, gps_ns=None) -> Consensus:
    """Majority vote over receivers; inputs (receivers, steps): int UTC labels (s) and leap counts, the
    pending announcement (-1, 0, +1), and validity (bool; e.g. ``epochs.time_valid``); ``gps_ns`` (steps,),
    optional: the epochs, for the check against the leap-second table (module docstring)."""
    utc = np.asarray(utc_s, dtype=np.int64)
    leap = np.asarray(leap_s, dtype=np.int64)
    pend = np.asarray(leap_pending, dtype=np.int64)
    valid = np.asarray(valid, dtype=bool)
    for name, a in (("utc_s", utc), ("leap_s", leap), ("leap_pending", pend)):
        if a.shape != valid.shape or a.ndim != 2:
            raise ValueError(f"{name} has shape {a.shape}, must be (receivers, steps) = {valid.shape}")
    u, fu = _majority(utc, valid)
    lp, fl = _majority(leap, valid)
    pd, fp = _majority(pend, valid)
    mismatch = np.zeros(valid.shape, dtype=bool)
    if gps_ns is not None:
        table, known = table_leap_s(np.broadcast_to(np.asarray(gps_ns, dtype=np.int64), valid.shape[1:]))
        mismatch = valid & known[None, :] & (leap != table[None, :])
        lp = np.where(known, table, lp)
        fl = fl | known
        # The label follows the count: a majority label of receivers with a wrong count is no label.
        gps_s = np.asarray(gps_ns, dtype=np.int64) // NS_PER_S
        u = np.where(known, gps_s - table, u)
    quorum = fu & fl & fp
    dissent = valid & ((utc != u) | (leap != lp) | (pend != pd) | mismatch)
    return Consensus(u, lp, pd, quorum, dissent, mismatch)


@dataclass(frozen=True)
class LeapSchedule:
    """The GPSDO's UTC output per second: ``leap_s`` in effect, POSIX ``utc_s`` label and ``leap_second``
    (True on the inserted 23:59:60). Read-only."""

    leap_s: np.ndarray
    utc_s: np.ndarray
    leap_second: np.ndarray

    def __post_init__(self):
        freeze(self)


def _day_ends_month(label_s: int, months: tuple[int, ...]) -> bool:
    """Whether the UTC day holding POSIX-style label ``label_s`` (s since 1980-01-06, no leap seconds) is the last
    day of one of ``months``."""
    day = np.datetime64("1980-01-06", "D") + int(label_s // SECONDS_PER_DAY)
    next_day = day + 1
    month = int(str(day)[5:7])
    return month in months and str(next_day)[8:10] == "01"


def leap_step(memory: dict, gps_s: int, pending: int, months: tuple[int, ...] = LEAP_MONTHS) -> tuple[int, bool]:
    """One second of :func:`apply_leap`: ``memory`` (``current``, ``armed``, ``spent``; updated in place), the GPS
    second and the consensus flag -> ``(leap count in effect, whether this second is an inserted 23:59:60)``."""
    flag = int(np.sign(pending))
    if flag == 0:
        memory["spent"] = False
    elif not memory["spent"]:
        memory["armed"] = memory["armed"] or flag
    current = memory["current"]
    label = int(gps_s) - current
    into_day = label % SECONDS_PER_DAY
    if memory["armed"] > 0 and into_day == 0 and _day_ends_month(label - 1, months):
        memory.update(current=current + 1, armed=0, spent=True)
        return current, True  # 23:59:60, labelled as the next midnight
    if memory["armed"] < 0 and into_day == SECONDS_PER_DAY - 1 and _day_ends_month(label, months):
        memory.update(current=current - 1, armed=0, spent=True)  # 23:59:59 does not exist
    return memory["current"], False


def apply_leap(gps_s, initial_leap_s: int, leap_pending, *, months: tuple[int, ...] = LEAP_MONTHS) -> LeapSchedule:
    """Apply a pending leap second at the end of the first eligible month end (module docstring).

    ``gps_s`` (steps,) consecutive GPS seconds; ``leap_pending`` (steps,) the consensus announcement:
    +1 insert (23:59:60), -1 delete (23:59:59 is skipped: from that second the count is ``L - 1``), 0 none;
    ``months``: the months whose last day may end with a leap second.
    """
    gps = np.asarray(gps_s, dtype=np.int64)
    pending = np.asarray(leap_pending, dtype=np.int64)
    leap = np.empty(gps.shape, dtype=np.int64)
    inserted = np.zeros(gps.shape, dtype=bool)
    if not pending.any():  # nothing announced: nothing is ever armed (leap_step), the count stays as it is
        leap[:] = int(initial_leap_s)
        return LeapSchedule(leap, gps - leap, inserted)
    memory = {"current": int(initial_leap_s), "armed": 0, "spent": False}
    for k, g in enumerate(gps):
        leap[k], inserted[k] = leap_step(memory, int(g), int(pending[k]), months)
    return LeapSchedule(leap, gps - leap, inserted)

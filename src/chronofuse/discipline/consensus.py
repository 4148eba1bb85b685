"""UTC-second and leap-second consensus across receivers (the GNSSDO paper section 3.2 (1) ②).

The source paper: "compare the UTC times from several modules to make sure UTC is right, and combine and
compare their leap-second information so that the leap second is handled in time". Per second:

* the UTC label (POSIX-style seconds, ``gps_s - leap_s``), the leap count (GPS - UTC, s) and the
  pending-leap flag of every receiver that has a valid time are put to a majority vote; a receiver
  that differs from the majority on any of them is flagged (a dissenter) and is not trusted that
  second. Without a strict majority there is no consensus that second (``quorum`` False).
* a pending leap second is applied at the right second, from the announcement and the time itself,
  not from when receivers happen to update their leap count: a positive leap second is inserted after
  23:59:59 UTC of the day during which it was pending (IERS Bulletin C; ITU-R TF.460-6). In GPS
  seconds ``g`` with the old count ``L``, the inserted second 23:59:60 is the one whose POSIX label
  ``g - L`` is the next midnight (``(g - L) % 86400 == 0``); it repeats that label, and from the
  following second on the count is ``L + 1`` (the convention of ``models.receiver``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.discipline.servo import freeze
from chronofuse.timescale import SECONDS_PER_DAY

__all__ = ["Consensus", "utc_consensus", "LeapSchedule", "apply_leap"]


@dataclass(frozen=True)
class Consensus:
    """Per second (steps,): majority ``utc_s``, ``leap_s``, ``leap_pending`` (-1, 0, +1) and ``quorum``; per receiver
    and second (receivers, steps): ``dissent``. Read-only."""

    utc_s: np.ndarray
    leap_s: np.ndarray
    leap_pending: np.ndarray
    quorum: np.ndarray
    dissent: np.ndarray

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


def utc_consensus(utc_s, leap_s, leap_pending, valid) -> Consensus:
    """Majority vote over receivers; inputs (receivers, steps): int UTC labels (s) and leap counts, the
    pending announcement (-1, 0, +1), and validity (bool; e.g. ``epochs.time_valid``)."""
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
    quorum = fu & fl & fp
    dissent = valid & ((utc != u) | (leap != lp) | (pend != pd))
    return Consensus(u, lp, pd, quorum, dissent)


@dataclass(frozen=True)
class LeapSchedule:
    """The GPSDO's UTC output per second: ``leap_s`` in effect, POSIX ``utc_s`` label and ``leap_second``
    (True on the inserted 23:59:60). Read-only."""

    leap_s: np.ndarray
    utc_s: np.ndarray
    leap_second: np.ndarray

    def __post_init__(self):
        freeze(self)


def apply_leap(gps_s, initial_leap_s: int, leap_pending) -> LeapSchedule:
    """Apply a pending leap second at the end of the UTC day it is pending in (module docstring).

    ``gps_s`` (steps,) consecutive GPS seconds; ``leap_pending`` (steps,) the consensus announcement:
    +1 insert (23:59:60), -1 delete (23:59:59 is skipped: from that second the count is ``L - 1``), 0 none.
    """
    gps = np.asarray(gps_s, dtype=np.int64)
    pending = np.asarray(leap_pending, dtype=np.int64)
    leap = np.empty(gps.shape, dtype=np.int64)
    inserted = np.zeros(gps.shape, dtype=bool)
    current = int(initial_leap_s)
    armed = 0
    for k, g in enumerate(gps):
        armed = armed or int(np.sign(pending[k]))
        into_day = (int(g) - current) % SECONDS_PER_DAY
        if armed > 0 and into_day == 0:
            inserted[k] = True  # 23:59:60, labelled as the next midnight
            leap[k] = current
            current += 1
            armed = 0
            continue
        if armed < 0 and into_day == SECONDS_PER_DAY - 1:
            current -= 1  # 23:59:59 does not exist: this second is already the next midnight
            armed = 0
        leap[k] = current
    return LeapSchedule(leap, gps - leap, inserted)

"""The UTC label of the regenerated 1PPS: leap-second consensus as a stage of the GNSSDO pipeline.

Per second and trial, the receivers with valid time vote on the UTC label, the leap count and the pending
flag (:func:`~.consensus.utc_consensus`, with the check against the built-in leap-second table). Where the
table is known to hold, the output's count is the table's (no announcement can add a leap the IERS did not
announce); past its horizon the count carries on from the table's last value and a pending leap (the
consensus flag) is applied at the end of the first eligible month end (:func:`~.consensus.apply_leap`). Gives ``utc_label_s`` (trials,
steps; POSIX-style seconds since 1980-01-06, an inserted 23:59:60 repeating the next midnight's label),
``utc_leap_s`` (GPS - UTC in effect), ``leap_second`` (True on 23:59:60) and ``leap_dissent`` (trials,
receivers, steps: the receiver disagreed with the consensus or the table and was not trusted for time).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from chronofuse.discipline.consensus import LEAP_MONTHS, apply_leap, leap_step, table_leap_s, utc_consensus
from chronofuse.timescale import NS_PER_S

__all__ = ["LeapStage"]


class LeapStage:
    """Leap-second consensus feeding the output's UTC label (module docstring)."""

    needs: ClassVar[tuple[str, ...]] = ("t_ns", "leap_s", "leap_pending", "time_valid")
    gives: ClassVar[tuple[str, ...]] = ("utc_label_s", "utc_leap_s", "leap_second", "leap_dissent")

    def __init__(self, months: tuple[int, ...] = LEAP_MONTHS):
        self.months = tuple(months)
        self.reset()

    def fit(self, frame=None) -> LeapStage:
        self.reset()
        return self

    def reset(self) -> None:
        self._memory = None

    @staticmethod
    def _vote(t_ns, leap, pending, valid):
        """Consensus of one trial's (receivers, steps) reports."""
        gps_ns = np.asarray(t_ns, dtype=np.int64)[0]
        utc = gps_ns[None, :] // NS_PER_S - leap
        return utc_consensus(utc, leap, pending, valid, gps_ns), gps_ns // NS_PER_S

    @staticmethod
    def _initial(c, gps_ns: int) -> int:
        table, known = table_leap_s(np.array([gps_ns]))
        return int(table[0]) if known[0] else int(c.leap_s[0])

    @staticmethod
    def _flags(c, gps_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The consensus flag where it may act (a quorum, past the table's horizon), the table's count and
        where the table holds."""
        table, known = table_leap_s(np.asarray(gps_s, dtype=np.int64) * NS_PER_S)
        return np.where(c.quorum & ~known, c.leap_pending, 0), table, known

    def step(self, epoch) -> dict:
        t = np.asarray(epoch["t_ns"], dtype=np.int64)
        leap = np.asarray(epoch["leap_s"], dtype=np.int64)
        pending = np.asarray(epoch["leap_pending"], dtype=np.int64)
        valid = np.asarray(epoch["time_valid"], dtype=bool)
        trials = t.shape[0]
        if self._memory is None:
            self._memory = [None] * trials
        label = np.empty(trials, np.int64)
        count = np.empty(trials, np.int64)
        second = np.zeros(trials, bool)
        dissent = np.zeros(leap.shape, bool)
        for i in range(trials):
            c, gps_s = self._vote(t[i][:, None], leap[i][:, None], pending[i][:, None], valid[i][:, None])
            if self._memory[i] is None:
                self._memory[i] = {"current": self._initial(c, int(t[i, 0])), "armed": 0, "spent": False}
            flag, table, known = self._flags(c, gps_s)
            count[i], second[i] = leap_step(self._memory[i], int(gps_s[0]), int(flag[0]), self.months)
            if known[0]:
                count[i], second[i] = table[0], False
                self._memory[i]["current"] = int(table[0])
            label[i] = gps_s[0] - count[i]
            dissent[i] = c.dissent[:, 0]
        return {"utc_label_s": label, "utc_leap_s": count, "leap_second": second, "leap_dissent": dissent}

    def run(self, frame) -> dict:
        t = np.asarray(frame["t_ns"], dtype=np.int64)
        leap = np.asarray(frame["leap_s"], dtype=np.int64)
        pending = np.asarray(frame["leap_pending"], dtype=np.int64)
        valid = np.asarray(frame["time_valid"], dtype=bool)
        trials, _, steps = t.shape
        label = np.empty((trials, steps), np.int64)
        count = np.empty((trials, steps), np.int64)
        second = np.empty((trials, steps), bool)
        dissent = np.empty(leap.shape, bool)
        for i in range(trials):
            c, gps_s = self._vote(t[i], leap[i], pending[i], valid[i])
            flag, table, known = self._flags(c, gps_s)
            sched = apply_leap(gps_s, self._initial(c, int(t[i, 0, 0])), flag, months=self.months)
            count[i] = np.where(known, table, sched.leap_s)
            second[i] = ~known & sched.leap_second
            label[i] = gps_s - count[i]
            dissent[i] = c.dissent
        return {"utc_label_s": label, "utc_leap_s": count, "leap_second": second, "leap_dissent": dissent}

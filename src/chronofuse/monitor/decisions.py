"""Per-epoch decisions of the monitor for each receiver: usable or not (the disciplined oscillator's
qualification, :mod:`chronofuse.discipline.qualification`), the clock-bias integrity alarm (the HOD
detector's streaming :meth:`~chronofuse.integrity.detector.HodDetector.step`), the UTC/leap consensus
across receivers (:func:`chronofuse.discipline.consensus.utc_consensus`) and offset jumps between
receivers.

Offset jump: a receiver whose clock bias moves from one epoch to the next by more than ``jump_s`` away
from the median move of all receivers at that epoch (a step of its own, not a common one; with two
receivers the median is their mean, so both are flagged: which one moved cannot be told).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from chronofuse.discipline.consensus import utc_consensus
from chronofuse.discipline.qualification import Qualification
from chronofuse.integrity.detector import HodDetector
from chronofuse.timescale import NS_PER_S

__all__ = ["MonitorSettings", "ReceiverMonitor", "decide_second"]


@dataclass(frozen=True)
class MonitorSettings:
    """``gdop_max``/``min_sats``: qualification; ``window``, ``pfa`` and the noise model (``h0``, ``hm2``,
    ``sigma_rho_m``; any None is learnt from the clock biases of the first ``training_s`` seconds, as
    ``detect --train`` does) of the HOD detector; ``jump_s``: offset-jump threshold between receivers."""

    gdop_max: float = 5.0
    min_sats: int = 4
    window: int = 20
    pfa: float = 1e-3
    h0: float | None = None
    hm2: float | None = None
    sigma_rho_m: float | None = None
    training_s: float = 120.0
    jump_s: float = 100e-9


@dataclass
class ReceiverMonitor:
    """One receiver's live state: its last epoch and decisions, alarm and outage counters."""

    name: str
    settings: MonitorSettings
    qualification: Qualification = field(init=False)
    detector: HodDetector | None = None
    connected: bool = False
    outages: int = 0
    alarms: int = 0
    epochs: int = 0
    last: dict | None = None
    interval_s: float | None = None
    _training: list = field(default_factory=list)
    _last_gps_ns: int | None = None

    def __post_init__(self):
        self.qualification = Qualification(self.settings.gdop_max, self.settings.min_sats)

    def decide(self, epoch: dict) -> dict:
        """Usable flag and integrity test of one epoch; returns the epoch with ``usable``, ``statistic``
        and ``alarm`` added (``dissent`` and ``jump`` are set by :func:`decide_second`)."""
        usable = bool(self.qualification.usable(epoch["fix_mode"] >= 2, epoch["time_valid"], epoch["gdop"],
                                                epoch["n_sats"]))
        if self._last_gps_ns is not None and self.interval_s is None and epoch["gps_ns"] > self._last_gps_ns:
            self.interval_s = (epoch["gps_ns"] - self._last_gps_ns) / NS_PER_S
        self._last_gps_ns = epoch["gps_ns"]
        statistic, alarm = math.nan, False
        bias = epoch["clock_bias_s"]
        if self.detector is None and self.interval_s is not None and math.isfinite(bias):
            self._training.append(bias)
            if len(self._training) >= self._training_epochs():
                self.detector = self._fit()
        elif self.detector is not None:
            out = self.detector.step(bias)
            statistic, alarm = out.statistic, bool(out.alarm)
        self.alarms += alarm
        self.epochs += 1
        record = {**epoch, "receiver": self.name, "usable": usable, "statistic": statistic, "alarm": alarm,
                  "dissent": False, "jump": False}
        self.last = record
        return record

    def _training_epochs(self) -> int:
        """Epochs in the first ``training_s`` seconds at this receiver's interval (at least 1)."""
        return max(1, math.ceil(self.settings.training_s / self.interval_s - 1e-9))

    def _fit(self) -> HodDetector | None:
        s = self.settings
        detector = HodDetector(interval_s=self.interval_s, window=s.window, pfa=s.pfa, h0=s.h0, hm2=s.hm2,
                               sigma_rho_m=s.sigma_rho_m)
        try:
            detector.fit(np.asarray(self._training))
        except (ValueError, np.linalg.LinAlgError):
            return None  # a training stretch the noise fit cannot use; keep training
        finally:
            self._training = self._training[-self._training_epochs() // 2:]
        for bias in self._training:
            detector.step(bias)
        return detector


def decide_second(records: list[dict], jump_s: float, previous_bias: dict) -> None:
    """Cross-receiver decisions for records of one epoch (same ``gps_ns``), in place: UTC/leap dissent
    (majority vote over the receivers with valid time) and offset jumps. ``previous_bias`` maps a
    receiver to its last clock bias (updated)."""
    if len(records) >= 2:
        utc = np.array([[(r["gps_ns"] - r["leap_s"] * NS_PER_S) // NS_PER_S] for r in records], dtype=np.int64)
        leap = np.array([[r["leap_s"]] for r in records], dtype=np.int64)
        pend = np.array([[r["leap_pending"]] for r in records], dtype=np.int64)
        valid = np.array([[bool(r["time_valid"])] for r in records])
        dissent = utc_consensus(utc, leap, pend, valid).dissent[:, 0]
        for r, d in zip(records, dissent):
            r["dissent"] = bool(d)
    moves = {}
    for r in records:
        before = previous_bias.get(r["receiver"])
        if before is not None and math.isfinite(before) and math.isfinite(r["clock_bias_s"]):
            moves[r["receiver"]] = r["clock_bias_s"] - before
        previous_bias[r["receiver"]] = r["clock_bias_s"]
    if len(moves) >= 2:
        common = float(np.median(list(moves.values())))
        for r in records:
            if r["receiver"] in moves:
                r["jump"] = abs(moves[r["receiver"]] - common) > jump_s

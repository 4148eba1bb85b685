"""Per-epoch decisions of the monitor for each receiver: usable or not (the disciplined oscillator's
qualification, :mod:`chronofuse.discipline.qualification`), the clock-bias integrity verdict (the detection
pipeline's live driver, :class:`chronofuse.integrity.watch.ClockWatch`, on the receiver's clock bias placed on
its grid as ``detect`` places it: status gate, millisecond repair, detector, latch, with the training stretch
of the first ``train_s`` seconds), the UTC/leap consensus across receivers
(:func:`chronofuse.discipline.consensus.utc_consensus`) and offset jumps between receivers.

A receiver's epochs are held until their integrity verdict is decided (the grid learns its interval from
the first epochs carrying a bias; after that each verdict comes with its epoch), then released in order:
the monitor logs the verdicts ``detect`` gives for the same recording.

Offset jump: a receiver whose clock bias moves from one epoch to the next by more than ``jump_s`` away
from the median move of all receivers at that epoch (a step of its own, not a common one; with two
receivers the median is their mean, so both are flagged: which one moved cannot be told).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from chronofuse.discipline.consensus import utc_consensus
from chronofuse.discipline.qualification import Qualification
from chronofuse.integrity.receiver_status import DEFAULT_MAX_TIME_ACC_S
from chronofuse.integrity.watch import ClockWatch, DetectionSettings
from chronofuse.io.capture_series import clock_epochs, clock_grid
from chronofuse.io.sources_decode import dicts_record, record_rows
from chronofuse.timescale import NS_PER_S
from chronofuse.validation import InputDataError, InputError

__all__ = ["MonitorSettings", "ReceiverMonitor", "decide_second"]


@dataclass(frozen=True)
class MonitorSettings:
    """``gdop_max``/``min_sats``: qualification; ``window``, ``pfa`` and the noise model (``h0``, ``hm2``,
    ``sigma_rho_m``; any None is learnt from the clock biases of the grid's first ``train_s`` seconds, as
    ``detect`` learns them) of the detector, ``max_time_acc_s``
    of the status gate (s; None: not used); ``jump_s``: offset-jump threshold between receivers."""

    gdop_max: float = 5.0
    min_sats: int = 4
    window: int = 20
    pfa: float = 1e-3
    h0: float | None = None
    hm2: float | None = None
    sigma_rho_m: float | None = None
    jump_s: float = 100e-9
    max_time_acc_s: float | None = DEFAULT_MAX_TIME_ACC_S
    train_s: float = 120.0

    def detection(self) -> DetectionSettings:
        """The clock watch's settings (a complete noise model needs no training stretch)."""
        complete = None not in (self.h0, self.hm2, self.sigma_rho_m)
        return DetectionSettings(window=self.window, pfa=self.pfa, h0=self.h0, hm2=self.hm2,
                                 sigma_rho_m=self.sigma_rho_m, train_s=None if complete else self.train_s,
                                 max_time_acc_s=self.max_time_acc_s)

    def check(self) -> None:
        """Refuse a setting no receiver could be watched with (an :class:`InputError` naming its field), before
        any source is opened: the qualification's limits, and the detector built as every receiver's will be."""
        Qualification(self.gdop_max, self.min_sats)
        detection = self.detection()
        detection.make_detector(1.0)
        need = self.window + 3
        if detection.train_s is not None and detection.train_s < need:
            raise InputError(f"{{train_s}} == {self.train_s:g} s is too short: the detector's training needs at least "
                             f"{{window}} + 3 = {need} valid epochs, {need} s at 1 Hz; give {{train_s}} >= {need} s "
                             "(or the whole noise model: {h0}, {hm2} and {sigma_rho_m})",
                             fields=("train_s", "window", "h0", "hm2", "sigma_rho_m"))


#: An epoch is held for its verdict while at most this many later epochs of the receiver have been decoded: a
#: receiver whose clock bias stops before its grid has learnt its interval (from its first 9 epochs with a
#: bias) does not hold its later epochs back.
MAX_HOLD_EPOCHS = 32

_NO_VERDICT = {"statistic": math.nan, "alarm": False, "state": "unavailable", "events": []}


@dataclass
class ReceiverMonitor:
    """One receiver's live state: its last epoch and decisions, alarm and outage counters, and its epochs
    held until their verdict is decided (module docstring)."""

    name: str
    settings: MonitorSettings
    qualification: Qualification = field(init=False)
    connected: bool = False
    outages: int = 0
    alarms: int = 0
    epochs: int = 0
    last: dict | None = None
    interval_s: float | None = None
    _last_gps_ns: int | None = None
    _released_gps_ns: int | None = None

    def __post_init__(self):
        self.qualification = Qualification(self.settings.gdop_max, self.settings.min_sats)
        self.watch = ClockWatch(self.settings.detection())
        self.grid = clock_grid(None)
        self._held: deque = deque()
        self._verdicts: dict[int, object] = {}
        self.restarts: list[str] = []  # why the clock-bias grid had to start again (a changed output rate)

    @property
    def horizon_ns(self) -> int | None:
        """The latest epoch up to which every epoch of this receiver is released (None: none seen yet)."""
        if self._held:
            return self._held[0]["gps_ns"] - 1
        return self._released_gps_ns

    def take(self, record) -> list[dict]:
        """A chunk of decoded epochs (:class:`~chronofuse.record.EpochRecord` on GPS time): qualified, their
        clock biases handed to the clock watch; returns the records whose verdicts are decided, in order."""
        if record is None or record.n_epochs == 0:
            return []
        for epoch in record_rows(record):
            usable = bool(self.qualification.usable(epoch["fix_mode"] >= 2, epoch["time_valid"], epoch["gdop"],
                                                    epoch["n_sats"]))
            if self._last_gps_ns is not None and self.interval_s is None and epoch["gps_ns"] > self._last_gps_ns:
                self.interval_s = (epoch["gps_ns"] - self._last_gps_ns) / NS_PER_S
            self._last_gps_ns = epoch["gps_ns"]
            self.epochs += 1
            held = {**epoch, "receiver": self.name, "usable": usable, **_NO_VERDICT, "dissent": False, "jump": False}
            self._held.append(held)
            self.last = held
        clock = clock_epochs(record)
        if clock is not None:
            try:
                gridded = self.grid.push(clock)
            except InputDataError as err:  # the receiver changed its rate: a new grid and a new watch from here
                self.restarts.append(str(err))
                self.watch, self.grid = ClockWatch(self.settings.detection()), clock_grid(None)
                gridded = self.grid.push(clock)
            self._note(gridded, self.watch.push(gridded))
        return self._release(final=False)

    def _note(self, gridded, verdicts) -> None:
        """Each verdict under its epoch's own time tag (the grid moved a jittered tag to its slot)."""
        if gridded is None:
            return
        offsets = gridded.columns["tag_offset_s"]
        for t, offset, verdict in zip(gridded.t_ns.tolist(), offsets.tolist(), verdicts):
            if offset == offset:  # a gap of the grid has no epoch of its own
                self._verdicts[t + int(round(offset * 1e9))] = verdict

    def close(self) -> list[dict]:
        """End of the stream: every epoch still held, with the verdicts decided at the end (a grid that never
        learnt its interval, one epoch with a bias, leaves its epoch without a verdict)."""
        try:
            gridded = self.grid.close()
        except InputDataError:
            gridded = None
        self._note(gridded, self.watch.push(gridded))
        self.watch.close()
        return self._release(final=True)

    def flush(self) -> list[dict]:
        """Every epoch still held, with the verdicts decided so far (the link went down: they are not held
        through the outage); the grid and the watch go on with the epochs after it."""
        return self._release(final=True)

    def decide(self, epoch: dict) -> dict:
        """One decoded epoch (a dict of ``gps_ns`` and the receiver fields): its record, ``usable`` set at once,
        the integrity fields once decided (released by :meth:`take`, :meth:`close`)."""
        self.take(dicts_record([epoch], self.name))
        return self.last

    def _release(self, final: bool) -> list[dict]:
        out = []
        while self._held:
            record = self._held[0]
            has_bias = math.isfinite(record["clock_bias_s"])
            verdict = self._verdicts.pop(record["gps_ns"], None)
            waited = len(self._held) > MAX_HOLD_EPOCHS  # a grid that never learns its interval
            if has_bias and verdict is None and not (final or waited):
                break
            if verdict is not None:
                record.update(statistic=verdict.statistic, alarm=verdict.alarm, state=verdict.state,
                              events=list(verdict.events))
                self.alarms += verdict.alarm
            out.append(self._held.popleft())
        if out:
            self._released_gps_ns = out[-1]["gps_ns"]
            done = self._released_gps_ns
            self._verdicts = {t: v for t, v in self._verdicts.items() if t > done}  # the grid's gap epochs
        return out


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

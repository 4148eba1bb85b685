"""The streaming clock-bias monitor: one epoch in, one frozen verdict out.

This is the per-epoch API the live monitor calls, and what ``chronofuse detect --json-lines`` runs::

    monitor = StreamingMonitor(detector)          # a fitted HodDetector
    verdict = monitor.step(t_ns, clock_bias_s, receiver_ok=True)
    verdict.state       # "ok" | "alarm" | "unavailable"
    verdict.events      # ("raise: ...", "clear: ...", "clock reset -1 ms", ...)

Per epoch, causally (epochs ``<= k`` only):

1. **clock steering**: a second difference within ``tolerance_s`` of a whole nonzero number of ms is a
   receiver clock reset (:mod:`chronofuse.integrity.clock_events`, the same rule as the batch repair): it
   is removed from this epoch on, reported as an event, and the test goes on;
2. **receiver status**: with ``receiver_ok=False`` (no fix, or a time accuracy worse than the caller's
   limit) the epoch is not tested (the GR-701W went on reporting a clock bias for 25 s after losing its
   fix); the state is ``unavailable`` and the difference chain restarts when the status returns;
3. **test**: :meth:`HodDetector.step` on the repaired bias;
4. **latch**: an alarm is *raised* at the first epoch over the threshold and stays raised until (a) the
   statistic has been at or below its threshold for ``clear_after`` consecutive tested epochs (default:
   one window, so the window holds no anomalous difference any more) and (b) the clock's frequency,
   the mean first difference over the last window ``(x(k) - x(k-n)) / (n t_s)``, is back within
   ``clear_sigma`` standard deviations of its value over the window before the one that raised the
   alarm; then it is *cleared*. The second difference sees only changes: a ramp (a frequency step)
   alarms for a window after its onset and then looks quiet while the range error grows, so (b)
   keeps it raised until the frequency returns. The standard deviation of the difference of the two
   means is that of the detector's noise model (:mod:`chronofuse.integrity.noise_model`): ``2 (2 s2 + n q1 t_s + n^3 q2 t_s^3 / 3) / (n t_s)^2``
   (white phase, white FM and random-walk FM over one window, for two independent windows). Each raise
   and clear is an event with its reason.

:class:`EpochVerdict` fields: ``t_ns`` (int), ``statistic``, ``threshold`` (NaN: no test), ``alarm`` (this
epoch over threshold), ``state``, ``events`` (tuple of str).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from chronofuse.estimation.pipeline import Pipeline
from chronofuse.integrity.clock_events import MILLISECOND_S
from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.stages import ClockRepair, DetectorStage, Latch, StatusGate, frequency_sigma

#: Epoch states of :class:`EpochVerdict`.
STATES = ("ok", "alarm", "unavailable")


@dataclass(frozen=True)
class EpochVerdict:
    """One epoch of :class:`StreamingMonitor` (module docstring)."""

    t_ns: int
    statistic: float
    threshold: float
    alarm: bool
    state: str
    events: tuple[str, ...] = ()

    def as_json(self) -> dict:
        """The ``--json-lines`` record: NaN as null."""
        def num(v: float):
            return None if math.isnan(v) else float(v)

        return {"t_ns": int(self.t_ns), "statistic": num(self.statistic), "threshold": num(self.threshold),
                "alarm": bool(self.alarm), "state": self.state, "events": list(self.events)}


def epoch_events(status: str, clock_reset_s: float, latch_event: str, training: bool, failed: bool) -> tuple[str, ...]:
    """The events of one epoch, in order: training, the receiver's status, a clock reset, a raise or clear."""
    events = []
    if training:
        events.append("training")
    elif failed:
        events.append("training failed")
    if status:
        events.append(status)
    if clock_reset_s:
        events.append(f"clock reset {round(clock_reset_s / MILLISECOND_S):+d} ms")
    if latch_event:
        events.append(latch_event)
    return tuple(events)


class StreamingMonitor:
    """Clock steering, receiver status, the HOD test and a latched alarm, one epoch at a time (module docstring):
    the stages of :mod:`chronofuse.integrity.stages` stepped for an already fitted detector.

    ``detector`` must be fitted; it is stepped in place (``reset()`` restarts everything). ``clear_after``
    (default: the detector's window) quiet tested epochs clear a raised alarm; ``tolerance_s`` is the clock
    reset tolerance. For a stream that trains its own detector, see :class:`chronofuse.integrity.watch.ClockWatch`.
    """

    def __init__(self, detector: HodDetector, *, clear_after: int | None = None, tolerance_s: float = 1e-4,
                 clear_sigma: float = 5.0):
        if not hasattr(detector, "whitener_"):
            raise RuntimeError("StreamingMonitor needs a fitted detector: call fit() first")
        self.detector = detector
        stage = DetectorStage(detector)
        stage.outlier_t_ns_, stage._outliers = np.zeros(0, dtype=np.int64), set()
        latch = Latch(detector, clear_after=clear_after, clear_sigma=clear_sigma)
        latch.sigma_freq_ = frequency_sigma(detector)
        self.pipeline = Pipeline([("status", StatusGate(None)), ("repair", ClockRepair(tolerance_s)),
                                  ("detector", stage), ("latch", latch)])
        self._stages = [s for _, s in self.pipeline.stages]
        self.reset()

    def reset(self) -> None:
        """Forget the stream: the detector's window, the clock correction and the latch."""
        self.pipeline.reset()

    def step(self, t_ns: int, clock_bias_s: float, *, receiver_ok: bool = True) -> EpochVerdict:
        """One epoch: its time (int ns), clock bias (s; NaN/None = missing) and receiver status."""
        x = math.nan if clock_bias_s is None else float(clock_bias_s)
        v = {"t_ns": t_ns, "clock_bias_s": x, "valid": receiver_ok, "training": False}
        for stage in self._stages:  # the pipeline's step, without wrapping each epoch's columns
            v.update(stage.step(v))
        status, reset, event = v["status"], v["clock_reset_s"], v["latch_event"]
        events = epoch_events(status, reset, event, False, False) if (status or reset or event) else ()
        return EpochVerdict(int(t_ns), v["statistic"], v["threshold"], v["over"], v["state"], events)


__all__ = ["STATES", "EpochVerdict", "StreamingMonitor", "epoch_events"]

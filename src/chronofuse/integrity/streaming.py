"""The streaming clock-bias monitor: one epoch in, one frozen verdict out (issue 10.5 and 10.6).

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
   means is that of the model of SPEC 4: ``2 (2 s2 + n q1 t_s + n^3 q2 t_s^3 / 3) / (n t_s)^2``
   (white phase, white FM and random-walk FM over one window, for two independent windows). Each raise
   and clear is an event with its reason.

:class:`EpochVerdict` fields: ``t_ns`` (int), ``statistic``, ``threshold`` (NaN: no test), ``alarm`` (this
epoch over threshold), ``state``, ``events`` (tuple of str).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from collections import deque

from chronofuse.integrity.clock_events import MILLISECOND_S
from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.noise_model import noise_intensities

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
                "state": self.state, "events": list(self.events)}


class StreamingMonitor:
    """Clock steering, receiver status, the HOD test and a latched alarm, one epoch at a time (module docstring).

    ``detector`` must be fitted; it is stepped in place (``reset()`` restarts everything). ``clear_after``
    (default: the detector's window) quiet tested epochs clear a raised alarm; ``tolerance_s`` is the clock
    reset tolerance.
    """

    def __init__(self, detector: HodDetector, *, clear_after: int | None = None, tolerance_s: float = 1e-4,
                 clear_sigma: float = 5.0):
        self.detector = detector
        self.clear_after = int(detector.window) if clear_after is None else int(clear_after)
        self.tolerance_s = tolerance_s
        self.clear_sigma = clear_sigma
        n, ts = int(detector.window), float(detector.interval_s)
        if all(hasattr(detector, name) for name in ("h0_", "hm2_", "sigma_rho_m_")):
            q1, q2, s2 = noise_intensities(detector.h0_, detector.hm2_, detector.sigma_rho_m_)
            q1, q2, s2 = (v * getattr(detector, "inflation_", 1.0) for v in (q1, q2, s2))
            self._sigma_freq = math.sqrt(2.0 * (2.0 * s2 + n * q1 * ts + n**3 * q2 * ts**3 / 3.0)) / (n * ts)
        else:  # a detector without a clock noise model: the latch clears on quiet epochs alone
            self._sigma_freq = math.nan
        self.reset()

    def reset(self) -> None:
        """Forget the stream: the detector's window, the clock correction and the latch."""
        self.detector.reset()
        self._raw = [math.nan, math.nan]  # the last two raw biases
        self._jump_prev = 0.0  # the reset found at the previous epoch
        self._correction = 0.0
        self._raised = False
        self._quiet = 0
        n = int(self.detector.window)
        self._history = deque([math.nan] * (3 * n + 1), maxlen=3 * n + 1)  # repaired biases, oldest first
        self._freq_ref = math.nan

    def _frequency(self, end: int) -> float:
        """Mean first difference over the window ending ``end`` epochs ago (NaN if a missing epoch is in it)."""
        n = int(self.detector.window)
        h = self._history
        last, first = h[len(h) - 1 - end], h[len(h) - 1 - end - n]
        return (last - first) / (n * float(self.detector.interval_s))

    def step(self, t_ns: int, clock_bias_s: float, *, receiver_ok: bool = True) -> EpochVerdict:
        """One epoch: its time (int ns), clock bias (s; NaN/None = missing) and receiver status."""
        x = math.nan if clock_bias_s is None else float(clock_bias_s)
        events: list[str] = []
        if not receiver_ok:
            x = math.nan
            events.append("receiver status: no valid fix")
        p1, p2 = self._raw
        self._raw = [x, p1]
        jump = 0.0
        if not math.isnan(x) and not math.isnan(p1) and not math.isnan(p2):
            d2 = x - 2.0 * p1 + p2 + self._jump_prev
            m = round(d2 / MILLISECOND_S)
            if m != 0 and abs(d2 - m * MILLISECOND_S) <= self.tolerance_s:
                jump = m * MILLISECOND_S
                self._correction += jump
                events.append(f"clock reset {m:+d} ms")
        self._jump_prev = jump
        repaired = x - self._correction
        self._history.append(repaired)
        out = self.detector.step(repaired)
        state = "unavailable"
        if out.dof > 0:
            if out.alarm:
                self._quiet = 0
                if not self._raised:
                    self._raised = True
                    self._freq_ref = self._frequency(int(self.detector.window))
                    events.append(f"raise: statistic {out.statistic:.3g} over threshold {out.threshold:.3g}")
            elif self._raised:
                self._quiet += 1
                drift = abs(self._frequency(0) - self._freq_ref)
                steady = not drift > self.clear_sigma * self._sigma_freq  # NaN (no reference): not held
                if self._quiet >= self.clear_after and steady:
                    self._raised = False
                    events.append(f"clear: {self._quiet} epochs consistent with the noise model and the frequency "
                                  "back to its value before the alarm")
            state = "alarm" if self._raised else "ok"
        elif self._raised:
            state = "alarm"  # an untested epoch does not clear a raised alarm
        return EpochVerdict(int(t_ns), float(out.statistic), float(out.threshold), bool(out.alarm), state,
                            tuple(events))


__all__ = ["STATES", "EpochVerdict", "StreamingMonitor"]

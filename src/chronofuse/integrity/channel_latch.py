"""Latched channel faults with raise and clear events, one epoch at a time.

A channel (satellite, or satellite and code) named faulty by identification
(:func:`chronofuse.integrity.identification.identify`) is *raised* at the epoch it is named and stays faulty
until it is consistent with the other channels again; then it is *cleared*, with the reason. The rule is
the one of the clock-level latch (:class:`chronofuse.integrity.streaming.StreamingMonitor`), applied to the
channel's residual against the other channels' clock (:func:`chronofuse.integrity.common_mode.channel_residuals`):

(a) its statistic has been at or below its threshold for ``clear_after`` consecutive tested epochs (default
    one window: the window holds no anomalous difference any more), and
(b) its residual, averaged over the last window, is back within ``clear_sigma`` standard deviations of its
    average over the window before the one that raised the fault. The second difference sees only
    changes: a step that persists looks quiet after one window while the channel stays off by the step
    (a ramp, by a growing amount), so (b) keeps it raised until the offset is gone. The standard deviation
    is that of the difference of two window means ``L`` epochs apart (``L``: from the reference window to
    now), the smaller of (i) the detector's noise model with the channel's fitted noise (inflation included),
    ``2 s2 / n + q1 L t_s + q2 (L t_s)^3 / 3`` (white phase noise averaged over ``n`` epochs; white FM and
    random-walk FM over ``L`` intervals, Brown & Hwang sec. 9.3), and (ii) the rms of that difference
    measured one window apart on the channel's residual over the ``3 n`` epochs before the raise, grown as
    ``sqrt(L / n)`` (a random walk, the white-FM term of the model), but not below the white-phase term
    ``2 s2 / n``. Why (ii): the fitted random-walk FM of a residual is loosely determined by a short
    training; on the real Trimble stations the model alone, extrapolated over the 15-25 min of a fault,
    allowed 40 to 220 ns at 5 sigma, and 30 ns and 100 ns steps still in place were cleared, while the
    measured spread of those residuals is a few ns.

An untested epoch neither raises nor clears. After a clear, the channel is raised again at its next alarm.
:class:`ChannelLatch` is the streaming form (one channel, one epoch); :func:`latch_channels` runs one latch
per channel over a batch result, through the same :meth:`ChannelLatch.step`.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from chronofuse.integrity.noise_model import noise_intensities


@dataclass(frozen=True)
class ChannelEvent:
    """A raise or clear of one channel: ``epoch`` index, ``channel`` name, ``kind`` ("raise"/"clear"), ``reason``."""

    epoch: int
    channel: str
    kind: str
    reason: str


class ChannelLatch:
    """The fault latch of one channel (module docstring). ``detector``: the channel's fitted HodDetector."""

    def __init__(self, detector, *, clear_after: int | None = None, clear_sigma: float = 5.0):
        self.window = int(detector.window)
        self.interval_s = float(detector.interval_s)
        self.clear_after = self.window if clear_after is None else int(clear_after)
        self.clear_sigma = float(clear_sigma)
        scale = getattr(detector, "inflation_", 1.0)
        self._q = tuple(v * scale for v in noise_intensities(detector.h0_, detector.hm2_, detector.sigma_rho_m_))
        self.faulty = False
        self._quiet = 0
        self._history: deque = deque([math.nan] * (4 * self.window + 1), maxlen=4 * self.window + 1)
        self._ref = math.nan
        self._spread = math.nan
        self._raised_at = -1

    def _level(self, end: int) -> float:
        """Mean residual over the window ending ``end`` epochs ago (NaN if an epoch in it is missing)."""
        h = self._history
        values = [h[len(h) - 1 - end - i] for i in range(self.window)]
        return math.fsum(values) / self.window

    def _model_sigma(self, epochs_apart: int) -> float:
        q1, q2, s2 = self._q
        span = epochs_apart * self.interval_s
        return math.sqrt(2.0 * s2 / self.window + q1 * span + q2 * span**3 / 3.0)

    def _measured_spread(self) -> float:
        """The rms of a window mean minus the one a window earlier, over the ``3 n`` epochs before now (NaN
        when fewer than ``n/2 + 1`` such pairs are complete)."""
        diffs = [self._level(end) - self._level(end + self.window) for end in range(self.window, 2 * self.window + 1)]
        diffs = [d for d in diffs if math.isfinite(d)]
        if len(diffs) < self.window // 2 + 1:
            return math.nan
        return math.sqrt(math.fsum(d * d for d in diffs) / len(diffs))

    def _sigma(self, epochs_apart: int) -> float:
        """Standard deviation of the difference of two window means ``epochs_apart`` apart (docstring, (b))."""
        model = self._model_sigma(epochs_apart)
        if not math.isfinite(self._spread):
            return model
        grown = self._spread * math.sqrt(epochs_apart / self.window)
        return max(min(model, grown), math.sqrt(2.0 * self._q[2] / self.window))

    def step(self, epoch: int, residual_s: float, *, tested: bool, alarm: bool, named: bool = False) -> str | None:
        """One epoch of the channel: its residual (s; NaN = missing), whether it was tested and alarmed, and
        whether identification names it here. Returns the event (``"raise: ..."``/``"clear: ..."``) or None;
        ``faulty`` is the latched state after this epoch."""
        self._history.append(float(residual_s))
        if not self.faulty:
            if named or (self._raised_at >= 0 and tested and alarm):
                self.faulty, self._quiet, self._raised_at = True, 0, epoch
                self._ref = self._level(self.window)
                self._spread = self._measured_spread()
                return ("raise: named faulty (its statistic over its threshold, the largest among the channels)"
                        if named else "raise: over its threshold again after a clear")
            return None
        if not tested:
            return None
        if alarm:
            self._quiet = 0
            return None
        self._quiet += 1
        offset = abs(self._level(0) - self._ref)
        sigma = self._sigma(epoch - self._raised_at + self.window)
        back = offset <= self.clear_sigma * sigma  # NaN (a missing epoch in either window): not back
        if self._quiet >= self.clear_after and back:
            self.faulty = False
            return (f"clear: {self._quiet} epochs within its threshold and its offset from the other channels back "
                    f"to {offset * 1e9:.3g} ns of its value before the fault ({self.clear_sigma:g} sigma = "
                    f"{self.clear_sigma * sigma * 1e9:.3g} ns)")
        return None


def latch_channels(result, *, clear_after: int | None = None, clear_sigma: float = 5.0):
    """Raise and clear every channel of an :class:`~chronofuse.integrity.identification.IdentificationResult`.

    Returns ``(faulty (epochs, sats) bool, events)``: the latched state per epoch and channel, and the
    :class:`ChannelEvent` list in time order. Each channel runs its own :class:`ChannelLatch` over the
    epochs, raised at the epoch identification named it (``blamed_at``).
    """
    epochs = result.t_s.size
    sats = result.satellites
    faulty = np.zeros((epochs, len(sats)), dtype=bool)
    events: list[ChannelEvent] = []
    for j, name in enumerate(sats):
        named_at = int(result.blamed_at[j]) if len(result.blamed_at) else -1
        if named_at < 0:
            continue
        latch = ChannelLatch(result.detectors[j], clear_after=clear_after, clear_sigma=clear_sigma)
        res = result.results[j]
        for k in range(epochs):
            event = latch.step(k, result.residual_s[k, j], tested=bool(res.dof[k] > 0), alarm=bool(res.alarm[k]),
                               named=k == named_at)
            faulty[k, j] = latch.faulty
            if event:
                kind, reason = event.split(": ", 1)
                events.append(ChannelEvent(k, name, kind, reason))
    events.sort(key=lambda e: (e.epoch, e.channel))
    return faulty, events


__all__ = ["ChannelEvent", "ChannelLatch", "latch_channels"]

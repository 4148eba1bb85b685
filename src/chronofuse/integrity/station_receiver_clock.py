"""Detection mode on the receiver clock a station's channels share: a fault on every satellite at once.

A fault that moves every channel together (the receiver's oscillator or its time-transfer chain) leaves
each channel's residual against the others untouched, so identification cannot see it. The common clock
``c0(k)`` of :class:`chronofuse.integrity.station_clock.CodeClock` (the receiver clock bias, named satellites
left out) is tested on its own, as detection mode tests one clock bias:

1. the receiver's whole-millisecond clock steering is repaired causally
   (:func:`chronofuse.integrity.clock_events.repair_clock_steering`) and each step is a clock event, not a fault;
2. its second difference in metres ``d(k) = c (c0(k) - 2 c0(k-1) + c0(k-2))`` is modelled as a channel's is
   (:func:`chronofuse.integrity.station_noise.fit_code_noise` on the training stretch: the three-parameter
   spectrum and the heavy tail with the margin its training length deserves; a receiver clock has no
   elevation, so one band); the Gaussian model of the clock-bias detector does not fit real receiver clocks
   (on AJAC's Leica GR50 it alarmed many times a day at 1e-4);
3. every full window after training is tested (:mod:`chronofuse.integrity.window_tests`) against the
   trained model and against the clock's recent noise, and the larger tail probability is kept: a receiver
   clock's noise drifts through the day (the median over the satellites in view is noisier when fewer are
   high), so the window scale's inverse-gamma prior is updated with the squared innovations of the
   ``reference`` epochs that end where the window starts (the conjugate update, as a satellite arc's own
   check does), a predictive F with ``nu + m`` degrees of freedom. A fault in the window is not in its
   reference, so it stands out against both;
4. an alarm is raised when a window fails at ``alpha`` (the share of the station's false-alarm probability
   reserved for it) and cleared after ``clear_after`` consecutive windows pass.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.integrity.clock_events import repair_clock_steering
from chronofuse.integrity.station_noise import CodeNoise, fit_code_noise
from chronofuse.integrity.window_tests import WINDOW_TESTS, f_tail

__all__ = ["ReceiverClockVerdict", "receiver_clock_test"]


@dataclass(frozen=True)
class ReceiverClockVerdict:
    """Per epoch: ``tested``, ``p``, ``alarm`` (latched) (epochs,); ``raised`` (epoch indices of each raise);
    ``steps`` (epoch indices of repaired millisecond steps); ``noise`` (None: training failed, ``reason``)."""

    tested: np.ndarray
    p: np.ndarray
    alarm: np.ndarray
    raised: np.ndarray
    steps: np.ndarray
    noise: CodeNoise | None
    reason: str = ""


def _recent_p(stat, innovation, last, n, noise: CodeNoise, window: int, test: str, reference: int) -> np.ndarray:
    """The tail probability of each window against the clock's recent noise (module docstring, step 3)."""
    e2 = np.zeros(n)
    seen = np.zeros(n)
    e2[last] = innovation**2
    seen[last] = 1.0
    cs, cn = np.r_[0.0, np.cumsum(e2)], np.r_[0.0, np.cumsum(seen)]
    hi = np.maximum(last - window, 0)  # the reference ends before the window starts
    lo = np.maximum(hi - reference, 0)
    m = cn[hi] - cn[lo]
    nu = noise.tail_dof if np.isfinite(noise.tail_dof) else 1e6
    post = (nu * noise.scale + (cs[hi] - cs[lo])) / (nu + m)
    if test == "chi-square":
        return f_tail(stat / (window * post), window, nu + m)
    return np.minimum(1.0, 3 * window * f_tail(stat / post, 1, nu + m))


def receiver_clock_test(clock_s: np.ndarray, training: np.ndarray, *, window: int, alpha: float,
                        test: str = "chi-square", confidence: float = 0.9, clear_after: int | None = None,
                        reference: int = 720) -> ReceiverClockVerdict:
    """The receiver clock ``clock_s`` (epochs,) (NaN: none) tested after its ``training`` epochs (module
    docstring) at ``alpha`` per epoch."""
    x = np.asarray(clock_s, dtype=np.float64)
    training = np.asarray(training, dtype=bool)
    n = x.size
    steering = repair_clock_steering(x)
    c0 = steering.repaired_s
    d = np.full(n, np.nan)
    d[2:] = SPEED_OF_LIGHT_M_PER_S * (c0[2:] - 2.0 * c0[1:-1] + c0[:-2])
    none = np.zeros(n, dtype=bool)
    try:
        noise = fit_code_noise("receiver clock", np.where(training, d, np.nan)[None, :], np.full((1, n), 90.0),
                               window=window, confidence=confidence)
    except ValueError as err:
        return ReceiverClockVerdict(none, np.full(n, np.nan), none, np.zeros(0, np.intp),
                                    np.asarray(steering.event_epochs, np.intp), None, str(err))
    p = np.full(n, np.nan)
    if n >= window:
        win = sliding_window_view(d, window)
        full = np.isfinite(win).all(axis=1)
        last = np.flatnonzero(full) + window - 1
        whitener = noise.whiteners[90]
        w = win[full] @ whitener.T
        stat, pv = WINDOW_TESTS[test](w, np.broadcast_to(whitener, (w.shape[0], window, window)), noise.scale,
                                      noise.tail_dof)
        p[last] = np.maximum(pv, _recent_p(stat, w[:, -1], last, n, noise, window, test, reference))
    tested = np.isfinite(p) & ~training
    alarm = np.zeros(n, dtype=bool)
    raised = []
    quiet_needed = window if clear_after is None else int(clear_after)
    on, quiet = False, 0
    for k in range(n):
        if not tested[k]:
            alarm[k] = on
            continue
        if p[k] < alpha:
            if not on:
                raised.append(k)
            on, quiet = True, 0
        elif on:
            quiet += 1
            if quiet >= quiet_needed:
                on = False
        alarm[k] = on
    return ReceiverClockVerdict(tested, p, alarm, np.asarray(raised, np.intp),
                                np.asarray(steering.event_epochs, np.intp), noise)

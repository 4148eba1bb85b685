"""The stages of clock-bias integrity (:mod:`chronofuse.estimation.pipeline`): status gate, clock repair,
detector and latch. ``detect FILE``, ``detect -``, the monitor and the disciplined oscillator's integrity
all run these four, in this order (:func:`chronofuse.integrity.watch.detection_pipeline`):

1. :class:`StatusGate` (:mod:`chronofuse.integrity.receiver_status`): an epoch whose receiver reported no
   fix (``valid`` False) or a time accuracy ``time_acc_s`` over the limit is not tested: its bias becomes
   missing and ``status`` says why;
2. :class:`ClockRepair` (:mod:`chronofuse.integrity.clock_events`): a second difference within a tolerance
   of a whole nonzero number of milliseconds is a receiver clock reset, removed from that epoch on
   (``clock_reset_s``: its size at the epoch, 0 elsewhere);
3. :class:`DetectorStage`: any clock-bias detector with the estimator interface (``fit``/``reset``/
   ``step``/``run`` giving ``statistic``, ``threshold``, ``dof`` and ``alarm``; the HOD chi-square test by
   default), on the repaired bias with the training stretch's outliers left out;
4. :class:`Latch`: an alarm is *raised* at the first tested epoch over the threshold and stays raised until
   the statistic has been quiet for ``clear_after`` tested epochs and the clock's frequency (the mean first
   difference over the last window) is back within ``clear_sigma`` standard deviations of its value over the
   window before the raise (the rule and its noise formula: :mod:`chronofuse.integrity.streaming`); epochs
   of the training stretch (column ``training``) are never tested.

Each stage's ``step`` and ``run`` share one core, so the pipeline streamed equals the pipeline in batch.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from chronofuse.integrity.clock_events import MILLISECOND_S, repair_clock_steering
from chronofuse.integrity.noise_model import noise_intensities
from chronofuse.integrity.receiver_status import DEFAULT_MAX_TIME_ACC_S, NO_FIX, status_reasons

__all__ = ["StatusGate", "ClockRepair", "DetectorStage", "Latch", "LATCH_STATES"]

#: Epoch states the latch gives.
LATCH_STATES = ("ok", "alarm", "unavailable")


class StatusGate:
    """Epochs the receiver's own status rules out (module docstring, step 1)."""

    needs: ClassVar[tuple[str, ...]] = ("clock_bias_s", "valid")
    gives: ClassVar[tuple[str, ...]] = ("status", "gated_bias_s")

    def __init__(self, max_time_acc_s: float | None = DEFAULT_MAX_TIME_ACC_S):
        self.max_time_acc_s = max_time_acc_s

    def fit(self, frame=None) -> StatusGate:
        return self

    def reset(self) -> None:
        pass

    def _tacc_reason(self) -> str:
        return f"receiver status: time accuracy over {self.max_time_acc_s * 1e9:g} ns"

    def step(self, epoch) -> dict:
        reason = ""
        tacc = epoch.get("time_acc_s")
        if self.max_time_acc_s is not None and tacc is not None and float(tacc) > self.max_time_acc_s:
            reason = self._tacc_reason()
        if not bool(epoch["valid"]):
            reason = NO_FIX
        return {"status": reason, "gated_bias_s": math.nan if reason else float(epoch["clock_bias_s"])}

    def run(self, frame) -> dict:
        bias = np.asarray(frame["clock_bias_s"], dtype=np.float64)
        reasons = status_reasons(frame["valid"], frame.get("time_acc_s"), self.max_time_acc_s, bias.size)
        return {"status": reasons, "gated_bias_s": np.where(reasons != "", np.nan, bias)}


class ClockRepair:
    """The receiver's millisecond clock resets found and removed, causally (module docstring, step 2)."""

    needs: ClassVar[tuple[str, ...]] = ("gated_bias_s",)
    gives: ClassVar[tuple[str, ...]] = ("repaired_bias_s", "clock_reset_s")

    def __init__(self, tolerance_s: float = 1e-4, unit_s: float = MILLISECOND_S):
        self.tolerance_s = tolerance_s
        self.unit_s = unit_s
        self.reset()

    def fit(self, frame=None) -> ClockRepair:
        self.reset()
        return self

    def reset(self) -> None:
        self._raw = [math.nan, math.nan]
        self._jump_prev = 0.0
        self._correction = 0.0

    def step(self, epoch) -> dict:
        x = float(epoch["gated_bias_s"])
        p1, p2 = self._raw
        self._raw = [x, p1]
        jump = 0.0
        if not (math.isnan(x) or math.isnan(p1) or math.isnan(p2)):
            d2 = x - 2.0 * p1 + p2 + self._jump_prev  # the same sum, in the same order, as the batch repair
            m = round(d2 / self.unit_s)
            if m != 0 and abs(d2 - m * self.unit_s) <= self.tolerance_s:
                jump = m * self.unit_s
                self._correction += jump
        self._jump_prev = jump
        return {"repaired_bias_s": x - self._correction, "clock_reset_s": jump}

    def run(self, frame) -> dict:
        steering = repair_clock_steering(frame["gated_bias_s"], tolerance_s=self.tolerance_s, unit_s=self.unit_s)
        jump = np.zeros(steering.repaired_s.shape)
        jump[steering.event_epochs] = steering.event_size_s
        return {"repaired_bias_s": steering.repaired_s, "clock_reset_s": jump}


class DetectorStage:
    """A clock-bias detector on the repaired bias (module docstring, step 3).

    ``fit(frame)`` fits the detector on the frame's ``repaired_bias_s`` (its model alone when ``frame`` is
    None) and remembers the time tags of the training epochs the detector left out as outliers
    (``training_outliers_``, when it has them): those epochs are missing for the test too, in batch and
    streaming alike. ``detector_input_s`` is the bias the detector saw.
    """

    needs: ClassVar[tuple[str, ...]] = ("t_ns", "repaired_bias_s")
    gives: ClassVar[tuple[str, ...]] = ("detector_input_s", "statistic", "threshold", "dof", "over")

    def __init__(self, detector):
        self.detector = detector

    def fit(self, frame=None) -> DetectorStage:
        if frame is None:
            self.detector.fit()
            self.outlier_t_ns_ = np.zeros(0, dtype=np.int64)
        else:
            self.detector.fit(frame["repaired_bias_s"])
            left_out = np.asarray(getattr(self.detector, "training_outliers_", np.zeros(0, dtype=bool)))
            t = np.asarray(frame["t_ns"])
            self.outlier_t_ns_ = t[left_out] if left_out.shape == t.shape else np.zeros(0, dtype=np.int64)
        self._outliers = set(self.outlier_t_ns_.tolist())
        return self

    def reset(self) -> None:
        self.detector.reset()

    def step(self, epoch) -> dict:
        x = float(epoch["repaired_bias_s"])
        if self._outliers and int(epoch["t_ns"]) in self._outliers:
            x = math.nan
        out = self.detector.step(x)  # a StepOutput: float statistic and threshold, int dof, bool alarm
        return {"detector_input_s": x, "statistic": out.statistic, "threshold": out.threshold, "dof": out.dof,
                "over": out.alarm}

    def run(self, frame) -> dict:
        x = np.asarray(frame["repaired_bias_s"], dtype=np.float64)
        x = np.where(np.isin(frame["t_ns"], self.outlier_t_ns_), np.nan, x)
        res = self.detector.run(x)
        return {"detector_input_s": x, "statistic": np.asarray(res.statistic), "threshold": np.asarray(res.threshold),
                "dof": np.asarray(res.dof), "over": np.asarray(res.alarm)}


def frequency_sigma(detector, window: int | None = None) -> float:
    """Standard deviation (s/s) of the difference of two window means of the first difference under the
    detector's noise model: ``sqrt(2 (2 s2 + n q1 t_s + n^3 q2 t_s^3 / 3)) / (n t_s)`` (white phase, white FM
    and random-walk FM over one window, two independent windows; :mod:`chronofuse.integrity.streaming`);
    NaN for a detector without a fitted noise model (the latch then clears on a quiet statistic alone)."""
    try:
        q1, q2, s2 = noise_intensities(detector.h0_, detector.hm2_, detector.sigma_rho_m_)
    except AttributeError:
        return math.nan
    q1, q2, s2 = (v * getattr(detector, "inflation_", 1.0) for v in (q1, q2, s2))
    n, ts = int(window if window is not None else detector.window), float(detector.interval_s)
    return math.sqrt(2.0 * (2.0 * s2 + n * q1 * ts + n**3 * q2 * ts**3 / 3.0)) / (n * ts)


class Latch:
    """Raised alarms that stay raised while the anomaly lasts (module docstring, step 4).

    ``detector``: the detector the latch follows (its interval and fitted noise model set the frequency
    test); ``window``: the frequency test's window (default: the detector's, else 20 epochs); ``clear_after``
    quiet tested epochs (default: one window) and ``clear_sigma``.
    """

    needs: ClassVar[tuple[str, ...]] = ("over", "dof", "statistic", "threshold", "detector_input_s", "training")
    gives: ClassVar[tuple[str, ...]] = ("state", "latch_event")

    def __init__(self, detector, *, window: int | None = None, clear_after: int | None = None,
                 clear_sigma: float = 5.0):
        self.detector = detector
        self.window = window
        self.clear_after = clear_after
        self.clear_sigma = clear_sigma
        self.reset()

    @property
    def _n(self) -> int:
        return int(self.window if self.window is not None else getattr(self.detector, "window", 20))

    def fit(self, frame=None) -> Latch:
        self.sigma_freq_ = frequency_sigma(self.detector, self._n)
        self.reset()
        return self

    def reset(self) -> None:
        n = self._n
        self._ring = [math.nan] * (2 * n + 1)  # the last 2n + 1 detector inputs, NaN before the first
        self._pos = 0
        self._state = [False, 0, math.nan]  # raised, quiet epochs, frequency before the raise

    def _advance(self, st: list, over: bool, dof: int, statistic: float, threshold: float, training: bool,
                 freq_now: float, freq_before: float) -> tuple[str, str]:
        """One epoch of the latch on its state ``st`` (changed in place): ``(state, event)``."""
        if training:
            return "unavailable", ""
        raised, quiet, ref = st
        event = ""
        if dof > 0:
            if over:
                quiet = 0
                if not raised:
                    raised, ref = True, freq_before
                    event = f"raise: statistic {statistic:.3g} over threshold {threshold:.3g}"
            elif raised:
                quiet += 1
                clear_after = self._n if self.clear_after is None else int(self.clear_after)
                steady = not abs(freq_now - ref) > self.clear_sigma * self.sigma_freq_  # NaN: not held
                if quiet >= clear_after and steady:
                    raised = False
                    event = (f"clear: {quiet} epochs consistent with the noise model and the frequency back to its "
                             "value before the alarm")
            state = "alarm" if raised else "ok"
        else:
            state = "alarm" if raised else "unavailable"  # an untested epoch does not clear a raised alarm
        st[:] = [raised, quiet, ref]
        return state, event

    def step(self, epoch) -> dict:
        ring, n = self._ring, self._n
        size = 2 * n + 1
        k = self._pos
        ring[k] = float(epoch["detector_input_s"])
        self._pos = (k + 1) % size
        span = n * float(self.detector.interval_s)
        mid, old = ring[k - n], ring[k - 2 * n]  # negative indices wrap the ring
        freq_now = (ring[k] - mid) / span
        freq_before = (mid - old) / span
        state, event = self._advance(self._state, epoch["over"], epoch["dof"], epoch["statistic"], epoch["threshold"],
                                     epoch["training"], freq_now, freq_before)
        return {"state": state, "latch_event": event}

    def run(self, frame) -> dict:
        x = np.asarray(frame["detector_input_s"], dtype=np.float64)
        steps = x.size
        n, ts = self._n, float(self.detector.interval_s)
        padded = np.concatenate((np.full(2 * n, np.nan), x))  # the history starts full of NaN, as in step
        now = (padded[2 * n :] - padded[n : n + steps]) / (n * ts)
        before = (padded[n : n + steps] - padded[:steps]) / (n * ts)
        st = [False, 0, math.nan]
        over, dof, stat, thr = (np.asarray(frame[c]) for c in ("over", "dof", "statistic", "threshold"))
        training = np.asarray(frame["training"], dtype=bool)
        states = np.empty(steps, dtype=object)
        events = np.empty(steps, dtype=object)
        for k in range(steps):
            states[k], events[k] = self._advance(st, bool(over[k]), int(dof[k]), float(stat[k]), float(thr[k]),
                                                 bool(training[k]), float(now[k]), float(before[k]))
        return {"state": states, "latch_event": events}

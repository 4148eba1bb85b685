"""The whole GNSSDO chain in one library call: qualify -> integrity -> fuse -> close the loop -> states.

:func:`discipline_run` takes the free-running oscillator's phase (trials, steps) and what the receivers
measured (their 1PPS errors and their epoch reports) and returns the disciplined 1PPS with everything
a report needs. Every stage but the loop depends only on the receivers, not on the oscillator: the
offset against receiver ``j`` is ``z_j = x - e_j``, so the usable mask, the integrity alarms and the
fusion weights (which see only differences between receivers, where ``x`` cancels) are computed first
over the whole batch, and the loop then closes on the fused reference ``e_f = sum_j w_j e_j``. That is
exactly what a streaming GPSDO computes second by second, in another order.

qErr settings (u-blox UBX-TIM-TP describes the NEXT pulse; users report both signs): the corrected
1PPS error is ``e = pps + qerr_sign * qerr[k - lag]`` with ``qerr_lag = 0`` when the message has
already been re-aligned with the pulse it describes (what ``models.receiver`` gives) and 1 when
messages are logged as received (each one describing the pulse that follows it). A wrong setting
leaves the sawtooth in (tested: the residual rms against the sawtooth-free truth).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from chronofuse.discipline.counter import MultiPhaseCounter
from chronofuse.discipline.fusion import FusionRun, InverseVarianceFusion
from chronofuse.discipline.loop import LoopRun, close_loop
from chronofuse.discipline.plausibility import DragMonitor
from chronofuse.discipline.qualification import Qualification, usable_epochs
from chronofuse.discipline.servo import Servo, freeze
from chronofuse.discipline.states import StateConfig, StateRun, run_states
from chronofuse.epochs import ReceiverEpochs
from chronofuse.validation import check_array, check_choice, check_scalar

__all__ = ["ChainConfig", "GnssdoRun", "corrected_pps_error", "integrity_alarms", "discipline_run"]


@dataclass(frozen=True)
class ChainConfig:
    """Settings of the chain around the servo.

    qualification : the usability test (GDOP threshold etc.).
    fusion : ``"fusion"`` (inverse-variance) or ``"selection"`` (best source).
    states : lock threshold and hold time.
    qerr_sign : +1 (u-blox: add qErr to the counter's reading) or -1.
    qerr_lag : 0 (qErr aligned with its pulse) or 1 (logged a pulse early: TIM-TP describes the next pulse).
    integrity_pfa : false-alarm probability per epoch of the clock-bias HOD detector (None: off).
    integrity_train_s : seconds at the start used to fit the detector's noise model.
    alarm_hold_s : a receiver stays excluded this long after its last alarm.
    counter : measure offsets with this multi-phase counter (None: exact).
    receiver_monitor, reference_monitor : the oscillator's plausibility test
        (:class:`~chronofuse.discipline.plausibility.DragMonitor`) of each receiver (a refused one is excluded
        from fusion and comes back with its weight earned anew) and of the fused reference (refused: the loop
        holds over); None: off.
    fast : compiled kernels for fusion and states (False: their numpy twins; the servo has its own flag).
    """

    qualification: Qualification = field(default_factory=Qualification)
    fusion: str = "fusion"
    states: StateConfig = field(default_factory=StateConfig)
    qerr_sign: int = 1
    qerr_lag: int = 0
    integrity_pfa: float | None = None
    integrity_train_s: float = 600.0
    alarm_hold_s: float = 600.0
    counter: MultiPhaseCounter | None = None
    fast: bool = True
    receiver_monitor: DragMonitor | None = None
    reference_monitor: DragMonitor | None = None

    def __post_init__(self):
        check_choice(self.fusion, "fusion", ("fusion", "selection"))
        check_choice(self.qerr_sign, "qerr_sign", (1, -1))
        check_choice(self.qerr_lag, "qerr_lag", (0, 1))
        if self.integrity_pfa is not None:
            check_scalar(self.integrity_pfa, "integrity_pfa", min_val=0.0, max_val=1.0, include_min=False,
                         include_max=False)
        check_scalar(self.integrity_train_s, "integrity_train_s", min_val=3.0)
        check_scalar(self.alarm_hold_s, "alarm_hold_s", min_val=0.0)


@dataclass(frozen=True)
class GnssdoRun:
    """The result of :func:`discipline_run`; arrays read-only.

    ``phase_s`` (trials, steps): time error of the disciplined 1PPS; ``reference_error_s``: the fused
    reference's error ``e_f`` the loop used (NaN when none or refused); ``usable`` (trials, receivers, steps)
    after qualification, integrity exclusion and the plausibility test; ``alarm`` (trials, receivers, steps):
    integrity alarms; ``implausible`` (trials, steps): the reference refused by the oscillator's prediction
    (the fused one, or every offered receiver); ``loop``, ``fusion`` and ``states``: each stage's own result.
    """

    phase_s: np.ndarray
    reference_error_s: np.ndarray
    usable: np.ndarray
    alarm: np.ndarray
    loop: LoopRun
    fusion: FusionRun
    states: StateRun
    interval_s: float
    implausible: np.ndarray | None = None

    def __post_init__(self):
        freeze(self)


def corrected_pps_error(pps_error_s, qerr_s, sign: int = 1, lag: int = 0) -> np.ndarray:
    """``pps + sign * qerr`` shifted by ``lag`` pulses along the last axis (see the module docstring)."""
    pps = np.asarray(pps_error_s, dtype=np.float64)
    q = np.asarray(qerr_s, dtype=np.float64)
    if lag:
        q = np.concatenate([np.full(q.shape[:-1] + (lag,), np.nan), q[..., :-lag]], axis=-1)
    return pps + sign * q


def integrity_alarms(clock_bias_s, interval_s: float, pfa: float, train_s: float, hold_s: float) -> np.ndarray:
    """Per-receiver exclusion mask from the clock-bias HOD detector (``chronofuse.integrity``).

    ``clock_bias_s`` (trials, receivers, steps). Each receiver's detector is fitted on its first
    ``train_s`` seconds (Whittle fit, assumed anomaly-free), then run over the record; an alarm
    excludes the receiver from that second until ``hold_s`` after its last alarm.
    """
    from chronofuse.integrity.detector import HodDetector

    bias = check_array(clock_bias_s, "clock_bias_s", ndim=3, allow_nan=True)
    trials, receivers, steps = bias.shape
    n_train = int(round(train_s / interval_s))
    hold = int(round(hold_s / interval_s))
    excluded = np.zeros(bias.shape, dtype=bool)
    for i in range(trials):
        for j in range(receivers):
            train = bias[i, j, :n_train]
            if np.isfinite(train).sum() < 30:
                continue
            det = HodDetector(interval_s=interval_s, pfa=pfa).fit(train)
            alarm = det.run(bias[i, j]).alarm
            if alarm.any():
                last = np.where(alarm, np.arange(steps), -(hold + 1))
                last = np.maximum.accumulate(last)
                excluded[i, j] = np.arange(steps) - last <= hold
    return excluded


def discipline_run(servo: Servo, free_phase_s, pps_error_s, epochs: ReceiverEpochs, config: ChainConfig = ChainConfig(),
                   *, seed=None) -> GnssdoRun:
    """Discipline ``free_phase_s`` (trials, steps) with ``servo`` to the receivers of ``epochs``.

    ``pps_error_s`` (trials, receivers, steps): each receiver's raw 1PPS edge error (s; NaN without a
    pulse), corrected here with the epochs' qErr per ``config``. The servo's interval is the epoch step.
    """
    free = check_array(free_phase_s, "free_phase_s", ndim=2)
    pps = check_array(pps_error_s, "pps_error_s", ndim=3, allow_nan=True)
    if not isinstance(epochs, ReceiverEpochs):
        raise TypeError(f"epochs == {epochs!r}, must be a ReceiverEpochs")
    if pps.shape != epochs.shape or free.shape != (pps.shape[0], pps.shape[2]):
        raise ValueError(f"shapes disagree: free_phase_s {free.shape}, pps_error_s {pps.shape}, epochs {epochs.shape}")
    dt = float(servo.interval_s)
    e = corrected_pps_error(pps, epochs.qerr_s, config.qerr_sign, config.qerr_lag)
    usable = usable_epochs(epochs, config.qualification, np.isfinite(e))
    if config.integrity_pfa is not None:
        alarm = integrity_alarms(epochs.clock_bias_s, dt, config.integrity_pfa, config.integrity_train_s,
                                 config.alarm_hold_s)
    else:
        alarm = np.zeros(usable.shape, dtype=bool)
    qualified = usable
    usable = qualified & ~alarm
    offered = usable
    if config.receiver_monitor is not None:  # y_j = x_free - e_j: what z_j - c gives the GPSDO
        # The monitor watches every qualified receiver, integrity-excluded or not, so that one returning from an
        # integrity exclusion is judged on its whole record.
        check = config.receiver_monitor.run(free[:, None, :] - e, qualified, fast=config.fast)
        usable = usable & check.plausible
    # A receiver back from an integrity or plausibility exclusion earns its weight anew.
    held_out = qualified & ~usable
    fresh = usable & np.concatenate([np.zeros(held_out.shape[:-1] + (1,), bool), held_out[..., :-1]], axis=-1)
    fusion = InverseVarianceFusion(config.fusion, interval_s=dt, fast=config.fast).run(np.where(usable, -e, np.nan),
                                                                                       usable, fresh)
    ref = -fusion.offset_s  # e_f: fused offset is x - e_f with x = 0 here
    implausible = offered.any(axis=1) & ~usable.any(axis=1)  # every offered receiver refused
    if config.reference_monitor is not None:
        have = np.isfinite(ref)
        check = config.reference_monitor.run((free - ref)[:, None, :], have[:, None, :], fast=config.fast)
        refused = have & ~check.plausible[:, 0]
        ref = np.where(refused, np.nan, ref)
        implausible = implausible | refused
    loop = close_loop(servo, free, ref, counter=config.counter, seed=seed)
    any_usable = np.isfinite(ref)
    all_alarmed = alarm.any(axis=1) & ~(usable.any(axis=1)) & ~implausible
    states = run_states(any_usable, loop.offset_s, config.states, alarm=all_alarmed, near_rail=loop.near_rail,
                        implausible=implausible, freq_adj=loop.freq_adj, fast=config.fast)
    return GnssdoRun(loop.phase_s, ref, usable, alarm, loop, fusion, states, dt, implausible)

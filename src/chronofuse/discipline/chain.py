"""The whole GNSSDO chain in one library call: qualify -> integrity -> fuse -> close the loop -> states,
the batch run of the pipeline of :mod:`chronofuse.discipline.stages`.

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
from chronofuse.discipline.fusion import FusionRun
from chronofuse.discipline.loop import LoopRun
from chronofuse.discipline.plausibility import DragMonitor
from chronofuse.discipline.qualification import Qualification
from chronofuse.discipline.servo import Servo, freeze
from chronofuse.discipline.stages import IntegrityStage, corrected_pps_error, gnssdo_pipeline
from chronofuse.discipline.states import StateConfig, StateRun
from chronofuse.epochs import ReceiverEpochs
from chronofuse.estimation.pipeline import Pipeline
from chronofuse.integrity.watch import DetectionSettings
from chronofuse.validation import check_array, check_choice, check_scalar

__all__ = ["ChainConfig", "GnssdoRun", "corrected_pps_error", "integrity_alarms", "discipline_run", "discipline_runs", "gnssdo_frame"]


@dataclass(frozen=True)
class ChainConfig:
    """Settings of the chain around the servo.

    - ``qualification``: the usability test (GDOP threshold etc.).
    - ``fusion``: ``"fusion"`` (inverse-variance) or ``"selection"`` (best source).
    - ``states``: lock threshold and hold time.
    - ``qerr_sign``: +1 (u-blox: add qErr to the counter's reading) or -1.
    - ``qerr_lag``: 0 (qErr aligned with its pulse) or 1 (logged a pulse early: TIM-TP describes the next pulse).
    - ``integrity_pfa``: false-alarm probability per epoch of the clock-bias HOD detector (None: off).
    - ``integrity_train_s``: seconds at the start used to fit the detector's noise model.
    - ``alarm_hold_s``: a receiver stays excluded this long after its last alarm.
    - ``counter``: measure offsets with this multi-phase counter (None: exact).
    - ``fast``: compiled kernels for fusion and states (False: their numpy twins; the servo has its own flag).
    - ``receiver_monitor``, ``reference_monitor``: the oscillator's plausibility test
      (:class:`~chronofuse.discipline.plausibility.DragMonitor`) of each receiver (a refused one is excluded
      from fusion and comes back with its weight earned anew) and of the fused reference (refused: the loop
      holds over); None: off.
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
    reference's error ``e_f`` the loop used (NaN when none, or refused as implausible); ``usable`` (trials,
    receivers, steps) after qualification, integrity exclusion and the plausibility test; ``alarm`` (trials,
    receivers, steps): integrity exclusions; ``implausible`` (trials, steps): the reference refused by the
    oscillator's prediction (the fused one, or every offered receiver); ``loop``, ``fusion`` and ``states``:
    each stage's own result; ``leap``: the UTC label stage's columns (``utc_label_s``, ``utc_leap_s``,
    ``leap_second``, ``leap_dissent``; :mod:`.utc_stage`).
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
    leap: dict | None = None

    def __post_init__(self):
        freeze(self)


def integrity_alarms(clock_bias_s, interval_s: float, pfa: float, train_s: float, hold_s: float) -> np.ndarray:
    """Per-receiver exclusion mask from the clock-bias detection pipeline (:mod:`chronofuse.integrity.watch`).

    ``clock_bias_s`` (trials, receivers, steps). Each receiver's clock runs through the status gate, the
    millisecond repair, the HOD detector fitted on its first ``train_s`` seconds and the latch; a receiver is
    excluded while its alarm is raised and ``hold_s`` after it clears (:class:`~.stages.IntegrityStage`).
    """
    bias = check_array(clock_bias_s, "clock_bias_s", ndim=3, allow_nan=True)
    interval_ns = int(round(interval_s * 1e9))
    stage = IntegrityStage(DetectionSettings(pfa=pfa, train_s=train_s, max_time_acc_s=None), interval_ns, hold_s)
    t_ns = np.arange(bias.shape[-1], dtype=np.int64) * interval_ns
    return stage.run({"t_ns": t_ns, "clock_bias_s": bias, "valid": np.ones(bias.shape, dtype=bool)})["excluded"]


def gnssdo_frame(free_phase_s, pps_error_s, epochs: ReceiverEpochs) -> dict:
    """The input columns of :func:`~.stages.gnssdo_pipeline`: the receivers' epochs (as their record gives them,
    lead axes (trials, receivers)), their raw 1PPS errors and the free-running oscillator (trials, steps)."""
    frame = epochs.to_record("receivers").frame()
    frame["pps_error_s"] = pps_error_s
    frame["free_phase_s"] = free_phase_s
    return frame


def discipline_run(servo: Servo, free_phase_s, pps_error_s, epochs: ReceiverEpochs, config: ChainConfig = ChainConfig(),
                   *, seed=None) -> GnssdoRun:
    """Discipline ``free_phase_s`` (trials, steps) with ``servo`` to the receivers of ``epochs``: the batch run of
    :func:`~.stages.gnssdo_pipeline` (qualify, integrity, fusion, loop, states).

    ``pps_error_s`` (trials, receivers, steps): each receiver's raw 1PPS edge error (s; NaN without a
    pulse), corrected here with the epochs' qErr per ``config``. The servo's interval is the epoch step.
    """
    return discipline_runs((servo,), free_phase_s, pps_error_s, epochs, config, seed=seed)[0]


def discipline_runs(servos, free_phase_s, pps_error_s, epochs: ReceiverEpochs, config: ChainConfig = ChainConfig(),
                    *, seed=None) -> list[GnssdoRun]:
    """:func:`discipline_run` for each of ``servos`` on the same data: the stages before the loop (qualification,
    integrity, the plausibility tests, fusion, the UTC label) see only the receivers and the free oscillator, so
    they run once and each servo closes its own loop and state machine on their columns (the same runs as one
    :func:`discipline_run` per servo, tested)."""
    servos = tuple(servos)
    if not servos or not all(isinstance(s, Servo) for s in servos):
        raise TypeError(f"servos == {servos!r}, must be one or more Servo")
    free = check_array(free_phase_s, "free_phase_s", ndim=2)
    pps = check_array(pps_error_s, "pps_error_s", ndim=3, allow_nan=True)
    if not isinstance(epochs, ReceiverEpochs):
        raise TypeError(f"epochs == {epochs!r}, must be a ReceiverEpochs")
    if pps.shape != epochs.shape or free.shape != (pps.shape[0], pps.shape[2]):
        raise ValueError(f"shapes disagree: free_phase_s {free.shape}, pps_error_s {pps.shape}, epochs {epochs.shape}")
    dt = float(servos[0].interval_s)
    if any(float(s.interval_s) != dt for s in servos):
        raise ValueError(f"the servos' intervals differ: {[float(s.interval_s) for s in servos]}")
    shared = gnssdo_pipeline(servos[0], config, int(round(dt * 1e9)), seed=seed).fit()
    names = [name for name, _ in shared.stages]
    before = Pipeline(shared.stages[:names.index("loop")])
    data = dict(before.run(gnssdo_frame(free, pps, epochs)).columns)
    runs = []
    for servo in servos:
        own = Pipeline(gnssdo_pipeline(servo, config, int(round(dt * 1e9)), seed=seed).stages[names.index("loop"):])
        r = own.fit().run(dict(data))
        runs.append(_gnssdo_run(r, dt))
    return runs


def _gnssdo_run(r, dt: float) -> GnssdoRun:
    loop = LoopRun(r["phase_s"], r["offset_s"], r["freq_adj"], r["phase_step_s"], r["offset_estimate_s"],
                   r["innovation_s"], r["used"], r["near_rail"], interval_s=dt)
    fusion = FusionRun(r["reference_error_s"] * -1.0, r["reference_variance_s2"], r["weights"])
    states = StateRun(r["gnssdo_state"], r["gnssdo_reason"], r["rail_alarm"], r["filtered_offset_s"],
                      r["holdover_ready"], r["holdover_sigma_s"])
    leap = {name: r[name] for name in ("utc_label_s", "utc_leap_s", "leap_second", "leap_dissent") if name in r}
    return GnssdoRun(loop.phase_s, r["loop_reference_s"], r["usable"], r["excluded"], loop, fusion, states, dt,
                     r["implausible"], leap or None)

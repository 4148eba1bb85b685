"""The GNSS-disciplined oscillator as a pipeline of stages (:mod:`chronofuse.estimation.pipeline`).

Per second, with ``trials`` and ``receivers`` as the lead axes of the receiver columns:

1. :class:`QualifyStage`: each receiver's 1PPS error corrected by its qErr (``pps + sign * qErr[k - lag]``,
   :func:`corrected_pps_error`) and qualified
   (:class:`~chronofuse.discipline.qualification.Qualification`: fix, time, satellites, GDOP, a pulse);
2. :class:`IntegrityStage`: each receiver's clock bias through the detection pipeline
   (:class:`chronofuse.integrity.watch.ClockWatch`: status gate, millisecond repair, detector, latch, its
   own training stretch); a receiver in a raised alarm, and for ``hold_s`` after it clears, is excluded;
3. :class:`~.guard_stages.ReceiverPlausibilityStage`: each qualified receiver against the free oscillator's
   prediction (:mod:`.plausibility`); a refused one is left out of fusion, and one back from any exclusion is
   ``fresh`` (its weight earned anew);
4. :class:`FusionStage`: the qualified, not excluded, plausible receivers fused
   (:class:`~chronofuse.discipline.fusion.InverseVarianceFusion`): the reference's 1PPS error;
5. :class:`~.guard_stages.ReferencePlausibilityStage`: the fused reference against the same prediction; the
   reference the loop closes on (``loop_reference_s``, NaN while refused: holdover); then
   :class:`~.utc_stage.LeapStage`: the receivers' UTC and leap-second consensus, the output's UTC label;
6. :class:`LoopStage`: the servo closes the loop on the oscillator (:func:`chronofuse.discipline.loop.close_loop`,
   through the servo's public ``initial_state``/``update``);
7. :class:`StateStage`: the operating state and its reason, the filtered time error and the holdover report
   (:mod:`chronofuse.discipline.states`).

:func:`gnssdo_pipeline` chains them; :func:`chronofuse.discipline.chain.discipline_run` (simulated runs and
the main job) runs it in batch, and it streams second by second with the same result
(``compare_streaming_to_batch``). A recorded 1PPS (:func:`chronofuse.experiments.gnssdo.run_reference`) runs
the last two.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from chronofuse.discipline.counter import MultiPhaseCounter
from chronofuse.discipline.fusion import InverseVarianceFusion
from chronofuse.discipline.guard_stages import (NoReceiverPlausibility, NoReferencePlausibility,
                                                ReceiverPlausibilityStage, ReferencePlausibilityStage)
from chronofuse.discipline.loop import close_loop
from chronofuse.discipline.qualification import Qualification
from chronofuse.discipline.utc_stage import LeapStage
from chronofuse.discipline.servo import Servo
from chronofuse.discipline.states import StateConfig, advance, initial_memory, run_states
from chronofuse.estimation.pipeline import Pipeline
from chronofuse.integrity.watch import ClockWatch, DetectionSettings, watch_record
from chronofuse.record import EpochRecord

__all__ = ["corrected_pps_error", "QualifyStage", "IntegrityStage", "FusionStage", "LoopStage", "StateStage", "gnssdo_pipeline"]


def corrected_pps_error(pps_error_s, qerr_s, sign: int = 1, lag: int = 0) -> np.ndarray:
    """``pps + sign * qerr`` shifted by ``lag`` pulses along the last axis (see the module docstring)."""
    pps = np.asarray(pps_error_s, dtype=np.float64)
    q = np.asarray(qerr_s, dtype=np.float64)
    if lag:
        q = np.concatenate([np.full(q.shape[:-1] + (lag,), np.nan), q[..., :-lag]], axis=-1)
    return pps + sign * q


class QualifyStage:
    """The 1PPS corrected by qErr and qualified (module docstring, step 1)."""

    needs: ClassVar[tuple[str, ...]] = ("pps_error_s", "qerr_s", "fix_mode", "time_valid", "gdop", "n_sats")
    gives: ClassVar[tuple[str, ...]] = ("pps_corrected_s", "qualified")

    def __init__(self, qualification: Qualification = Qualification(), qerr_sign: int = 1, qerr_lag: int = 0):
        self.qualification = qualification
        self.qerr_sign = qerr_sign
        self.qerr_lag = qerr_lag
        self.reset()

    def fit(self, frame=None) -> QualifyStage:
        self.reset()
        return self

    def reset(self) -> None:
        self._qerr_before = None

    def _qualify(self, e, frame) -> np.ndarray:
        return self.qualification.usable(np.asarray(frame["fix_mode"]) >= 2, frame["time_valid"], frame["gdop"],
                                         frame["n_sats"], np.isfinite(e))

    def step(self, epoch) -> dict:
        qerr = np.asarray(epoch["qerr_s"], dtype=np.float64)
        if self.qerr_lag:
            used = np.full(qerr.shape, np.nan) if self._qerr_before is None else self._qerr_before
            self._qerr_before = qerr
        else:
            used = qerr
        e = np.asarray(epoch["pps_error_s"], dtype=np.float64) + self.qerr_sign * used
        return {"pps_corrected_s": e, "qualified": self._qualify(e, epoch)}

    def run(self, frame) -> dict:
        e = corrected_pps_error(frame["pps_error_s"], frame["qerr_s"], self.qerr_sign, self.qerr_lag)
        return {"pps_corrected_s": e, "qualified": self._qualify(e, frame)}


class IntegrityStage:
    """Each receiver's clock bias watched by the detection pipeline (module docstring, step 2).

    ``settings``: :class:`chronofuse.integrity.watch.DetectionSettings` (with its training stretch);
    ``interval_ns``: the epochs' grid; ``hold_s``: a receiver stays excluded this long after its alarm
    clears. ``integrity_alarm``: the receiver's latched alarm; ``excluded``: the alarm and its hold.
    """

    needs: ClassVar[tuple[str, ...]] = ("t_ns", "clock_bias_s", "valid")
    gives: ClassVar[tuple[str, ...]] = ("integrity_alarm", "excluded")

    def __init__(self, settings, interval_ns: int, hold_s: float):
        self.settings = settings
        self.interval_ns = int(interval_ns)
        self.hold_s = hold_s
        self.reset()

    @property
    def _hold(self) -> int:
        return int(round(self.hold_s * 1e9 / self.interval_ns))

    def fit(self, frame=None) -> IntegrityStage:
        self.reset()
        return self

    def reset(self) -> None:
        self._watches = None
        self._since = None

    def step(self, epoch) -> dict:
        bias = np.asarray(epoch["clock_bias_s"], dtype=np.float64)
        valid = np.asarray(epoch["valid"], dtype=bool)
        t = int(np.asarray(epoch["t_ns"]).flat[0])
        if self._watches is None:
            self._watches = np.empty(bias.shape, dtype=object)
            for index in np.ndindex(bias.shape):
                self._watches[index] = ClockWatch(self.settings)
                self._watches[index].begin(t, self.interval_ns)
            self._since = np.full(bias.shape, np.iinfo(np.int64).max // 2, dtype=np.int64)
        alarm = np.zeros(bias.shape, dtype=bool)
        for index in np.ndindex(bias.shape):
            verdict = self._watches[index].step({"t_ns": t, "clock_bias_s": float(bias[index]),
                                                 "valid": bool(valid[index])})
            alarm[index] = verdict.state == "alarm"
        self._since = np.where(alarm, 0, self._since + 1)
        return {"integrity_alarm": alarm, "excluded": self._since <= self._hold}

    def run(self, frame) -> dict:
        bias = np.asarray(frame["clock_bias_s"], dtype=np.float64)
        valid = np.asarray(frame["valid"], dtype=bool)
        t = np.asarray(frame["t_ns"], dtype=np.int64).reshape(-1, bias.shape[-1])[0]
        alarm = np.zeros(bias.shape, dtype=bool)
        for index in np.ndindex(bias.shape[:-1]):
            record = EpochRecord.from_arrays(t, {"clock_bias_s": bias[index]}, {"clock_bias_s": "s"},
                                             source="receiver", valid=valid[index], interval_ns=self.interval_ns)
            alarm[index] = np.asarray(watch_record(record, self.settings).result["state"]) == "alarm"
        steps = bias.shape[-1]
        last = np.where(alarm, np.arange(steps), -(self._hold + 1) - steps)
        last = np.maximum.accumulate(last, axis=-1)
        return {"integrity_alarm": alarm, "excluded": np.arange(steps) - last <= self._hold}


class FusionStage:
    """Qualified, not excluded, plausible receivers fused into the reference (module docstring, step 3).

    ``reference_error_s`` (trials,): the fused reference's 1PPS error (NaN: no usable receiver); ``usable``
    (trials, receivers); ``reference_variance_s2``; ``weights`` (trials, receivers). A receiver ``fresh`` this
    second (back from an exclusion) restarts its variance estimate: its weight is earned anew.
    """

    needs: ClassVar[tuple[str, ...]] = ("pps_corrected_s", "qualified", "excluded", "receiver_plausible", "fresh")
    gives: ClassVar[tuple[str, ...]] = ("usable", "reference_error_s", "reference_variance_s2", "weights")

    def __init__(self, fusion: InverseVarianceFusion):
        self.fusion = fusion
        self.reset()

    def fit(self, frame=None) -> FusionStage:
        self.reset()
        return self

    def reset(self) -> None:
        self._state = None

    @staticmethod
    def _usable(values) -> np.ndarray:
        return (np.asarray(values["qualified"], dtype=bool) & ~np.asarray(values["excluded"], dtype=bool)
                & np.asarray(values["receiver_plausible"], dtype=bool))

    def step(self, epoch) -> dict:
        e = np.asarray(epoch["pps_corrected_s"], dtype=np.float64)
        usable = self._usable(epoch)
        z = np.where(usable, -e, np.nan)
        if self._state is None:
            self._state = self.fusion.initial_state(*z.shape)
        self._state, fused, variance, weights = self.fusion.update(self._state, z, usable & np.isfinite(z),
                                                                   np.asarray(epoch["fresh"], dtype=bool))
        return {"usable": usable, "reference_error_s": -fused, "reference_variance_s2": variance, "weights": weights}

    def run(self, frame) -> dict:
        e = np.asarray(frame["pps_corrected_s"], dtype=np.float64)
        usable = self._usable(frame)
        out = self.fusion.run(np.where(usable, -e, np.nan), usable, np.asarray(frame["fresh"], dtype=bool))
        return {"usable": usable, "reference_error_s": -out.offset_s, "reference_variance_s2": out.variance_s2,
                "weights": out.weights}


_LOOP_OUTPUTS = ("freq_adj", "phase_step_s", "offset_estimate_s", "innovation_s", "used", "near_rail")


class LoopStage:
    """The servo closing the loop on the oscillator (module docstring, step 4): ``free_phase_s`` (trials,) the
    free-running oscillator's time error, ``reference_error_s`` the reference's; gives the disciplined
    ``phase_s``, the measured ``offset_s`` and the servo's outputs (:class:`~chronofuse.discipline.loop.LoopRun`)."""

    gives: ClassVar[tuple[str, ...]] = ("phase_s", "offset_s", *_LOOP_OUTPUTS)

    def __init__(self, servo: Servo, *, counter: MultiPhaseCounter | None = None, seed=None,
                 reference: str = "reference_error_s"):
        #: ``reference``: the column of the reference's 1PPS error the loop closes on (the GNSSDO pipeline's is
        #: ``loop_reference_s``, the fused reference after the plausibility test).
        self.reference = reference
        self.needs = ("free_phase_s", reference)
        self.servo = servo
        self.counter = counter
        self.seed = seed
        self.reset()

    def fit(self, frame=None) -> LoopStage:
        self.reset()
        return self

    def reset(self) -> None:
        self._state = None
        self._c = None
        self._k = 0  # seconds stepped: the sample's time k * dt, as the batch loop gives it to the servo
        self._rng = np.random.default_rng(self.seed) if self.counter is not None else None

    def step(self, epoch) -> dict:
        free = np.atleast_1d(np.asarray(epoch["free_phase_s"], dtype=np.float64))
        ref = np.broadcast_to(np.asarray(epoch[self.reference], dtype=np.float64), free.shape)
        if self._state is None:
            self._state = self.servo.initial_state(free.size)
            self._c = np.zeros(free.size)
        x = free + self._c
        z = x - ref
        valid = np.isfinite(z)
        if self.counter is not None:
            z = np.where(valid, self.counter.measure_interval_s(1.0 + np.where(valid, z, 0.0),
                                                                self._rng.random(free.size)) - 1.0, z)
        dt = float(self.servo.interval_s)
        self._state, out = self.servo.update(self._state, z, valid, local_ts_s=self._k * dt)
        self._k += 1
        self._c = self._c + out[1] + dt * out[0]
        return {"phase_s": x, "offset_s": z, **dict(zip(_LOOP_OUTPUTS, out))}

    def run(self, frame) -> dict:
        loop = close_loop(self.servo, frame["free_phase_s"], frame[self.reference], counter=self.counter,
                          seed=self.seed)
        return {"phase_s": loop.phase_s, "offset_s": loop.offset_s,
                **{name: getattr(loop, name) for name in _LOOP_OUTPUTS}}


class StateStage:
    """The operating state each second (module docstring, step 5): ``gnssdo_state`` and ``gnssdo_reason``
    (:class:`~chronofuse.discipline.states.State`, ``Reason``), ``rail_alarm`` the DAC near a rail, the
    filtered time error and the holdover report (``holdover_ready``, ``holdover_sigma_s``). The reference is
    usable when the loop has one (``loop_reference_s`` finite); ``implausible`` when the plausibility test
    refused it; integrity counts as an alarm when receivers are excluded by it and none is left usable."""

    needs: ClassVar[tuple[str, ...]] = ("loop_reference_s", "offset_s", "excluded", "usable", "near_rail", "freq_adj",
                                        "implausible", "reference_variance_s2", "unresolved_s")
    gives: ClassVar[tuple[str, ...]] = ("gnssdo_state", "gnssdo_reason", "rail_alarm", "filtered_offset_s",
                                        "holdover_ready", "holdover_sigma_s")

    def __init__(self, config: StateConfig = StateConfig(), *, fast: bool = True):
        self.config = config
        self.fast = fast
        self.reset()

    def fit(self, frame=None) -> StateStage:
        self.reset()
        return self

    def reset(self) -> None:
        self._memory = None

    @staticmethod
    def _inputs(values, axis: int):
        usable = np.asarray(values["usable"], dtype=bool)
        alarm = np.asarray(values["excluded"], dtype=bool)
        implausible = np.asarray(values["implausible"], dtype=bool)
        all_alarmed = alarm.any(axis=axis) & ~usable.any(axis=axis) & ~implausible
        return np.isfinite(np.asarray(values["loop_reference_s"])), all_alarmed, implausible

    def step(self, epoch) -> dict:
        any_usable, all_alarmed, implausible = self._inputs(epoch, -1)
        if self._memory is None:
            self._memory = initial_memory(any_usable.size)
        self._memory, reason, report = advance(self._memory, any_usable, np.asarray(epoch["offset_s"], dtype=np.float64),
                                               self.config, alarm=all_alarmed, implausible=implausible,
                                               near_rail=np.asarray(epoch["near_rail"], dtype=bool),
                                               freq_adj=np.asarray(epoch["freq_adj"], dtype=np.float64),
                                               reference_variance_s2=np.asarray(epoch["reference_variance_s2"],
                                                                                dtype=np.float64),
                                               unresolved_s=np.asarray(epoch["unresolved_s"], dtype=np.float64))
        return {"gnssdo_state": self._memory["state"].copy(), "gnssdo_reason": reason,
                "rail_alarm": np.asarray(epoch["near_rail"], dtype=bool), **report}

    def run(self, frame) -> dict:
        any_usable, all_alarmed, implausible = self._inputs(frame, -2)
        states = run_states(any_usable, frame["offset_s"], self.config, alarm=all_alarmed, near_rail=frame["near_rail"],
                            implausible=implausible, freq_adj=frame["freq_adj"],
                            reference_variance_s2=frame["reference_variance_s2"], unresolved_s=frame["unresolved_s"],
                            fast=self.fast)
        return {"gnssdo_state": states.state, "gnssdo_reason": states.reason, "rail_alarm": states.rail_alarm,
                "filtered_offset_s": states.filtered_offset_s, "holdover_ready": states.holdover_ready,
                "holdover_sigma_s": states.holdover_sigma_s}


def gnssdo_pipeline(servo: Servo, config, interval_ns: int, *, seed=None) -> Pipeline:
    """The stages (module docstring) for a :class:`~chronofuse.discipline.chain.ChainConfig` and a ``servo``:
    qualify, integrity, the receivers' plausibility test, fusion, the fused reference's plausibility test,
    the loop and the states (:mod:`.guard_stages`); integrity runs only when ``config.integrity_pfa`` is set
    (else no receiver is excluded), each plausibility test only with its monitor in ``config``."""
    stages = [("qualify", QualifyStage(config.qualification, config.qerr_sign, config.qerr_lag))]
    if config.integrity_pfa is not None:
        settings = DetectionSettings(pfa=config.integrity_pfa, train_s=config.integrity_train_s, max_time_acc_s=None)
        stages.append(("integrity", IntegrityStage(settings, interval_ns, config.alarm_hold_s)))
    else:
        stages.append(("integrity", _NoIntegrity()))
    dt = interval_ns / 1e9
    receiver_check = (NoReceiverPlausibility() if config.receiver_monitor is None
                      else ReceiverPlausibilityStage(config.receiver_monitor, fast=config.fast))
    noise = None if config.receiver_monitor is None else config.receiver_monitor.noise
    reference_check = (NoReferencePlausibility(receiver_noise=noise) if config.reference_monitor is None
                       else ReferencePlausibilityStage(config.reference_monitor, fast=config.fast, receiver_noise=noise))
    stages += [("receiver_plausibility", receiver_check),
               ("fusion", FusionStage(InverseVarianceFusion(config.fusion, interval_s=dt, fast=config.fast))),
               ("reference_plausibility", reference_check),
               ("utc", LeapStage()),
               ("loop", LoopStage(servo, counter=config.counter, seed=seed, reference="loop_reference_s")),
               ("states", StateStage(config.states, fast=config.fast))]
    return Pipeline(stages)


class _NoIntegrity:
    """Integrity off: no receiver alarmed, none excluded."""

    needs: ClassVar[tuple[str, ...]] = ("clock_bias_s",)
    gives: ClassVar[tuple[str, ...]] = ("integrity_alarm", "excluded")

    def fit(self, frame=None):
        return self

    def reset(self) -> None:
        pass

    def step(self, epoch) -> dict:
        shape = np.shape(epoch["clock_bias_s"])
        return {"integrity_alarm": np.zeros(shape, dtype=bool), "excluded": np.zeros(shape, dtype=bool)}

    def run(self, frame) -> dict:
        shape = np.shape(frame["clock_bias_s"])
        return {"integrity_alarm": np.zeros(shape, dtype=bool), "excluded": np.zeros(shape, dtype=bool)}


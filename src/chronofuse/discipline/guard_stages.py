"""The GNSSDO pipeline's guards around fusion: the oscillator's plausibility test of each receiver (before fusion)
and of the fused reference (after it), as stages of :mod:`chronofuse.estimation.pipeline`.

The GPSDO knows its own applied corrections, so ``y = z - c = x_free - e`` (:mod:`.plausibility`); in the
pipeline that is ``free_phase_s - e``, the free-running oscillator (a column of the frame) against a receiver's
corrected 1PPS error, or against the fused reference.

* :class:`ReceiverPlausibilityStage` watches every qualified receiver (integrity-excluded or not) and gives
  ``receiver_plausible``; ``fresh`` marks a receiver usable again after any exclusion (integrity or
  plausibility), whose fusion weight is then earned anew; ``receiver_unresolved_s``, the bound on an offset
  each receiver was let back in with, ``receiver_predicted_s``, each refused receiver as the holdover
  prediction has it, and ``receiver_return_bound_s``, what a return from a gap could hide
  (:class:`~.plausibility.PlausibilityRun`).
* :class:`ReferencePlausibilityStage` watches the fused reference and gives the reference the loop closes on,
  ``loop_reference_s`` (while refused, the free oscillator less the holdover prediction from before the
  excursion: the loop holds over on the oscillator's own frequency, not on what a drag taught it; NaN where
  there is none), ``implausible`` (the fused reference refused, or
  every offered receiver refused) and ``unresolved_s``: the bound on the offset the reference may carry that
  the oscillator could not resolve, the larger of its own and its receivers' bounds weighted as fused (a
  weighted mean errs by at most the weighted mean of the bounds; a receiver that agrees for a minute with
  those carrying none carries only its measured offset from them, :class:`_Vouched`). The state machine keeps it off the lock
  threshold: a coherent step refused at once but let back in when the holdover prediction's tolerance had
  grown over it is not claimed locked.

Each has a pass-through twin for a chain without the test (:class:`NoReceiverPlausibility`,
:class:`NoReferencePlausibility`), so the pipeline's columns are the same either way.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from chronofuse.discipline.plausibility import DragMonitor, ReferenceNoise

__all__ = ["ReceiverPlausibilityStage", "ReferencePlausibilityStage", "NoReceiverPlausibility",
           "NoReferencePlausibility"]


def _fresh(usable: np.ndarray, held_out_before: np.ndarray) -> np.ndarray:
    return usable & held_out_before


class _FreshTracker:
    """``fresh``: usable now, held out (qualified but excluded) the second before."""

    def reset(self) -> None:
        self._held = None

    def step(self, qualified, usable) -> np.ndarray:
        held_before = np.zeros(usable.shape, bool) if self._held is None else self._held
        self._held = qualified & ~usable
        return _fresh(usable, held_before)

    @staticmethod
    def run(qualified, usable) -> np.ndarray:
        held = qualified & ~usable
        before = np.concatenate([np.zeros(held.shape[:-1] + (1,), bool), held[..., :-1]], axis=-1)
        return _fresh(usable, before)


class ReceiverPlausibilityStage:
    """Each qualified receiver against the free oscillator's prediction (module docstring)."""

    needs: ClassVar[tuple[str, ...]] = ("free_phase_s", "pps_corrected_s", "qualified", "excluded")
    gives: ClassVar[tuple[str, ...]] = ("receiver_plausible", "fresh", "receiver_unresolved_s", "receiver_predicted_s",
                                        "receiver_return_bound_s")

    def __init__(self, monitor: DragMonitor, *, fast: bool = True):
        self.monitor = monitor
        self.fast = fast
        self._fresh = _FreshTracker()
        self.reset()

    def fit(self, frame=None) -> ReceiverPlausibilityStage:
        self.reset()
        return self

    def reset(self) -> None:
        self._state = None
        self._fresh.reset()

    def step(self, epoch) -> dict:
        e = np.asarray(epoch["pps_corrected_s"], dtype=np.float64)
        qualified = np.asarray(epoch["qualified"], dtype=bool)
        free = np.asarray(epoch["free_phase_s"], dtype=np.float64).reshape(e.shape[:-1] + (1,))
        if self._state is None:
            self._state = self.monitor.initial_state(e.shape)
        self._state, plausible, _, _ = self.monitor.update(self._state, free - e, qualified)
        usable = qualified & ~np.asarray(epoch["excluded"], dtype=bool) & plausible
        return {"receiver_plausible": plausible, "fresh": self._fresh.step(qualified, usable),
                "receiver_unresolved_s": self._state["unresolved"].copy(),
                "receiver_predicted_s": self.monitor.predicted(self._state),
                "receiver_return_bound_s": self._state["return_bound"].copy()}

    def run(self, frame) -> dict:
        e = np.asarray(frame["pps_corrected_s"], dtype=np.float64)
        qualified = np.asarray(frame["qualified"], dtype=bool)
        free = np.asarray(frame["free_phase_s"], dtype=np.float64)[..., None, :]
        test = self.monitor.run(free - e, qualified, fast=self.fast)
        usable = qualified & ~np.asarray(frame["excluded"], dtype=bool) & test.plausible
        return {"receiver_plausible": test.plausible, "fresh": _FreshTracker.run(qualified, usable),
                "receiver_unresolved_s": test.unresolved_s, "receiver_predicted_s": test.predicted_s,
                "receiver_return_bound_s": test.return_bound_s}


class NoReceiverPlausibility:
    """No plausibility test of the receivers: all plausible; ``fresh`` still marks returns from integrity."""

    needs: ClassVar[tuple[str, ...]] = ("qualified", "excluded")
    gives: ClassVar[tuple[str, ...]] = ("receiver_plausible", "fresh", "receiver_unresolved_s", "receiver_predicted_s",
                                        "receiver_return_bound_s")

    def __init__(self):
        self._fresh = _FreshTracker()
        self.reset()

    def fit(self, frame=None):
        self.reset()
        return self

    def reset(self) -> None:
        self._fresh.reset()

    def step(self, epoch) -> dict:
        qualified = np.asarray(epoch["qualified"], dtype=bool)
        usable = qualified & ~np.asarray(epoch["excluded"], dtype=bool)
        return {"receiver_plausible": np.ones(qualified.shape, bool), "fresh": self._fresh.step(qualified, usable),
                "receiver_unresolved_s": np.zeros(qualified.shape), "receiver_predicted_s": np.full(qualified.shape, np.nan),
                "receiver_return_bound_s": np.full(qualified.shape, np.nan)}

    def run(self, frame) -> dict:
        qualified = np.asarray(frame["qualified"], dtype=bool)
        usable = qualified & ~np.asarray(frame["excluded"], dtype=bool)
        return {"receiver_plausible": np.ones(qualified.shape, bool), "fresh": _FreshTracker.run(qualified, usable),
                "receiver_unresolved_s": np.zeros(qualified.shape), "receiver_predicted_s": np.full(qualified.shape, np.nan),
                "receiver_return_bound_s": np.full(qualified.shape, np.nan)}


def _every_offered_refused(frame, axis: int) -> np.ndarray:
    """Receivers were offered (qualified, not excluded) and the plausibility test refused them all; ``axis``:
    the receivers' (-2 in a batch, -1 in one epoch)."""
    offered = np.asarray(frame["qualified"], dtype=bool) & ~np.asarray(frame["excluded"], dtype=bool)
    usable = np.asarray(frame["usable"], dtype=bool)
    return offered.any(axis=axis) & ~usable.any(axis=axis)


def _holdover_reference(free, predicted, axis: int, own=None) -> np.ndarray:
    """The reference the loop holds over on while refused: the free oscillator less the holdover prediction of
    the series (``own``, the fused reference's, where it has one; else the mean of the refused receivers'),
    NaN where none. The loop then keeps the oscillator's frequency from before the excursion, not the one a
    drag taught it before it was refused."""
    predicted = np.asarray(predicted, dtype=np.float64)
    have = np.isfinite(predicted)
    n = have.sum(axis=axis)
    mean = np.where(n > 0, np.where(have, predicted, 0.0).sum(axis=axis) / np.maximum(n, 1), np.nan)
    if own is not None:
        mean = np.where(np.isfinite(own), own, mean)
    return np.asarray(free, dtype=np.float64) - mean


#: Seconds a receiver let back in with a bound must agree with the receivers that carry none before they vouch
#: for it (the exponential average of the difference).
VOUCH_S = 64


class _Vouched:
    """The fused reference's share of its receivers' unresolved offsets (module docstring), weighted as fused.

    Each receiver's bound is what its monitor let it back in with after a refusal (``receiver_unresolved_s``),
    and, where it came back from a gap while another receiver was refused or carried a bound (a step while it
    was away), what the prediction could hide at its return (``receiver_return_bound_s``, where over the
    vouching tolerance). A receiver with a bound is vouched for by the *clean* usable ones (no bound, a
    measured offset within the tolerance, its last return within the tolerance) once the exponential
    average (``VOUCH_S``) of its difference from them is within the tolerance (3 sigma of that average for
    two receivers' noise, ``noise``: their :class:`~.plausibility.ReferenceNoise`). The difference is taken
    against the clean receivers less their own measured offsets, so it is each receiver's offset from the
    timescale the receivers had before any bound; a vouched receiver keeps it and vouches in turn only while
    it is within the tolerance: a ladder of steps each under the tolerance adds up and is refused vouching from
    its second rung. What a vouched receiver may still carry, up to the tolerance, is not counted (like any
    offset of one receiver under the thresholds, fusion dilutes it by its weight; counting the measured offset,
    mostly the receivers' noise, cost the urban-canyon day 7 % of its LOCKED time). Receivers stepped alone or two of three
    differ from the clean ones by their step; where no usable receiver is clean (a coherent step) nothing
    vouches. A receiver never refused vouches for what it is: an offset under the test's thresholds on every
    receiver is not seen (``drag_check``)."""

    def __init__(self, noise: ReferenceNoise | None):
        self.tolerance_s = math.inf if noise is None else 3.0 * math.sqrt(2.0 * noise.block_var(VOUCH_S))
        self.reset()

    def reset(self) -> None:
        self._m = None

    def step(self, usable, unresolved, weights, error, returned, refused) -> np.ndarray:
        usable = np.asarray(usable, dtype=bool)
        u = np.nan_to_num(np.asarray(unresolved, dtype=np.float64))
        e = np.asarray(error, dtype=np.float64)
        back = np.asarray(returned, dtype=np.float64)
        refused = np.asarray(refused, dtype=bool)
        if self._m is None:
            self._m = {name: np.zeros(u.shape) for name in ("base", "carried", "offset", "diff", "count", "last",
                                                              "back_tol")}
        m = self._m
        came_back = np.isfinite(back)
        m["back_tol"] = np.where(came_back, back, m["back_tol"])
        # A step while it was away: another receiver refused, or carrying a bound not vouched for, as it returns.
        bounded = (u + m["carried"] - m["base"]) > 0.0
        others = (refused | bounded).sum(axis=-1, keepdims=True) - (refused | bounded)
        m["carried"] = m["carried"] + np.where(came_back & (others > 0) & (back > self.tolerance_s), back, 0.0)
        total = u + m["carried"]
        count = np.where(total > m["last"], 0.0, m["count"])  # a new bound: its agreement starts again
        own = total - m["base"]
        clean = (usable & np.isfinite(e) & (own <= 0.0) & (np.abs(m["offset"]) < self.tolerance_s)
                 & (m["back_tol"] <= self.tolerance_s))
        n = clean.sum(axis=-1, keepdims=True)
        level = np.where(clean, e - m["offset"], 0.0).sum(axis=-1, keepdims=True) / np.maximum(n, 1)
        pending = usable & np.isfinite(e) & (own > 0.0) & (n > 0)
        diff = np.where(pending, e - level, 0.0)
        m["diff"] = np.where(pending, np.where(count > 0, m["diff"] + (diff - m["diff"]) / VOUCH_S, diff), m["diff"])
        count = np.where(pending, count + 1, count)
        vouch = pending & (count >= VOUCH_S) & (np.abs(m["diff"]) < self.tolerance_s)
        m["base"] = np.where(vouch, total, m["base"])
        m["offset"] = np.where(vouch, m["diff"], m["offset"])
        m["count"], m["last"] = count, total
        bound = total - m["base"]
        return np.sum(np.nan_to_num(np.asarray(weights, dtype=np.float64)) * bound, axis=-1)

    def run(self, usable, unresolved, weights, error, returned, refused) -> np.ndarray:
        usable = np.asarray(usable, dtype=bool)
        unresolved = np.asarray(unresolved, dtype=np.float64)
        out = np.zeros(usable.shape[:-2] + usable.shape[-1:])
        refused = np.asarray(refused, dtype=bool)
        if not np.any(unresolved) and not (np.isfinite(returned).any() and refused.any()):
            return out  # the usual run: no receiver let back in with a bound, none back while another refused
        weights, error, returned = (np.asarray(a, dtype=np.float64) for a in (weights, error, returned))
        self.reset()
        for k in range(usable.shape[-1]):
            out[..., k] = self.step(usable[..., k], unresolved[..., k], weights[..., k], error[..., k],
                                    returned[..., k], refused[..., k])
        return out


def _vouch_inputs(values) -> tuple:
    refused = np.asarray(values["qualified"], dtype=bool) & ~np.asarray(values["receiver_plausible"], dtype=bool)
    return (values["usable"], values["receiver_unresolved_s"], values["weights"], values["pps_corrected_s"],
            values["receiver_return_bound_s"], refused)


class ReferencePlausibilityStage:
    """The fused reference against the free oscillator's prediction (module docstring)."""

    needs: ClassVar[tuple[str, ...]] = ("free_phase_s", "reference_error_s", "qualified", "excluded", "usable",
                                        "weights", "receiver_unresolved_s", "receiver_predicted_s", "pps_corrected_s",
                                        "receiver_plausible", "receiver_return_bound_s")
    gives: ClassVar[tuple[str, ...]] = ("loop_reference_s", "implausible", "unresolved_s")

    def __init__(self, monitor: DragMonitor, *, fast: bool = True, receiver_noise: ReferenceNoise | None = None):
        self.monitor = monitor
        self.fast = fast
        self._vouched = _Vouched(receiver_noise)
        self.reset()

    def fit(self, frame=None) -> ReferencePlausibilityStage:
        self.reset()
        return self

    def reset(self) -> None:
        self._state = None
        self._vouched.reset()

    def step(self, epoch) -> dict:
        ref = np.asarray(epoch["reference_error_s"], dtype=np.float64)
        free = np.asarray(epoch["free_phase_s"], dtype=np.float64)
        if self._state is None:
            self._state = self.monitor.initial_state(ref.shape + (1,))
        have = np.isfinite(ref)
        self._state, plausible, _, _ = self.monitor.update(self._state, (free - ref)[..., None], have[..., None])
        refused = have & ~plausible[..., 0]
        implausible = refused | _every_offered_refused(epoch, -1)
        held = _holdover_reference(free, epoch["receiver_predicted_s"], -1, own=self.monitor.predicted(self._state)[..., 0])
        return {"loop_reference_s": np.where(implausible, held, ref), "implausible": implausible,
                "unresolved_s": np.maximum(self._state["unresolved"][..., 0], self._vouched.step(*_vouch_inputs(epoch)))}

    def run(self, frame) -> dict:
        ref = np.asarray(frame["reference_error_s"], dtype=np.float64)
        free = np.asarray(frame["free_phase_s"], dtype=np.float64)
        have = np.isfinite(ref)
        test = self.monitor.run((free - ref)[..., None, :], have[..., None, :], fast=self.fast)
        refused = have & ~test.plausible[..., 0, :]
        implausible = refused | _every_offered_refused(frame, -2)
        held = _holdover_reference(free, frame["receiver_predicted_s"], -2, own=test.predicted_s[..., 0, :])
        return {"loop_reference_s": np.where(implausible, held, ref), "implausible": implausible,
                "unresolved_s": np.maximum(test.unresolved_s[..., 0, :], self._vouched.run(*_vouch_inputs(frame)))}


class NoReferencePlausibility:
    """No plausibility test of the fused reference: the loop closes on it; ``implausible`` only when every offered
    receiver was refused."""

    needs: ClassVar[tuple[str, ...]] = ("free_phase_s", "reference_error_s", "qualified", "excluded", "usable",
                                        "weights", "receiver_unresolved_s", "receiver_predicted_s", "pps_corrected_s",
                                        "receiver_plausible", "receiver_return_bound_s")
    gives: ClassVar[tuple[str, ...]] = ("loop_reference_s", "implausible", "unresolved_s")

    def __init__(self, receiver_noise: ReferenceNoise | None = None):
        self._vouched = _Vouched(receiver_noise)
        self.reset()

    def fit(self, frame=None):
        self.reset()
        return self

    def reset(self) -> None:
        self._vouched.reset()

    def step(self, epoch) -> dict:
        implausible = _every_offered_refused(epoch, -1)
        held = _holdover_reference(epoch["free_phase_s"], epoch["receiver_predicted_s"], -1)
        return {"loop_reference_s": np.where(implausible, held, np.asarray(epoch["reference_error_s"], dtype=np.float64)),
                "implausible": implausible,
                "unresolved_s": self._vouched.step(*_vouch_inputs(epoch))}

    def run(self, frame) -> dict:
        implausible = _every_offered_refused(frame, -2)
        held = _holdover_reference(frame["free_phase_s"], frame["receiver_predicted_s"], -2)
        return {"loop_reference_s": np.where(implausible, held, np.asarray(frame["reference_error_s"], dtype=np.float64)),
                "implausible": implausible,
                "unresolved_s": self._vouched.run(*_vouch_inputs(frame))}

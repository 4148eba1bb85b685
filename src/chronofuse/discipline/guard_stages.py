"""The GNSSDO pipeline's guards around fusion: the oscillator's plausibility test of each receiver (before fusion)
and of the fused reference (after it), as stages of :mod:`chronofuse.estimation.pipeline`.

The GPSDO knows its own applied corrections, so ``y = z - c = x_free - e`` (:mod:`.plausibility`); in the
pipeline that is ``free_phase_s - e``, the free-running oscillator (a column of the frame) against a receiver's
corrected 1PPS error, or against the fused reference.

* :class:`ReceiverPlausibilityStage` watches every qualified receiver (integrity-excluded or not) and gives
  ``receiver_plausible``; ``fresh`` marks a receiver usable again after any exclusion (integrity or
  plausibility), whose fusion weight is then earned anew; ``receiver_unresolved_s``, the bound on an offset
  each receiver was let back in with (:attr:`~.plausibility.PlausibilityRun.unresolved_s`).
* :class:`ReferencePlausibilityStage` watches the fused reference and gives the reference the loop closes on,
  ``loop_reference_s`` (NaN while refused: holdover), ``implausible`` (the fused reference refused, or
  every offered receiver refused) and ``unresolved_s``: the bound on the offset the reference may carry that
  the oscillator could not resolve, the larger of its own and its receivers' bounds weighted as fused (a
  weighted mean errs by at most the weighted mean of the bounds; a receiver vouched for by another with no
  bound counts none, :class:`_Vouched`). The state machine keeps it off the lock
  threshold: a coherent step refused at once but let back in when the holdover prediction's tolerance had
  grown over it is not claimed locked.

Each has a pass-through twin for a chain without the test (:class:`NoReceiverPlausibility`,
:class:`NoReferencePlausibility`), so the pipeline's columns are the same either way.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from chronofuse.discipline.plausibility import DragMonitor

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
    gives: ClassVar[tuple[str, ...]] = ("receiver_plausible", "fresh", "receiver_unresolved_s")

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
                "receiver_unresolved_s": self._state["unresolved"].copy()}

    def run(self, frame) -> dict:
        e = np.asarray(frame["pps_corrected_s"], dtype=np.float64)
        qualified = np.asarray(frame["qualified"], dtype=bool)
        free = np.asarray(frame["free_phase_s"], dtype=np.float64)[..., None, :]
        test = self.monitor.run(free - e, qualified, fast=self.fast)
        usable = qualified & ~np.asarray(frame["excluded"], dtype=bool) & test.plausible
        return {"receiver_plausible": test.plausible, "fresh": _FreshTracker.run(qualified, usable),
                "receiver_unresolved_s": test.unresolved_s}


class NoReceiverPlausibility:
    """No plausibility test of the receivers: all plausible; ``fresh`` still marks returns from integrity."""

    needs: ClassVar[tuple[str, ...]] = ("qualified", "excluded")
    gives: ClassVar[tuple[str, ...]] = ("receiver_plausible", "fresh", "receiver_unresolved_s")

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
                "receiver_unresolved_s": np.zeros(qualified.shape)}

    def run(self, frame) -> dict:
        qualified = np.asarray(frame["qualified"], dtype=bool)
        usable = qualified & ~np.asarray(frame["excluded"], dtype=bool)
        return {"receiver_plausible": np.ones(qualified.shape, bool), "fresh": _FreshTracker.run(qualified, usable),
                "receiver_unresolved_s": np.zeros(qualified.shape)}


def _every_offered_refused(frame, axis: int) -> np.ndarray:
    """Receivers were offered (qualified, not excluded) and the plausibility test refused them all; ``axis``:
    the receivers' (-2 in a batch, -1 in one epoch)."""
    offered = np.asarray(frame["qualified"], dtype=bool) & ~np.asarray(frame["excluded"], dtype=bool)
    usable = np.asarray(frame["usable"], dtype=bool)
    return offered.any(axis=axis) & ~usable.any(axis=axis)


class _Vouched:
    """The fused reference's share of its receivers' unresolved offsets (module docstring): each usable
    receiver's bound since it was last vouched for, weighted as fused. A receiver usable beside another usable
    one that carries no bound is vouched for by it (the fusion's leave-one-out weights, earned anew, carry
    that cross-check: one receiver of three off leaves the output as it was); where every usable receiver was
    let back in with a bound (a coherent step), nothing vouches and the bounds stand."""

    def reset(self) -> None:
        self._base = None

    def step(self, usable, unresolved, weights) -> np.ndarray:
        usable = np.asarray(usable, dtype=bool)
        u = np.nan_to_num(np.asarray(unresolved, dtype=np.float64))
        base = np.zeros(u.shape) if self._base is None else self._base
        clean = usable & (u - base <= 0.0)
        vouch = (clean.any(axis=-1) & (usable.sum(axis=-1) >= 2))[..., None] & usable
        self._base = np.where(vouch, u, base)
        return np.sum(np.nan_to_num(np.asarray(weights, dtype=np.float64)) * (u - self._base), axis=-1)

    @staticmethod
    def run(usable, unresolved, weights) -> np.ndarray:
        usable = np.asarray(usable, dtype=bool)
        unresolved = np.asarray(unresolved, dtype=np.float64)
        weights = np.asarray(weights, dtype=np.float64)
        tracker = _Vouched()
        tracker.reset()
        out = np.empty(usable.shape[:-2] + usable.shape[-1:])
        for k in range(usable.shape[-1]):
            out[..., k] = tracker.step(usable[..., k], unresolved[..., k], weights[..., k])
        return out


class ReferencePlausibilityStage:
    """The fused reference against the free oscillator's prediction (module docstring)."""

    needs: ClassVar[tuple[str, ...]] = ("free_phase_s", "reference_error_s", "qualified", "excluded", "usable",
                                        "weights", "receiver_unresolved_s")
    gives: ClassVar[tuple[str, ...]] = ("loop_reference_s", "implausible", "unresolved_s")

    def __init__(self, monitor: DragMonitor, *, fast: bool = True):
        self.monitor = monitor
        self.fast = fast
        self.reset()

    def fit(self, frame=None) -> ReferencePlausibilityStage:
        self.reset()
        return self

    def reset(self) -> None:
        self._state = None
        self._vouched = _Vouched()
        self._vouched.reset()

    def step(self, epoch) -> dict:
        ref = np.asarray(epoch["reference_error_s"], dtype=np.float64)
        free = np.asarray(epoch["free_phase_s"], dtype=np.float64)
        if self._state is None:
            self._state = self.monitor.initial_state(ref.shape + (1,))
        have = np.isfinite(ref)
        self._state, plausible, _, _ = self.monitor.update(self._state, (free - ref)[..., None], have[..., None])
        refused = have & ~plausible[..., 0]
        return {"loop_reference_s": np.where(refused, np.nan, ref), "implausible": refused | _every_offered_refused(epoch, -1),
                "unresolved_s": np.maximum(self._state["unresolved"][..., 0], self._vouched.step(
                    epoch["usable"], epoch["receiver_unresolved_s"], epoch["weights"]))}

    def run(self, frame) -> dict:
        ref = np.asarray(frame["reference_error_s"], dtype=np.float64)
        free = np.asarray(frame["free_phase_s"], dtype=np.float64)
        have = np.isfinite(ref)
        test = self.monitor.run((free - ref)[..., None, :], have[..., None, :], fast=self.fast)
        refused = have & ~test.plausible[..., 0, :]
        return {"loop_reference_s": np.where(refused, np.nan, ref), "implausible": refused | _every_offered_refused(frame, -2),
                "unresolved_s": np.maximum(test.unresolved_s[..., 0, :], _Vouched.run(
                    frame["usable"], frame["receiver_unresolved_s"], frame["weights"]))}


class NoReferencePlausibility:
    """No plausibility test of the fused reference: the loop closes on it; ``implausible`` only when every offered
    receiver was refused."""

    needs: ClassVar[tuple[str, ...]] = ("reference_error_s", "qualified", "excluded", "usable", "weights",
                                        "receiver_unresolved_s")
    gives: ClassVar[tuple[str, ...]] = ("loop_reference_s", "implausible", "unresolved_s")

    def __init__(self):
        self.reset()

    def fit(self, frame=None):
        self.reset()
        return self

    def reset(self) -> None:
        self._vouched = _Vouched()
        self._vouched.reset()

    def step(self, epoch) -> dict:
        return {"loop_reference_s": np.asarray(epoch["reference_error_s"], dtype=np.float64),
                "implausible": _every_offered_refused(epoch, -1),
                "unresolved_s": self._vouched.step(epoch["usable"], epoch["receiver_unresolved_s"], epoch["weights"])}

    def run(self, frame) -> dict:
        return {"loop_reference_s": np.asarray(frame["reference_error_s"], dtype=np.float64),
                "implausible": _every_offered_refused(frame, -2),
                "unresolved_s": _Vouched.run(frame["usable"], frame["receiver_unresolved_s"], frame["weights"])}

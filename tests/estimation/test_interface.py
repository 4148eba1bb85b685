"""The interface's helpers: read-only results, input picking, and a checker that does catch a mismatch."""

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from chronofuse.estimation.interface import FrozenResult, compare_streaming_to_batch, pick_inputs, readonly


@dataclass(frozen=True)
class _Out:
    value: float


@dataclass(frozen=True)
class _Result(FrozenResult):
    value: np.ndarray


class _RunningSum:
    """Cumulative sum; ``drift_in_run`` adds an error to the batch path, ``mutating_run`` resets in run."""

    inputs: ClassVar[tuple[str, ...]] = ()

    def __init__(self, drift_in_run=0.0, mutating_run=False):
        self.drift_in_run = drift_in_run
        self.mutating_run = mutating_run

    def fit(self, train=None):
        self.reset()
        return self

    def reset(self):
        self._s = 0.0

    def step(self, z):
        self._s += float(z)
        return _Out(self._s)

    def run(self, Z):
        if self.mutating_run:
            self._s = 0.0
        return _Result(np.cumsum(Z, axis=1) + self.drift_in_run)


def test_the_checker_passes_a_consistent_estimator_and_reports_a_drifting_or_mutating_one():
    Z = np.arange(12.0).reshape(2, 6)
    assert compare_streaming_to_batch(_RunningSum().fit(), Z) == []
    problems = compare_streaming_to_batch(_RunningSum(drift_in_run=1e-6).fit(), Z)
    assert len(problems) == 2 and "value: trial 0" in problems[0]
    mutating = compare_streaming_to_batch(_RunningSum(mutating_run=True).fit(), Z)
    assert mutating == ["value: trial 0 streaming != batch at 3 step(s), first at step 3"]


def test_readonly_views_leave_the_callers_array_writeable():
    a = np.zeros(3)
    r = _Result(a)
    with pytest.raises(ValueError):
        r.value[0] = 1.0
    a[0] = 2.0  # the caller's own array is untouched
    assert readonly(a)[0] == 2.0 and a.flags.writeable


def test_pick_inputs_hands_over_exactly_the_declared_inputs_and_names_a_missing_one():
    class NeedsRef:
        inputs = ("reference_s",)

    assert pick_inputs(_RunningSum(), reference_s=1.0) == {}
    assert pick_inputs(NeedsRef(), reference_s=1.0, other=2) == {"reference_s": 1.0}
    with pytest.raises(ValueError, match="reference_s"):
        pick_inputs(NeedsRef())

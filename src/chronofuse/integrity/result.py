"""What every clock-bias detector returns: the frozen :class:`DetectionResult` of ``run`` and the
:class:`StepOutput` of ``step``, their fields named alike so that
:func:`chronofuse.estimation.interface.compare_streaming_to_batch` checks one against the other."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from chronofuse.estimation.interface import FrozenResult


@dataclass(frozen=True)
class DetectionResult(FrozenResult):
    """What a detector's ``run`` returns; arrays have the input's shape (steps,) or (trials, steps), read-only.

    Attributes
    ----------
    statistic : ndarray of float
        Test statistic per epoch (NaN where no test is possible).
    alarm : ndarray of bool
        ``statistic > threshold``.
    dof : ndarray of int
        Epochs (differences) in the window; fewer than ``window`` at start-up and after a gap, 0 where no test.
    threshold : ndarray of float
        The threshold that applied at each epoch (NaN where ``dof == 0``).
    skipped : ndarray of bool
        Missing (NaN) input epochs.
    n_skipped : int
        Number of missing input epochs (all trials).
    window : int
    pfa : float
    """

    statistic: np.ndarray
    alarm: np.ndarray
    dof: np.ndarray
    threshold: np.ndarray
    skipped: np.ndarray
    n_skipped: int
    window: int
    pfa: float

    @classmethod
    def from_statistic(cls, stat, dof, threshold, x, window: int, pfa: float) -> "DetectionResult":
        """Assemble a result: alarm where ``stat > threshold`` (never where either is NaN); skipped = NaN in ``x``."""
        skipped = np.isnan(x)
        return cls(
            statistic=stat,
            alarm=np.nan_to_num(stat, nan=-np.inf) > np.nan_to_num(threshold, nan=np.inf),
            dof=dof,
            threshold=threshold,
            skipped=skipped,
            n_skipped=int(skipped.sum()),
            window=int(window),
            pfa=float(pfa),
        )

    @property
    def n_alarms(self) -> int:
        return int(self.alarm.sum())

    def first_alarm(self, start: int = 0) -> np.ndarray:
        """Index of the first alarm at or after epoch ``start`` per trial (-1 if none); shape (...,)."""
        tail = self.alarm[..., start:]
        hit = tail.any(axis=-1)
        return np.where(hit, np.argmax(tail, axis=-1) + start, -1)


@dataclass(frozen=True)
class StepOutput:
    """One epoch of a streaming detector: statistic, alarm, dof, threshold, whether the input was missing,
    and the normalised innovation (last whitened component, NaN where ``dof == 0``)."""

    statistic: float
    alarm: bool
    dof: int
    threshold: float
    skipped: bool
    innovation: float = math.nan

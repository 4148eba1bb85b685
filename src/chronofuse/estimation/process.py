"""Discrete process models the estimators share: the clock's ``Phi`` and ``Q``, and the second difference.

The clock model (phase, frequency[, drift]) from its h-coefficients lives with the truth in
:mod:`chronofuse.models.clock` (Van Dierendonck, McGraw and Brown 1984; Brown and Hwang sec. 9.3), because
the simulators there sample it and ``models/`` sits above ``estimation/`` in the layer order; this
module gives it to the filters as one ``(F, Q)`` pair. The second difference is the operator that removes
a clock's phase and frequency (the detection patent)::

    d2x(k) = (x(k) - 2 x(k-1) + x(k-2)) / t_s

written once here, in :func:`second_difference`, for the batch (arrays) and the streaming (floats) paths.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.models.clock import clock_intensities, clock_process_noise, clock_transition

__all__ = ["ClockProcess", "clock_intensities", "clock_process_noise", "clock_transition", "second_difference",
           "second_difference_series"]


@dataclass(frozen=True)
class ClockProcess:
    """``F`` (Phi) and ``Q`` of the clock over one step ``dt_s`` (s); ``states`` 2 (phase, frequency) or 3 (+ drift).

    ``h0`` (s) and ``hm2`` (1/s): white-FM and random-walk-FM coefficients; ``drift_psd_per_s3``: spectral
    density of the noise driving the drift (1/s^3, three states only). See :mod:`chronofuse.models.clock`.
    """

    dt_s: float
    h0: float
    hm2: float
    drift_psd_per_s3: float = 0.0
    states: int = 2

    @property
    def F(self) -> np.ndarray:
        """The state transition ``Phi``, (states, states)."""
        return clock_transition(self.dt_s, self.states)

    @property
    def Q(self) -> np.ndarray:
        """The process-noise covariance per step, (states, states)."""
        return clock_process_noise(self.dt_s, h0=self.h0, hm2=self.hm2, drift_psd_per_s3=self.drift_psd_per_s3,
                                   states=self.states)

    def __post_init__(self):
        # builds Q once to validate every parameter by name
        clock_process_noise(self.dt_s, h0=self.h0, hm2=self.hm2, drift_psd_per_s3=self.drift_psd_per_s3,
                            states=self.states)


def second_difference(newest, previous, before, interval_s: float):
    """``(newest - 2 previous + before) / interval_s``: one difference (floats) or many (arrays), NaN in, NaN out."""
    return (newest - 2.0 * previous + before) / interval_s


def second_difference_series(x, interval_s: float) -> np.ndarray:
    """:func:`second_difference` along the last axis: (..., steps) -> (..., steps), the first two epochs NaN."""
    x = np.asarray(x, dtype=np.float64)
    out = np.full(x.shape, np.nan)
    out[..., 2:] = second_difference(x[..., 2:], x[..., 1:-1], x[..., :-2], interval_s)
    return out

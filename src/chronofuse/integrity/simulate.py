"""Receiver clock-bias truth under H0 from the detector's own noise model, batched and seeded.

The receiver clock is the two-state model (phase ``x``, fractional frequency ``y``) driven by white FM
and random-walk FM, discretised exactly: its ``Phi`` and ``Q`` are those of
:func:`chronofuse.models.clock.clock_transition` and :func:`~chronofuse.models.clock.clock_process_noise`
(Brown & Hwang, "Introduction to Random Signals and Applied Kalman Filtering", 4th ed., sec. 9.3), sampled
by :func:`~chronofuse.models.clock.two_state_clock_phase_s`. The measured clock bias adds white noise of
variance ``s2 = sigma_rho^2 / c^2``. The second difference of this measured bias has exactly the
``r(0..2)`` of :func:`chronofuse.integrity.noise_model.difference_autocorrelation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from chronofuse.record import EpochRecord

import numpy as np

from chronofuse.integrity.noise_model import noise_intensities
from chronofuse.models.clock import two_state_clock_phase_s
from chronofuse.seeding import child_rng, root_seed
from chronofuse.validation import check_scalar


@dataclass(frozen=True)
class ClockNoise:
    """Noise of a receiver clock bias: white FM ``h0`` (s), random-walk FM ``hm2`` (1/s), ``sigma_rho_m`` (m)."""

    h0: float
    hm2: float
    sigma_rho_m: float

    def __post_init__(self):
        for name in ("h0", "hm2", "sigma_rho_m"):
            check_scalar(getattr(self, name), name, min_val=0.0)


@dataclass(frozen=True)
class ClockBiasSimulation:
    """Simulated clock biases, shape (trials, steps): ``truth_s`` (the clock) and ``measured_s`` (+ noise)."""

    truth_s: np.ndarray
    measured_s: np.ndarray
    interval_s: float

    @property
    def t_s(self) -> np.ndarray:
        """Epoch times (s) from the first epoch, shape (steps,)."""
        return np.arange(self.truth_s.shape[-1]) * self.interval_s

    def record(self, t0_ns: int = 0, *, source: str = "simulate_clock_bias") -> EpochRecord:
        """The measured biases as the one epoch record: column ``clock_bias_s`` with lead axis (trials,), on
        the grid ``t0_ns + k * interval`` (integer ns, the file axis: the simulation has no GPS time)."""
        interval_ns = int(round(self.interval_s * 1e9))
        t_ns = int(t0_ns) + np.arange(self.measured_s.shape[-1], dtype=np.int64) * interval_ns
        return EpochRecord.from_arrays(t_ns, {"clock_bias_s": self.measured_s}, {"clock_bias_s": "s"}, source=source,
                                       interval_ns=interval_ns, time_scale="file")


def simulate_clock_bias(
    noise: ClockNoise, *, interval_s: float, steps: int, trials: int, seed: int | np.random.SeedSequence
) -> ClockBiasSimulation:
    """Simulate ``trials`` independent clock-bias records of ``steps`` epochs under H0.

    The clock is :func:`~chronofuse.models.clock.two_state_clock_phase_s`, starting at phase 0 and
    frequency 0; the measurement adds white noise of ``sigma_rho / c``. Trial ``i`` draws from the child
    ``spawn_key + (i,)`` of ``seed`` (:mod:`chronofuse.seeding`), so it is the same whatever ``trials``
    is, and a SeedSequence passed in is not mutated.
    """
    check_scalar(interval_s, "interval_s", min_val=0.0, include_min=False)
    check_scalar(steps, "steps", min_val=3, integer=True)
    check_scalar(trials, "trials", min_val=1, integer=True)
    ss = root_seed(seed)
    sig = math.sqrt(noise_intensities(noise.h0, noise.hm2, noise.sigma_rho_m)[2])
    truth = np.empty((trials, steps))
    measured = np.empty((trials, steps))
    for i in range(trials):
        z = child_rng(ss, i).standard_normal((4, steps))
        x = two_state_clock_phase_s(z[0], z[1], z[2], h0=noise.h0, hm2=noise.hm2, dt_s=float(interval_s))
        truth[i] = x
        measured[i] = x + sig * z[3]
    return ClockBiasSimulation(truth_s=truth, measured_s=measured, interval_s=float(interval_s))

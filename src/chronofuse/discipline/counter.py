"""Multi-phase interval counter (MP-PLL, the GNSSDO paper section 5.1, eqs. (4-1)-(4-2)).

The 10 MHz OCXO is multiplied (x20) to ``f_clk = 200 MHz`` and split into ``N`` clocks ``360/N``
degrees apart; each counts its rising edges between two corrected 1PPS edges. With the interval
``T`` (s) covering ``L = f_clk T`` clock periods and the first 1PPS edge at fractional position ``u``
(in periods, ``0 <= u < 1``) after a tick of phase 1, clock ``i`` (ticks at ``(n + i/N) / f_clk``,
``i = 0 .. N-1``) counts

    C_i = floor(u + L - i/N) - floor(u - i/N)                        (the source paper's eq. (4-1), made exact)

and the mean count ``C_bar = (1/N) sum C_i`` estimates ``L``. Its error is the count error of one clock
of frequency ``N f_clk`` divided by ``N``: with ``phi = frac(N L)`` it takes the values
``(1 - phi)/N`` or ``-phi/N`` (probabilities ``phi``, ``1 - phi`` over a uniform ``u``), mean zero and
variance ``phi (1 - phi) / N^2``; averaged over a uniform ``phi`` the rms is ``1 / (N sqrt(6))``
counts: the resolution is ``1 / (N f_clk)`` (1.25 ns for N = 4 at 200 MHz), one N-th of a single
counter's. The frequency error is ``(C_bar - C_ideal) / T`` counts per second (eq. (4-2)), or
``(C_bar - C_ideal) / C_ideal`` as a fractional frequency.

Seed example (section 3.2 (2)): counts 200000010, 200000011, 200000011, 200000011 -> mean
200000010.75, error 10.75 against the ideal 200000000 (it is what the formula gives for
``L = 200000010.75``, ``u = 0``; tested).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.validation import check_scalar

__all__ = ["MultiPhaseCounter", "multiphase_counts"]


def multiphase_counts(cycles, start_phase, n_phases: int) -> np.ndarray:
    """Counts ``C_i`` of ``n_phases`` equally spaced clocks over an interval (see the module docstring).

    ``cycles``: interval length in clock periods ``L`` (any shape); ``start_phase``: ``u`` in periods
    (broadcast with ``cycles``). Returns int64 of shape ``broadcast(cycles, start_phase).shape + (N,)``.
    """
    check_scalar(n_phases, "n_phases", min_val=1, integer=True)
    cycles = np.asarray(cycles, dtype=np.float64)[..., None]
    u = np.asarray(start_phase, dtype=np.float64)[..., None]
    shift = np.arange(int(n_phases)) / float(n_phases)
    return (np.floor(u + cycles - shift) - np.floor(u - shift)).astype(np.int64)


@dataclass(frozen=True)
class MultiPhaseCounter:
    """An ``n_phases``-phase counter on the reference multiplied ``multiplier`` times.

    Parameters
    ----------
    reference_hz : nominal oscillator frequency (Hz), > 0 (seed: 10 MHz).
    multiplier : PLL multiplication factor, >= 1 (seed: 20, giving 200 MHz).
    n_phases : clocks 360/N degrees apart, >= 1 (seed: 4).
    """

    reference_hz: float = 10e6
    multiplier: int = 20
    n_phases: int = 4

    def __post_init__(self):
        check_scalar(self.reference_hz, "reference_hz", min_val=0.0, include_min=False)
        check_scalar(self.multiplier, "multiplier", min_val=1, integer=True)
        check_scalar(self.n_phases, "n_phases", min_val=1, integer=True)

    @property
    def clock_hz(self) -> float:
        """Counting clock ``f_clk = multiplier * reference_hz`` (Hz)."""
        return float(self.multiplier * self.reference_hz)

    @property
    def resolution_s(self) -> float:
        """Effective resolution ``1 / (N f_clk)`` (s)."""
        return 1.0 / (self.n_phases * self.clock_hz)

    def counts(self, interval_s, start_phase) -> np.ndarray:
        """Counts of the N clocks over ``interval_s`` (true duration in OCXO-clock time, s), shape (..., N)."""
        return multiphase_counts(np.asarray(interval_s, dtype=np.float64) * self.clock_hz, start_phase, self.n_phases)

    def count_error(self, counts, gate_s: float = 1.0) -> np.ndarray:
        """``C_bar - C_ideal`` (counts) with ``C_ideal = f_clk gate_s``; ``counts`` has shape (..., N)."""
        counts = np.asarray(counts)
        # Integer sum first: the mean of counts near 2e8 keeps every quarter count exactly.
        total = counts.sum(axis=-1, dtype=np.int64) - counts.shape[-1] * round(self.clock_hz * gate_s)
        return total / counts.shape[-1]

    def fractional_frequency(self, counts, gate_s: float = 1.0) -> np.ndarray:
        """Frequency error as a fraction, ``(C_bar - C_ideal) / C_ideal`` (eq. (4-2) over ``f_clk``)."""
        return self.count_error(counts, gate_s) / (self.clock_hz * gate_s)

    def measure_interval_s(self, interval_s, start_phase) -> np.ndarray:
        """The interval as this counter measures it, ``C_bar / f_clk`` (s): quantized to ``1/(N f_clk)``."""
        counts = self.counts(interval_s, start_phase)
        return counts.sum(axis=-1, dtype=np.int64) / (counts.shape[-1] * self.clock_hz)

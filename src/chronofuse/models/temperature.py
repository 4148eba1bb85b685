"""The oscillator's environment temperature and what it does through the tempco, with a compensation table.

A profile is the temperature (K) at each 1/rate step: :func:`diurnal_profile` (a sine of a day's period) or
:func:`step_profile` (a step at a time). It acts on the oscillator through
:attr:`~chronofuse.models.oscillator.OscillatorModel.temp_coeff_per_K` (``y += c (T - T_ref)``, zero-order
hold: :func:`chronofuse.models.oscillator.simulate_oscillator` with ``temperature_K``, or
:func:`temperature_phase_s` for the phase it adds). A :class:`CompensationTable` (temperature -> the
fractional-frequency correction a unit applies, linear between its rows, held beyond its ends) is
feed-forward: the compensated oscillator's frequency is ``y + c (T - T_ref) - table(T)``
(:func:`compensated_phase_s`).

Theory (:func:`holdover_temperature_error_s`): a loop locked until ``t0`` has learnt the frequency the
oscillator had then, the temperature's part included; in holdover the temperature keeps moving, and the
time error grows by ``c int_0^h (T(t0 + s) - T(t0)) ds`` (less what a table removes), on top of the noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from chronofuse.validation import InputError, check_array, check_scalar

__all__ = ["diurnal_profile", "step_profile", "CompensationTable", "temperature_phase_s", "compensated_phase_s",
           "holdover_temperature_error_s"]


def diurnal_profile(steps: int, rate_hz: float = 1.0, mean_K: float = 298.15, amplitude_K: float = 5.0,
                    period_s: float = 86_400.0, phase_rad: float = 0.0) -> np.ndarray:
    """``mean + amplitude sin(2 pi t / period + phase)`` at ``t = n / rate``, (steps,)."""
    check_scalar(steps, "steps", min_val=1, integer=True)
    check_scalar(period_s, "period_s", min_val=0.0, include_min=False)
    t = np.arange(int(steps)) / rate_hz
    return mean_K + amplitude_K * np.sin(2.0 * math.pi * t / period_s + phase_rad)


def step_profile(steps: int, rate_hz: float = 1.0, base_K: float = 298.15, step_K: float = 5.0,
                 at_s: float = 0.0) -> np.ndarray:
    """``base`` before ``at_s``, ``base + step`` from it, (steps,)."""
    check_scalar(steps, "steps", min_val=1, integer=True)
    t = np.arange(int(steps)) / rate_hz
    return np.where(t >= at_s, base_K + step_K, base_K)


@dataclass(frozen=True)
class CompensationTable:
    """Rows of temperature (K, increasing) and the fractional-frequency correction at each; linear between
    rows, held beyond the ends."""

    temperature_K: tuple[float, ...]
    correction: tuple[float, ...]

    def __post_init__(self):
        t = np.asarray(self.temperature_K, dtype=float)
        c = np.asarray(self.correction, dtype=float)
        if t.ndim != 1 or t.size < 2 or t.shape != c.shape:
            raise InputError("a compensation table needs at least two rows of temperature and correction")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(c))):
            raise InputError("a compensation table's temperatures and corrections must be finite")
        if np.any(np.diff(t) <= 0):
            raise InputError("a compensation table's temperatures must increase")

    @classmethod
    def from_tempco(cls, temp_coeff_per_K: float, temp_ref_K: float, lo_K: float, hi_K: float,
                    rows: int = 11) -> CompensationTable:
        """The table of a linear tempco (e.g. the one :func:`chronofuse.discipline.characterize.characterize`
        fitted) over ``lo_K .. hi_K``."""
        t = np.linspace(lo_K, hi_K, rows)
        return cls(tuple(t.tolist()), tuple((temp_coeff_per_K * (t - temp_ref_K)).tolist()))

    def __call__(self, temperature_K) -> np.ndarray:
        return np.interp(np.asarray(temperature_K, dtype=float), self.temperature_K, self.correction)


def temperature_phase_s(temperature_K, temp_coeff_per_K: float, temp_ref_K: float, rate_hz: float = 1.0) -> np.ndarray:
    """The phase (s) the temperature adds, ``x[n] = sum_{j<n} c (T[j] - T_ref) / rate`` (what
    ``simulate_oscillator`` adds for ``temperature_K``), shape like the profile."""
    temp = check_array(temperature_K, "temperature_K", ndim=(1, 2))
    y = temp_coeff_per_K * (temp - temp_ref_K)
    x = np.zeros_like(y)
    np.cumsum(y[..., :-1], axis=-1, out=x[..., 1:])
    return x / rate_hz


def compensated_phase_s(temperature_K, temp_coeff_per_K: float, temp_ref_K: float, table: CompensationTable | None,
                        rate_hz: float = 1.0) -> np.ndarray:
    """The temperature's phase (s) with the table's feed-forward correction taken off (none: the bare one)."""
    x = temperature_phase_s(temperature_K, temp_coeff_per_K, temp_ref_K, rate_hz)
    if table is None:
        return x
    corr = table(temperature_K)
    cx = np.zeros_like(corr)
    np.cumsum(corr[..., :-1], axis=-1, out=cx[..., 1:])
    return x - cx / rate_hz


def holdover_temperature_error_s(temperature_K, start_index: int, horizons_s, temp_coeff_per_K: float,
                                 table: CompensationTable | None = None, rate_hz: float = 1.0) -> np.ndarray:
    """``c int_0^h (T(t0 + s) - T(t0)) ds`` less the table's share (module docstring), per horizon (s)."""
    temp = check_array(temperature_K, "temperature_K", ndim=1)
    idx = start_index + np.rint(np.asarray(horizons_s, dtype=float) * rate_hz).astype(np.int64)
    if np.any(idx >= temp.size):
        raise ValueError("horizons run past the profile")
    y = temp_coeff_per_K * temp - (0.0 if table is None else table(temp))
    dy = y - y[start_index]
    csum = np.concatenate(([0.0], np.cumsum(dy)))
    return (csum[idx] - csum[start_index]) / rate_hz

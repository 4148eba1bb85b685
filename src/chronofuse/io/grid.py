"""Placing time-tagged samples on a regular grid of sample slots; a missing slot becomes a gap (NaN)."""

from __future__ import annotations

import numpy as np

from chronofuse.validation import InputDataError


def grid_slots(offsets: np.ndarray, interval: float, tolerance: float) -> tuple[np.ndarray, int]:
    """Slot index of each sample: ``round(offsets / interval)``, shape (N,).

    ``offsets`` (N,) are times since the first sample (any unit, the same as ``interval``). Returns
    ``(slots, bad)`` where ``bad`` is the position of the first sample that is more than
    ``tolerance * interval`` off its slot or does not advance to a later slot than the one before
    (``-1`` when every sample is good). Slot numbers are measured from the first sample, so timing
    jitter does not accumulate over a long record.
    """
    offsets = np.asarray(offsets, dtype=np.float64)
    slots = np.rint(offsets / interval).astype(np.int64)
    off = np.abs(offsets - slots * interval) > tolerance * interval
    stuck = np.r_[False, np.diff(slots) <= 0]
    bad = np.flatnonzero(off | stuck)
    return slots, int(bad[0]) if bad.size else -1


def place_on_grid(slots: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Values at their slots, NaN in the empty ones: shape ``(slots[-1] + 1, *values.shape[1:])``."""
    out = np.full((int(slots[-1]) + 1, *np.shape(values)[1:]), np.nan)
    out[slots] = values
    return out


def regular_grid(t_s: np.ndarray, values: np.ndarray, interval_s: float, source: str,
                 tolerance: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Place ``values`` (N,) at times ``t_s`` (N,) on the grid ``t_s[0] + k interval_s``; empty slots are NaN.

    A step may differ from a whole number of intervals by ``tolerance`` (a fraction of the interval).
    Returns ``(grid times (M,), grid values (M,))``.

    Raises :class:`~chronofuse.validation.InputDataError` naming ``source`` and the epoch when time does not
    increase or a step is not a whole number of intervals (a changed sampling interval).
    """
    t_s = np.asarray(t_s, dtype=np.float64)
    steps = np.diff(t_s)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise InputDataError(f"epoch {k + 1}: time is not increasing ({t_s[k - 1]:g} s then {t_s[k]:g} s)", source)
    slots, bad = grid_slots(t_s - t_s[0], interval_s, tolerance)
    if bad >= 0:
        raise InputDataError(
            f"epoch {bad + 1}: time step {steps[bad - 1]:g} s is not a whole number of {interval_s:g} s intervals "
            "(the sampling interval changed: a new interval needs a new detector, check {rate_hz})",
            source, fields=("rate_hz",))
    grid = place_on_grid(slots, values)
    return t_s[0] + np.arange(grid.size) * interval_s, grid

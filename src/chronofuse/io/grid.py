"""Placing time-tagged samples on a regular grid of sample slots; a missing slot becomes a gap (NaN)."""

from __future__ import annotations

import numpy as np


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

"""Receiver clock steering: millisecond resets recognised, reported as clock events, and repaired.

Many GNSS receivers with a free-running oscillator keep their clock within +-0.5 ms of GPS time by
jumping it a whole millisecond whenever it drifts out (the IGS stations MANA, URUM and TIXJ in
``igs15904.clk`` do, every 5-min epoch or two; pseudoranges then jump by ``c x 1 ms`` = 299.79 km). To the
HOD test such a jump is a huge anomaly; it is not a fault of the signal in space but the
receiver's documented behaviour, so it is recognised and taken out before the test:

* at epoch ``k`` with three consecutive valid biases, the second difference of the repaired series
  ``d2 = x(k) - 2 x(k-1) + x(k-2)`` (seconds, not divided by ``t_s``) is compared with whole
  milliseconds: ``m = round(d2 / 1 ms)``; when ``m != 0`` and ``|d2 - m ms| <= tolerance_s`` the epoch is a
  clock event of ``m`` ms, and ``m ms`` is subtracted from epoch ``k`` on (the jump of the raw first
  difference, e.g. TIXJ's +808 us, is this 1 ms plus the clock's own drift over the interval);
* the test is causal (it uses epochs ``<= k``) and the repair of one event is applied before the next is
  looked for; across a gap (a NaN epoch) no second difference exists, and the HOD chain restarts there
  anyway.

The tolerance (default 0.1 ms) must exceed the second difference the clock itself produces over two
intervals (a free-running TCXO at 300 s: well under 1 us) and stay far below 0.5 ms, so a jump that is
not near a whole millisecond is left to the detector as an anomaly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.validation import check_array, check_scalar

#: The steering unit of GNSS receiver clocks (s).
MILLISECOND_S = 1e-3


@dataclass(frozen=True)
class ClockSteering:
    """A clock-bias series with its millisecond resets repaired.

    ``repaired_s`` (epochs,) the bias with the resets removed; ``event_epochs`` (events,) the epoch index
    of each reset and ``event_size_s`` (events,) its size (a signed whole number of ms, as found).
    """

    repaired_s: np.ndarray
    event_epochs: np.ndarray
    event_size_s: np.ndarray


def repair_clock_steering(bias_s, *, tolerance_s: float = 1e-4, unit_s: float = MILLISECOND_S) -> ClockSteering:
    """Find and remove the receiver's whole-``unit_s`` clock jumps in ``bias_s`` (epochs,), causally.

    See the module docstring. The candidates are the epochs whose raw second difference exceeds half a
    unit (a repair changes the second differences of the two epochs after it only, by the jump), so the
    sequential pass visits only those: the cost is one vectorised second difference.
    """
    x = check_array(bias_s, "bias_s", ndim=1, allow_nan=True)
    check_scalar(unit_s, "unit_s", min_val=0.0, include_min=False)
    check_scalar(tolerance_s, "tolerance_s", min_val=0.0, max_val=unit_s / 2, include_max=False)
    d2 = np.full(x.shape, np.nan)
    d2[2:] = x[2:] - 2.0 * x[1:-1] + x[:-2]
    # Repaired x_r = x - C with C(k) the sum of the jumps J_j, j <= k, so
    # d2_r(k) = d2(k) - J_k + J_(k-1): before deciding J_k, d2(k) + J_(k-1) is what is tested.
    todo = sorted(set(np.flatnonzero(np.abs(np.nan_to_num(d2)) > unit_s / 2 - tolerance_s).tolist()))
    jumps: dict[int, float] = {}
    i = 0
    while i < len(todo):
        k = todo[i]
        i += 1
        d2_rep = d2[k] + jumps.get(k - 1, 0.0)
        if not np.isfinite(d2_rep):
            continue
        m = round(d2_rep / unit_s)
        if m != 0 and abs(d2_rep - m * unit_s) <= tolerance_s:
            jumps[k] = m * unit_s
            if k + 1 < x.size and (i >= len(todo) or todo[i] != k + 1):
                todo.insert(i, k + 1)  # the epoch after a jump is tested with the jump removed
    epochs = np.array(sorted(jumps), dtype=np.int64)
    sizes = np.array([jumps[int(k)] for k in epochs], dtype=np.float64)
    correction = np.zeros(x.shape)
    if epochs.size:
        np.add.at(correction, epochs, sizes)
        correction = np.cumsum(correction)
    return ClockSteering(repaired_s=x - correction, event_epochs=epochs, event_size_s=sizes)


__all__ = ["MILLISECOND_S", "ClockSteering", "repair_clock_steering"]

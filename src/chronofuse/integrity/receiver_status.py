"""The receiver's own status per epoch: its fix flags and its time accuracy estimate.

A receiver that loses its fix keeps reporting a clock bias: it extrapolates its clock with the last
frequency (the Navisys GR-701W in ``tests/data/receivers/gpsd/navisys-gr701w.log`` for 29 s, its bias
advancing by exactly its drift), which the HOD test sees as a perfectly healthy clock. Two things the
receiver says tell it apart, and an epoch that fails either is ``unavailable`` with that reason:

* the fix flags (UBX NAV-SOL/PVT/STATUS, :attr:`chronofuse.io.ubx.NavClockRecord.fix_ok`);
* the time accuracy estimate ``tAcc`` of the clock solution (UBX NAV-CLOCK, ns), over ``max_time_acc_s``.
  While coasting, the GR-701W's tAcc grew from 41 ns to 172 ns.

Default limit :data:`DEFAULT_MAX_TIME_ACC_S` = 100 ns. In the u-blox captures of ``tests/data/receivers``
with a fix (GR-701W, GR-8013, ZED-F9P/F9R/F9T, NEO-F9V, LEA-4T, AEK-4T) tAcc is 1 to 63 ns (the 63 ns the
GR-701W's first epoch after it regained its fix), so 100 ns leaves healthy epochs of these receivers alone
and is about where the GR-701W's oscillator, free-running at 426 ns/s of drift, had drifted 19 s from its
last fix. It is a limit on the receiver's own claim, not on the detector's statistic; a timing
application with a tighter budget sets its own (``max_time_acc_s``).
"""

from __future__ import annotations

import numpy as np

#: Default largest receiver time accuracy estimate (s) for an epoch to be tested (module docstring).
DEFAULT_MAX_TIME_ACC_S = 100e-9

NO_FIX = "receiver status: no valid fix"


def status_reasons(receiver_ok, time_acc_s, max_time_acc_s: float | None, n_epochs: int) -> np.ndarray:
    """Per epoch the reason the receiver's status rules the epoch out (``""``: none), shape (n_epochs,).

    ``receiver_ok`` (bool per epoch, or None), ``time_acc_s`` (s per epoch, NaN = not reported, or None),
    ``max_time_acc_s`` (s, or None: not used). No fix takes precedence over a poor time accuracy.
    """
    reasons = np.full(n_epochs, "", dtype=object)
    if time_acc_s is not None and max_time_acc_s is not None:
        tacc = np.asarray(time_acc_s, dtype=np.float64)
        reasons[tacc > max_time_acc_s] = f"receiver status: time accuracy over {max_time_acc_s * 1e9:g} ns"
    if receiver_ok is not None:
        reasons[~np.asarray(receiver_ok, dtype=bool)] = NO_FIX
    return reasons


__all__ = ["DEFAULT_MAX_TIME_ACC_S", "NO_FIX", "status_reasons"]

"""u-blox TIM-TP time pulses placed on the epochs of :mod:`chronofuse.io.ubx_epochs`.

TIM-TP announces the ``qErr`` (quantization error, s) of the NEXT time pulse, whose time is ``towMS``/``week``
in ``timeBase`` (0 GNSS, 1 UTC; u-blox 8 / M8 interface description, TIM-TP). A pulse is kept as the tuple
``(week, tow_ms, time_base, qerr_s)`` until the epoch it describes is known, then its ``qErr`` is put on
that epoch's row (:func:`attach_pulses`).
"""

from __future__ import annotations

import numpy as np

from chronofuse.timescale import NS_PER_S, NS_PER_WEEK, gps_minus_utc_s

__all__ = ["attach_pulses", "pulse_gps_ns"]


def pulse_gps_ns(pulse: tuple, leap_s: int) -> int:
    """GPS ns of a pulse ``(week, tow_ms, time_base, qerr_s)``; a UTC time base is moved to GPS with ``leap_s``."""
    week, tow_ms, base, _ = pulse
    return week * NS_PER_WEEK + tow_ms * 1_000_000 + (leap_s * NS_PER_S if base == 1 else 0)


def attach_pulses(rows: dict, pulses: list) -> tuple[dict, int]:
    """Put each TIM-TP ``qErr`` on the epoch of the pulse it describes (GPS ns of the pulse; a UTC time
    base is moved to GPS with that epoch's leap count). Returns the rows and the number of pulses whose
    epoch is not among them: such a pulse is no epoch (it has no fix, no time, no solution of its own; the
    last TIM-TP of a recording announces a pulse after the recording ends), so it is counted, never made
    a row. The rows keep their order (the stream's: :mod:`chronofuse.io.arrival` puts them in time order)."""
    if not pulses:
        return rows, 0
    order = np.argsort(rows["gps_ns"], kind="stable")
    gps = rows["gps_ns"][order]
    rows = {**rows, "qerr_s": np.array(rows["qerr_s"], dtype=np.float64)}
    unmatched = 0
    for week, tow_ms, base, qerr in pulses:
        t = week * NS_PER_WEEK + tow_ms * 1_000_000
        if base == 1:  # UTC time base: towMS counts UTC seconds of the week
            j = np.searchsorted(gps, t, side="right") - 1
            leap = int(rows["leap_s"][order[max(j, 0)]]) if gps.size else int(gps_minus_utc_s(t))
            t += leap * NS_PER_S
        j = np.searchsorted(gps, t)
        if j < gps.size and gps[j] == t:
            rows["qerr_s"][order[j]] = qerr
        else:
            unmatched += 1
    return rows, unmatched

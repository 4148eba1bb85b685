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


def attach_pulses(rows: dict, pulses: list) -> dict:
    """Put each TIM-TP ``qErr`` on the epoch of the pulse it describes (GPS ns of the pulse; a UTC
    time base is moved to GPS with that epoch's leap count); a pulse without an epoch gets its own row."""
    if not pulses:
        return rows
    gps = rows["gps_ns"]
    order = np.argsort(gps, kind="stable")
    rows = {k: v[order] for k, v in rows.items()}
    gps = rows["gps_ns"]
    extra = []
    for week, tow_ms, base, qerr in pulses:
        t = week * NS_PER_WEEK + tow_ms * 1_000_000
        if base == 1:  # UTC time base: towMS counts UTC seconds of the week
            j = np.searchsorted(gps, t, side="right") - 1
            leap = int(rows["leap_s"][max(j, 0)]) if gps.size else int(gps_minus_utc_s(t))
            t += leap * NS_PER_S
        j = np.searchsorted(gps, t)
        if j < gps.size and gps[j] == t:
            rows["qerr_s"][j] = qerr
        else:
            extra.append((t, qerr))
    if extra:
        n_extra = len(extra)
        add = {k: np.resize(np.zeros(1, v.dtype), n_extra) for k, v in rows.items()}
        add["gps_ns"] = np.array([t for t, _ in extra], dtype=np.int64)
        add["qerr_s"] = np.array([q for _, q in extra])
        for k in ("gdop", "pdop", "hdop", "vdop", "tdop", "clock_bias_s", "clock_drift_s_per_s"):
            add[k] = np.full(n_extra, np.nan)
        add["n_sats"] = np.full(n_extra, -1, dtype=np.int16)
        j = np.clip(np.searchsorted(gps, add["gps_ns"]) - 1, 0, max(gps.size - 1, 0))
        add["leap_s"] = rows["leap_s"][j] if gps.size else gps_minus_utc_s(add["gps_ns"]).astype(np.int16)
        rows = {k: np.concatenate([rows[k], add[k]]) for k in rows}
        order = np.argsort(rows["gps_ns"], kind="stable")
        rows = {k: v[order] for k, v in rows.items()}
    return rows

"""IMU logs as CSV: the columns, their units, and the blocks of samples between GNSS epochs.

Columns (a header row; order free, other columns ignored):

* time, one of: ``gps_ns`` (int64 ns since 1980-01-06, GPS time), or ``gps_week`` with ``tow_s``, or ``t_s``
  (seconds from any origin; then the caller gives the GPS time of ``t_s = 0``);
* angular rate of the body frame (x forward, y right, z down) against inertial space, the average over
  the sample interval: ``gyro_x_rad_per_s``, ``gyro_y_rad_per_s``, ``gyro_z_rad_per_s`` (or ``..._deg_per_s``);
* specific force, the same axes and averaging: ``accel_x_m_per_s2``, ``accel_y_m_per_s2``,
  ``accel_z_m_per_s2`` (or ``..._g``, standard gravity 9.80665 m/s^2).

The samples must be at one rate (the median interval; an interval more than 1 % off it, or a time going
back, is refused naming its line); a missing value is refused naming line and column. :func:`imu_blocks`
cuts the log into the ``(epochs, samples, 3)`` blocks that :class:`chronofuse.positioning.loose.LooselyCoupled`
and :class:`chronofuse.positioning.tight.TightlyCoupled` take: block ``k`` holds the samples after GNSS
epoch ``k - 1`` up to epoch ``k``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from chronofuse.timescale import NS_PER_S, gps_ns_from_week_tow, seconds_to_ns
from chronofuse.validation import InputDataError

__all__ = ["ImuLog", "read_imu_csv", "imu_blocks", "write_imu_csv"]

_G0 = 9.80665
_AXES = ("x", "y", "z")


@dataclass(frozen=True)
class ImuLog:
    """``gps_ns`` (samples,) int64, ``gyro_rad_per_s`` and ``accel_m_per_s2`` (samples, 3), ``rate_hz``."""

    gps_ns: np.ndarray
    gyro_rad_per_s: np.ndarray
    accel_m_per_s2: np.ndarray
    rate_hz: float
    source: str = ""


def _columns(frame: pd.DataFrame, stem: str, units: dict[str, float], source: str) -> np.ndarray:
    for unit, scale in units.items():
        names = [f"{stem}_{a}_{unit}" for a in _AXES]
        if all(n in frame.columns for n in names):
            block = frame[names].to_numpy(dtype=np.float64)
            bad = np.argwhere(~np.isfinite(block))
            if bad.size:
                row, col = bad[0]
                raise InputDataError(f"line {row + 2}: no value in column {names[col]}", source)
            return block * scale
    wanted = " or ".join(f"{stem}_x/y/z_{u}" for u in units)
    raise InputDataError(f"no {wanted} columns (columns: {', '.join(frame.columns)})", source)


def read_imu_csv(path, *, start_gps_ns: int | None = None) -> ImuLog:
    """Read an IMU log (module docstring). ``start_gps_ns``: GPS time of ``t_s = 0`` for a ``t_s`` column."""
    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise InputDataError("no such file", source)
    try:
        frame = pd.read_csv(path, comment="#")
    except (ValueError, pd.errors.ParserError) as exc:
        raise InputDataError(f"not a readable CSV ({exc})", source) from exc
    frame.columns = [str(c).strip() for c in frame.columns]
    if "gps_ns" in frame.columns:
        t = frame["gps_ns"].to_numpy(dtype=np.int64)
    elif {"gps_week", "tow_s"} <= set(frame.columns):
        t = gps_ns_from_week_tow(frame["gps_week"].to_numpy(dtype=np.int64), seconds_to_ns(frame["tow_s"].to_numpy()))
    elif "t_s" in frame.columns:
        if start_gps_ns is None:
            raise InputDataError("a t_s column needs the GPS time of t_s = 0 (start_gps_ns)", source)
        t = int(start_gps_ns) + seconds_to_ns(frame["t_s"].to_numpy(dtype=np.float64))
    else:
        raise InputDataError("no time column (gps_ns, gps_week + tow_s, or t_s)", source)
    if t.size < 2:
        raise InputDataError("fewer than two samples", source)
    gyro = _columns(frame, "gyro", {"rad_per_s": 1.0, "deg_per_s": math.pi / 180.0}, source)
    accel = _columns(frame, "accel", {"m_per_s2": 1.0, "g": _G0}, source)
    step = np.diff(t)
    median = float(np.median(step))
    bad = np.flatnonzero((step <= 0) | (np.abs(step - median) > 0.01 * median))
    if bad.size:
        k = int(bad[0])
        raise InputDataError(f"line {k + 3}: sample interval {step[k] / NS_PER_S:g} s against the log's "
                             f"{median / NS_PER_S:g} s (a gap, a repeated or a reversed time)", source)
    return ImuLog(gps_ns=np.asarray(t, dtype=np.int64), gyro_rad_per_s=gyro, accel_m_per_s2=accel,
                  rate_hz=NS_PER_S / median, source=source)


def write_imu_csv(path, gps_ns, gyro_rad_per_s, accel_m_per_s2) -> None:
    """Write a log in the columns :func:`read_imu_csv` reads (``gps_ns``, rad/s, m/s^2)."""
    g = np.asarray(gyro_rad_per_s, dtype=np.float64)
    a = np.asarray(accel_m_per_s2, dtype=np.float64)
    table = {"gps_ns": np.asarray(gps_ns, dtype=np.int64)}
    table.update({f"gyro_{ax}_rad_per_s": g[:, k] for k, ax in enumerate(_AXES)})
    table.update({f"accel_{ax}_m_per_s2": a[:, k] for k, ax in enumerate(_AXES)})
    pd.DataFrame(table).to_csv(path, index=False, float_format="%.17g")


def imu_blocks(log: ImuLog, epochs_gps_ns) -> tuple[np.ndarray, np.ndarray]:
    """``(gyro, accel)`` blocks (epochs, samples, 3): block ``k`` the samples in ``(t_{k-1}, t_k]`` (for the
    first epoch, the ``samples`` before it). The epochs must be a whole number of samples apart and covered
    by the log; raises :class:`InputDataError` naming the log otherwise."""
    t = np.asarray(epochs_gps_ns, dtype=np.int64)
    interval = np.diff(t)
    if t.size < 1 or (interval.size and not (interval == interval[0]).all()):
        raise InputDataError("the GNSS epochs must be evenly spaced", log.source)
    dt = int(round(NS_PER_S / log.rate_hz))
    span = int(interval[0]) if interval.size else dt
    samples = span // dt
    if samples < 1 or samples * dt != span:
        raise InputDataError(f"the GNSS interval {span / NS_PER_S:g} s is not a whole number of IMU samples "
                             f"({dt / NS_PER_S:g} s)", log.source)
    last = np.searchsorted(log.gps_ns, t, side="right") - 1  # the sample at or before each epoch
    first = last - samples + 1
    if first[0] < 0 or (log.gps_ns[last] != t).any():
        raise InputDataError("the log does not hold a sample at every GNSS epoch (or starts too late)", log.source)
    idx = first[:, None] + np.arange(samples)[None, :]
    return log.gyro_rad_per_s[idx], log.accel_m_per_s2[idx]

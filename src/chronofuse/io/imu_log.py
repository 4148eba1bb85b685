"""IMU logs as CSV: the columns, their units, and the blocks of samples between GNSS epochs.

Columns (a header row; order free, other columns ignored):

* time, one of: ``gps_ns`` (int64 ns since 1980-01-06, GPS time), or ``gps_week`` with ``tow_s``, or ``t_s``
  (seconds from any origin; then the caller gives the GPS time of ``t_s = 0``);
* angular rate of the body frame (x forward, y right, z down) against inertial space, the average over
  the sample interval: ``gyro_x_rad_per_s``, ``gyro_y_rad_per_s``, ``gyro_z_rad_per_s`` (or ``..._deg_per_s``);
* specific force, the same axes and averaging: ``accel_x_m_per_s2``, ``accel_y_m_per_s2``,
  ``accel_z_m_per_s2`` (or ``..._g``, standard gravity 9.80665 m/s^2).

The samples must be at one rate (the median interval; an interval more than 1 % off it, or a time going
back, is refused naming its line; with ``allow_gaps`` a longer interval is kept as a gap); a missing value, or text where a number belongs, is refused naming line
and column; ``gps_ns`` must be written as an integer (a float64 such as ``1.4e18`` cannot hold a GPS time
to the nanosecond). One unit per quantity: a log with both the rad/s and the deg/s gyro columns (or both
m/s^2 and g) is refused, as the two could disagree. Plausibility: a rate beyond :data:`MAX_GYRO_RAD_PER_S`
(100 rad/s, 5,730 deg/s, past the full scale of navigation IMUs, 2,000-4,000 deg/s for MEMS parts) or a
specific force beyond :data:`MAX_ACCEL_M_PER_S2` (2,000 m/s^2, about 200 g) is refused naming its line: it
is a unit or column mistake, not motion. :func:`imu_blocks`
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

__all__ = ["ImuLog", "MAX_ACCEL_M_PER_S2", "MAX_GYRO_RAD_PER_S", "read_imu_csv", "imu_blocks", "write_imu_csv"]

#: Plausibility limits of the samples (module docstring): |rate| and |specific force| per axis.
MAX_GYRO_RAD_PER_S = 100.0
MAX_ACCEL_M_PER_S2 = 2000.0
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


def _numbers(frame: pd.DataFrame, name: str, source: str) -> np.ndarray:
    """Column ``name`` as float64; text or a missing value is refused naming its line."""
    column = frame[name]
    values = pd.to_numeric(column, errors="coerce").to_numpy(dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        k = int(bad[0])
        text = column.iloc[k]
        what = "no value" if pd.isna(text) or not str(text).strip() else f"{str(text).strip()!r} is not a finite number"
        raise InputDataError(f"line {k + 2}: {what} in column {name}", source)
    return values


def _integer_ns(frame: pd.DataFrame, name: str, source: str) -> np.ndarray:
    """Column ``name`` (read as text) as int64 ns: each value an integer as written, never through a float."""
    texts = frame[name]
    out = np.empty(len(texts), dtype=np.int64)
    for k, text in enumerate(texts):
        word = "" if pd.isna(text) else str(text).strip()
        if not word:
            raise InputDataError(f"line {k + 2}: no value in column {name}", source)
        if not word.lstrip("+-").isdigit():
            raise InputDataError(f"line {k + 2}: {name} == {word!r}, must be an integer number of nanoseconds (a "
                                 "float such as 1.4e18 cannot hold a GPS time to the nanosecond)", source)
        value = int(word)
        if not 0 <= value < 2**63:
            raise InputDataError(f"line {k + 2}: {name} == {word}, out of the int64 range of GPS ns", source)
        out[k] = value
    return out


def _columns(frame: pd.DataFrame, stem: str, units: dict[str, float], source: str, limit: float,
             si_unit: str) -> np.ndarray:
    present = [u for u in units if all(f"{stem}_{a}_{u}" in frame.columns for a in _AXES)]
    if len(present) > 1:
        raise InputDataError(f"both {' and '.join(f'{stem}_x/y/z_{u}' for u in present)} columns: keep one unit "
                             "(the two could disagree)", source)
    for unit in present:
        names = [f"{stem}_{a}_{unit}" for a in _AXES]
        block = np.stack([_numbers(frame, n, source) for n in names], axis=1) * units[unit]
        bad = np.argwhere(np.abs(block) > limit)
        if bad.size:
            row, col = bad[0]
            raise InputDataError(f"line {row + 2}: {names[col]} == {frame[names[col]].iloc[row]}, beyond the "
                                 f"plausible {limit:g} {si_unit} (a unit or column mistake?)", source)
        return block
    wanted = " or ".join(f"{stem}_x/y/z_{u}" for u in units)
    raise InputDataError(f"no {wanted} columns (columns: {', '.join(frame.columns)})", source)


def read_imu_csv(path, *, start_gps_ns: int | None = None, allow_gaps: bool = False) -> ImuLog:
    """Read an IMU log (module docstring). ``start_gps_ns``: GPS time of ``t_s = 0`` for a ``t_s`` column;
    ``allow_gaps``: an interval longer than the log's (a gap: samples lost) is kept, for a caller that
    reports it (:func:`chronofuse.experiments.real_ins.align_imu`); a shorter, repeated or reversed time is
    refused all the same."""
    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise InputDataError("no such file", source)
    try:
        frame = pd.read_csv(path, comment="#", dtype=str, keep_default_na=False)
    except (ValueError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise InputDataError(f"not a readable CSV ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})",
                             source) from None
    frame.columns = [str(c).strip() for c in frame.columns]
    if "gps_ns" in frame.columns:
        t = _integer_ns(frame, "gps_ns", source)
    elif {"gps_week", "tow_s"} <= set(frame.columns):
        week = _numbers(frame, "gps_week", source)
        bad = np.flatnonzero((week != np.round(week)) | (week < 0))
        if bad.size:
            raise InputDataError(f"line {bad[0] + 2}: gps_week == {frame['gps_week'].iloc[bad[0]]}, must be a whole "
                                 "week number >= 0", source)
        t = gps_ns_from_week_tow(week.astype(np.int64), seconds_to_ns(_numbers(frame, "tow_s", source)))
    elif "t_s" in frame.columns:
        if start_gps_ns is None:
            raise InputDataError("a t_s column needs the GPS time of t_s = 0 (start_gps_ns)", source)
        t = int(start_gps_ns) + seconds_to_ns(_numbers(frame, "t_s", source))
    else:
        raise InputDataError("no time column (gps_ns, gps_week + tow_s, or t_s)", source)
    if t.size < 2:
        raise InputDataError("fewer than two samples", source)
    gyro = _columns(frame, "gyro", {"rad_per_s": 1.0, "deg_per_s": math.pi / 180.0}, source, MAX_GYRO_RAD_PER_S,
                    "rad/s")
    accel = _columns(frame, "accel", {"m_per_s2": 1.0, "g": _G0}, source, MAX_ACCEL_M_PER_S2, "m/s^2")
    step = np.diff(t)
    median = float(np.median(step))
    off = (step - median > 0.01 * median) if not allow_gaps else np.zeros(step.shape, dtype=bool)
    bad = np.flatnonzero((step <= 0) | (median - step > 0.01 * median) | off)
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

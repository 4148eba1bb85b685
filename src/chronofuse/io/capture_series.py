"""A receiver recording's clock bias as one time-tagged series: the path from any capture
:func:`chronofuse.io.inspect.read_capture` reads (UBX, NMEA + UBX, gzip or not) to ``chronofuse detect``
and ``chronofuse stability``.

The series is the capture's ``clock_bias_s`` column (UBX-NAV-CLOCK ``clkB``; u-blox interface description,
class 0x01 id 0x22) with its ``clock_drift_s_per_s`` (``clkD``), on the regular grid ``gps_ns[0] + k *
interval`` of integer GPS nanoseconds. The grid is that of the epochs that carry a bias (the solutions;
other epochs of a mixed recording, e.g. NMEA's whole seconds, are not on it); its interval is the median
step between them, rounded to the millisecond (u-blox ``iTOW`` is in ms), or ``1 / rate_hz`` when given.
A receiver tags its solutions on its own clock (``iTOW`` steps by 999 or 1001 ms now and then), so an
epoch may sit :data:`TIME_TOLERANCE` of an interval off its slot; an empty slot (a solution the recording
lacks) is a gap (NaN), never closed up.

NMEA 0183 sentences carry no receiver clock bias (GGA, RMC, ZDA give the time of a fix, not the offset of
the receiver's clock from GNSS time): a recording without NAV-CLOCK is refused with one line saying so.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.io.grid import grid_slots, place_on_grid
from chronofuse.io.inspect import Capture, read_capture
from chronofuse.io.records import KINDS, ClockRecord
from chronofuse.timescale import NS_PER_S
from chronofuse.validation import InputDataError, InputError, InputWarning, check_choice, check_scalar

__all__ = ["ClockBiasSeries", "TIME_TOLERANCE", "capture_clock_series", "read_clock_series", "capture_record"]

#: How far (a fraction of the interval) an epoch may sit off its grid slot: u-blox iTOW steps by 999 or
#: 1001 ms now and then, the receiver tagging its solutions on its own clock.
TIME_TOLERANCE = 0.05
_CLOCK_MESSAGE = "UBX NAV-CLOCK"


@dataclass(frozen=True)
class ClockBiasSeries:
    """One receiver's clock bias on a regular grid of GPS epochs.

    Attributes
    ----------
    gps_ns : ndarray of int64, shape (M,)
        The grid epochs, GPS ns since 1980-01-06 (:mod:`chronofuse.timescale`).
    clock_bias_s, clock_drift_s_per_s : ndarray of float64, shape (M,)
        ``clkB`` (s) and ``clkD`` (s/s); NaN in a gap.
    receiver_ok : ndarray of bool, shape (M,)
        The receiver's own fix status: False where it reported no fix (gpsd mode 1), True where it reported
        a fix or nothing (a gap says nothing bad).
    interval_ns : int
        Grid interval (ns).
    n_missing : int
        Grid epochs without a bias (gaps).
    n_damaged : int
        Frames of the recording lost to damage: UBX checksum failures, truncated frames, frames pyubx2 refused.
    source : str
        The file read.
    jitter_rms_s, jitter_max_s : float
        Rms and largest distance of the solutions' time tags from their grid slots (s).
    time_acc_s : ndarray of float64, shape (M,), or None
        The receiver's time accuracy estimate (NAV-CLOCK ``tAcc``, s; NaN where not reported); None when
        the recording carries none (RINEX).
    """

    gps_ns: np.ndarray
    clock_bias_s: np.ndarray
    clock_drift_s_per_s: np.ndarray
    receiver_ok: np.ndarray
    interval_ns: int
    n_missing: int
    n_damaged: int
    source: str
    jitter_rms_s: float = 0.0
    jitter_max_s: float = 0.0
    time_acc_s: np.ndarray | None = None

    @property
    def interval_s(self) -> float:
        return self.interval_ns / NS_PER_S

    @property
    def rate_hz(self) -> float:
        return NS_PER_S / self.interval_ns


def _no_bias_reason(capture: Capture) -> str:
    """Why a recording gives no clock bias, naming what it holds and what would carry one."""
    if "rinex-obs" in capture.protocols:
        return ("a RINEX observation file holds pseudoranges, not one receiver clock bias: its satellites' clock "
                "biases are tested by clock-bias detection in identification mode, given a navigation file ({nav}) "
                "and the antenna position ({position_m})")
    if "ubx" in capture.protocols:
        held = ", ".join(sorted(capture.ubx.decoded)) or "no decodable UBX navigation message"
        return (f"no {_CLOCK_MESSAGE} message, so no receiver clock bias (the recording holds {held}); enable "
                "NAV-CLOCK output on the receiver")
    if "nmea" in capture.protocols:
        return (f"NMEA 0183 carries no receiver clock bias (only the time of each fix); record {_CLOCK_MESSAGE} "
                "(clkB) messages from a u-blox receiver")
    return f"no receiver epochs decoded, so no clock bias ({_CLOCK_MESSAGE} carries one)"


def _interval_ns(t_ns: np.ndarray, rate_hz: float | None, source: str) -> int:
    if rate_hz is not None:
        check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
        return int(round(NS_PER_S / rate_hz))
    if t_ns.size < 2:
        raise InputError(f"one {_CLOCK_MESSAGE} solution and no {{rate_hz}}: the interval is unknown", source,
                         fields=("rate_hz",))
    step_ms = int(round(float(np.median(np.diff(t_ns))) / 1e6))  # iTOW is in ms
    return step_ms * 1_000_000


def capture_clock_series(capture: Capture, rate_hz: float | None = None) -> ClockBiasSeries:
    """The clock bias of a :class:`~chronofuse.io.inspect.Capture` on its regular grid (see the module).

    Raises :class:`InputDataError` naming the recording when it holds no clock bias (saying which message
    would carry one), has a single solution and no ``rate_hz``, or an epoch off the grid by more than
    :data:`TIME_TOLERANCE` of an interval (the output rate changed).
    """
    rows, source = capture.rows, capture.source
    have = np.isfinite(rows["clock_bias_s"])
    if not have.any():
        raise InputError(_no_bias_reason(capture), source, fields=("nav", "position_m"))
    t_ns = rows["gps_ns"][have]
    interval_ns = _interval_ns(t_ns, rate_hz, source)
    if interval_ns <= 0:
        raise InputError(f"{_CLOCK_MESSAGE} epochs less than 1 ms apart: give the rate ({{rate_hz}})", source,
                         fields=("rate_hz",))
    # offsets from the first bias epoch are small (int64 ns -> float64 exact below 104 days)
    slots, bad = grid_slots((t_ns - t_ns[0]).astype(np.float64), float(interval_ns), TIME_TOLERANCE)
    if bad >= 0:
        step_s = (t_ns[bad] - t_ns[bad - 1]) / NS_PER_S
        raise InputError(
            f"clock solution {bad + 1}: time step {step_s:g} s is not a whole number of "
            f"{interval_ns / NS_PER_S:g} s intervals (the output rate changed; check {{rate_hz}})", source,
            fields=("rate_hz",))
    off_s = ((t_ns - t_ns[0]) - slots * interval_ns) / NS_PER_S
    bias = place_on_grid(slots, rows["clock_bias_s"][have])
    drift = place_on_grid(slots, rows["clock_drift_s_per_s"][have])
    no_fix = place_on_grid(slots, (rows["fix_mode"][have] == 1).astype(np.float64))
    tacc = None if capture.time_acc_s is None else place_on_grid(slots, capture.time_acc_s[have])
    frames = capture.frames
    return ClockBiasSeries(
        gps_ns=t_ns[0] + np.arange(bias.size, dtype=np.int64) * interval_ns,
        clock_bias_s=bias, clock_drift_s_per_s=drift, receiver_ok=~(no_fix == 1.0), interval_ns=interval_ns,
        n_missing=int(np.isnan(bias).sum()),
        n_damaged=int(frames.ubx_bad_checksum + frames.truncated + capture.ubx.parse_errors),
        source=source, jitter_rms_s=float(np.sqrt(np.mean(off_s**2))), jitter_max_s=float(np.abs(off_s).max()),
        time_acc_s=tacc)


def read_clock_series(path: str | Path, rate_hz: float | None = None) -> ClockBiasSeries:
    """:func:`capture_clock_series` of the recording at ``path`` (plain or gzip, told by content)."""
    return capture_clock_series(read_capture(path), rate_hz)


def capture_record(path: str | Path, kind: str = "phase", rate_hz: float | None = None,
                   station: str | None = None) -> ClockRecord:
    """A recording's clock as the phase or frequency record ``chronofuse stability`` analyses: the clock
    bias (phase, s) or the clock drift (``kind="freq"``: fractional frequency, s/s) at the recording's
    interval (``rate_hz`` sets it instead), gaps as NaN; ``t_ns`` holds the GPS epochs. A RINEX clock product
    gives ``station``'s clock, or without one its first station's (with a warning naming it); ``station``
    on any other recording is refused naming the file."""
    check_choice(kind, "kind", KINDS)
    capture = read_capture(path, receiver=station)
    if station is not None and "rinex-clock" not in capture.protocols:
        raise InputError("{station} picks a station of a RINEX clock product (.clk); this recording has "
                         "one receiver", str(path), fields=("station",))
    if station is None and len(capture.receivers) > 1:
        warnings.warn(InputWarning(f"{path}: a RINEX clock product of {len(capture.receivers)} stations: the first, "
                                   f"{capture.receivers[0]}, is analysed ({{station}} picks any)", fields=("station",)),
                      stacklevel=2)
    series = capture_clock_series(capture, rate_hz)
    values, column = ((series.clock_bias_s, "clock_bias_s") if kind == "phase"
                      else (series.clock_drift_s_per_s, "clock_drift_s_per_s"))
    if np.isnan(values).all():
        raise InputDataError(f"every {column} value is missing", series.source)
    return ClockRecord(values=values, rate_hz=series.rate_hz, kind=kind, t_ns=series.gps_ns, source=series.source,
                       n_gaps=int(np.isnan(values).sum()), column=column, jitter_rms_s=series.jitter_rms_s,
                       jitter_max_s=series.jitter_max_s)

"""A receiver recording's clock bias as one gridded record: the path from any capture
:func:`chronofuse.io.inspect.read_capture` reads (UBX, NMEA + UBX, RINEX clock, gzip or not) to
``chronofuse detect`` and ``chronofuse stability``.

The series is the capture's ``clock_bias_s`` column (UBX-NAV-CLOCK ``clkB``; u-blox interface description,
class 0x01 id 0x22) with its ``clock_drift_s_per_s`` (``clkD``), time accuracy ``time_acc_s`` (``tAcc``) and
the receiver's ``fix_mode``, as an :class:`~chronofuse.record.EpochRecord` on the regular grid ``t0 + k *
interval`` of integer GPS nanoseconds (:class:`chronofuse.io.grid.GridPlacer`). The grid is that of the
epochs that carry a bias (the solutions; other epochs of a mixed recording, e.g. NMEA's whole seconds, are
not on it); its interval is the lower median of the first steps between them, a whole number of
milliseconds (u-blox ``iTOW`` is in ms), or ``1 / rate_hz`` when given. A receiver tags its solutions on its
own clock (``iTOW`` steps by 999 or 1001 ms now and then), so an epoch may sit :data:`TIME_TOLERANCE` of an
interval off its slot; an empty slot (a solution the recording lacks) is a gap (NaN), never closed up. The
same placement runs on a live stream, so ``detect FILE`` and ``detect -`` see the same epochs.

NMEA 0183 sentences carry no receiver clock bias (GGA, RMC, ZDA give the time of a fix, not the offset of
the receiver's clock from GNSS time): a recording without NAV-CLOCK is refused with one line saying so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from chronofuse.io.grid import GridPlacer
from chronofuse.io.inspect import Capture, read_capture
from chronofuse.record import EpochRecord
from chronofuse.validation import InputDataError, InputError, check_scalar

__all__ = ["TIME_TOLERANCE", "CLOCK_COLUMNS", "capture_clock_series", "clock_grid", "clock_epochs",
           "no_bias_reason", "read_clock_series"]

#: How far (a fraction of the interval) an epoch may sit off its grid slot: u-blox iTOW steps by 999 or
#: 1001 ms now and then, the receiver tagging its solutions on its own clock.
TIME_TOLERANCE = 0.05
#: u-blox ``iTOW`` is in milliseconds: a recording's interval is a whole number of them.
RESOLUTION_NS = 1_000_000
#: The columns of a receiver's clock series (those the recording has).
CLOCK_COLUMNS = ("clock_bias_s", "clock_drift_s_per_s", "time_acc_s", "fix_mode")
_CLOCK_MESSAGE = "UBX NAV-CLOCK"


def no_bias_reason(protocols: tuple, decoded=()) -> str:
    """Why a recording gives no clock bias, naming what it holds and what would carry one."""
    if "rinex-obs" in protocols:
        return ("a RINEX observation file holds pseudoranges, not one receiver clock bias: its satellites' clock "
                "biases are tested by clock-bias detection in identification mode, given a navigation file ({nav}) "
                "and the antenna position ({position_m})")
    if "ubx" in protocols:
        held = ", ".join(sorted(decoded)) or "no decodable UBX navigation message"
        return (f"no {_CLOCK_MESSAGE} message, so no receiver clock bias (the recording holds {held}); enable "
                "NAV-CLOCK output on the receiver")
    if "nmea" in protocols:
        return (f"NMEA 0183 carries no receiver clock bias (only the time of each fix); record {_CLOCK_MESSAGE} "
                "(clkB) messages from a u-blox receiver")
    return f"no receiver epochs decoded, so no clock bias ({_CLOCK_MESSAGE} carries one)"


def clock_epochs(record: EpochRecord) -> EpochRecord | None:
    """The epochs of a receiver record that carry a clock bias, with the :data:`CLOCK_COLUMNS` it has
    (None when none does)."""
    have = np.isfinite(record.column("clock_bias_s"))
    if not have.any():
        return None
    keep = [name for name in CLOCK_COLUMNS if name in record]
    part = record.take(have)
    return EpochRecord(t_ns=part.t_ns, columns={n: part.columns[n] for n in keep}, units={n: part.units[n] for n in keep},
                       valid=part.valid, provenance=part.provenance, time_scale=part.time_scale, info=part.info)


def clock_grid(rate_hz: float | None = None) -> GridPlacer:
    """The grid a recording's clock series is placed on (module docstring): ``1 / rate_hz``, or learnt."""
    interval_ns = None
    if rate_hz is not None:
        check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
        interval_ns = int(round(1e9 / rate_hz))
        if interval_ns <= 0:
            raise InputDataError(f"a rate of {rate_hz:g} Hz is under 1 ns per epoch")
    return GridPlacer(interval_ns, resolution_ns=RESOLUTION_NS, tolerance=TIME_TOLERANCE)


def capture_clock_series(capture: Capture, rate_hz: float | None = None) -> EpochRecord:
    """The clock bias of a :class:`~chronofuse.io.inspect.Capture` on its regular grid (see the module).

    Raises :class:`InputDataError` naming the recording when it holds no clock bias (saying which message
    would carry one), has a single solution and no ``rate_hz``, or an epoch off the grid by more than
    :data:`TIME_TOLERANCE` of an interval (the output rate changed).
    """
    epochs = clock_epochs(capture.record())
    if epochs is None:
        raise InputError(no_bias_reason(capture.protocols, capture.ubx.decoded), capture.source,
                         fields=("nav", "position_m"))
    placer = clock_grid(rate_hz)
    return EpochRecord.concat([placer.push(epochs), placer.close()])


def read_clock_series(path: str | Path, rate_hz: float | None = None, station: str | None = None) -> EpochRecord:
    """:func:`capture_clock_series` of the recording at ``path`` (plain or gzip, told by content; ``station``
    picks a RINEX clock product's station)."""
    return capture_clock_series(read_capture(path, receiver=station), rate_hz)

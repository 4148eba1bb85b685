"""A real receiver's 1PPS phase record against a reference clock: the truth a disciplined oscillator is
run against (``chronofuse gnssdo --reference``). One value column (or time and value), or a field log's
clock (a ts2phc or phc2sys offset, a TSIP receiver's PPS offset), 1 Hz, no gaps, and values that can be a
1PPS phase in seconds (not a frequency, another unit, or a ramp)."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np

from chronofuse.io.formats import log_format
from chronofuse.io.records import read_record
from chronofuse.validation import InputError

__all__ = ["read_pps_reference"]


def _data_line(path: Path, index: int) -> int:
    """1-based file line of the ``index``-th data line (0-based) of a text record, for error messages."""
    opener = gzip.open if path.suffix == ".gz" else open
    count = -1
    with opener(path, "rt") as fh:
        for lineno, line in enumerate(fh, start=1):
            text = line.split("#")[0].strip()
            if text and (text[0].isdigit() or text[0] in "+-.n"):
                count += 1
                if count == index:
                    return lineno
    return lineno


def read_pps_reference(path: str | Path, *, min_samples: int = 2) -> np.ndarray:
    """The 1PPS phase (s, shape (N,)) of the record at ``path``, sampled at 1 Hz without gaps: any record
    :func:`~chronofuse.io.records.read_record` reads, a field log's first clock among them.

    Refused, naming the file and line: another rate than 1 Hz (from a time column), any gap, fewer
    than ``min_samples`` samples, and values that cannot be a 1PPS phase in seconds
    (:func:`_check_pps_phase`: a frequency, another unit, a ramp).
    """
    path = Path(path)
    try:  # the time column, when there is one, says the rate (a rate given here would override it)
        rec = read_record(path, kind="phase")
    except InputError:
        rec = read_record(path, kind="phase", rate_hz=1.0)
    if not math.isclose(rec.rate_hz, 1.0, rel_tol=1e-6):
        raise InputError(f"the time column gives a rate of {rec.rate_hz:g} Hz; the reference record must be "
                         "sampled at 1 Hz", str(path), _data_line(path, 1))
    if rec.n_gaps:
        first = int(np.flatnonzero(np.isnan(rec.values))[0])
        # a field log's lines are not one sample each: its gap is named by sample (and time), not by line
        line = None if log_format(path) else _data_line(path, first)
        raise InputError(f"gap in the reference record ({rec.n_gaps} missing samples, the first at sample "
                         f"{first}); the loop needs one sample every second", str(path), line)
    if rec.values.size < min_samples:
        raise InputError(f"{rec.values.size} samples, need at least {min_samples}", str(path))
    _check_pps_phase(rec.values, path)
    return rec.values


#: What a receiver's 1PPS against a reference clock can look like (in seconds, once read): within this of its
#: median (antenna and cable offsets are constant; a GNSS 1PPS wanders by tens of ns), drifting by at most
#: this fractional frequency (the reference is a clock, the 1PPS steered to GNSS time), and moving by at least
#: this rms from second to second (a timing receiver's 1PPS jitters by a nanosecond or more, the real GPS
#: record in tests/data by 5.1 ns; a fractional-frequency record read as phase moves by 1e-11).
REFERENCE_MAX_SPREAD_S = 10e-6
REFERENCE_MAX_SLOPE = 1e-9
REFERENCE_MIN_JITTER_S = 1e-10


def _check_pps_phase(x: np.ndarray, path: Path) -> None:
    """Refuse, naming the file and line, a record that is not a 1PPS phase against a reference clock in
    seconds: a frequency (in Hz, or fractional), another unit read as seconds, or a ramp."""
    field_log = bool(log_format(path))

    def _line(k: int) -> int | None:  # a field log's lines are not one sample each
        return None if field_log else _data_line(path, k)

    median = float(np.median(x))
    if abs(median) > 1.0:
        raise InputError(f"values of order {median:.6g}: not a 1PPS phase in seconds (a frequency in Hz, or a phase "
                         "in ns or us without a unit in the header?)", str(path), _line(0))
    far = np.flatnonzero(np.abs(x - median) > REFERENCE_MAX_SPREAD_S)
    if far.size:
        k = int(far[0])
        raise InputError(f"{x[k]:.6g} s is {x[k] - median:+.3g} s from the record's median; a 1PPS against a reference "
                         f"stays within {REFERENCE_MAX_SPREAD_S:g} s (values in ns or us without a unit header? a "
                         "free-running clock?)", str(path), _line(k))
    t = np.arange(x.size, dtype=np.float64)
    slope = float(np.polyfit(t, x, 1)[0])
    if abs(slope) > REFERENCE_MAX_SLOPE:
        raise InputError(f"the record drifts by {slope:.3g} s/s over its {x.size} samples; a 1PPS against a "
                         f"reference clock drifts by less than {REFERENCE_MAX_SLOPE:g} (a ramp: the reference is "
                         "not a clock, or the record is not a 1PPS)", str(path), _line(x.size - 1))
    jitter = float(np.sqrt(np.mean(np.diff(x) ** 2)))
    if jitter < REFERENCE_MIN_JITTER_S:
        raise InputError(f"consecutive values differ by {jitter:.3g} s rms; a receiver's 1PPS jitters by far more "
                         "(a fractional-frequency record read as phase?)", str(path), _line(1))

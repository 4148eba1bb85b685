"""Time tags as users write them, to exact integer nanoseconds: numbers in a unit, or date-time stamps.

Numbers (``decimal_text_to_ns`` in :mod:`chronofuse.io.columns` does the exact conversion) take their
unit from the column name (``mjd``; ``_s``, ``_ms``, ``_us``, ``_ns``; ``Time (s)``); without one, from
their magnitude, with a warning that says what was assumed:

- 40 000 to 100 000 with steps under half a day: MJD days (the Stable32/TimeLab time-tag layout);
- 9e11 to 4.2e12, 9e14 to 4.2e15, 9e17 to 4.2e18: UNIX milliseconds, microseconds, nanoseconds (years
  1998 to 2103: read as seconds they would be tens of millennia away);
- anything else: seconds, warned as implausible when the sample interval comes out under 1 ns or over
  a day.

Date-time stamps: ISO 8601 (``2023-01-05T12:34:56.123456789``, a space instead of ``T``, ``/`` instead
of ``-``, a decimal comma in the seconds, optionally ``Z``, ``+hh:mm`` or the word ``UTC``/``GMT``), ``dd.mm.yyyy hh:mm:ss[.f]``, and a date and a clock time in
two white-space separated fields. Stamps with a zone are converted to UTC; stamps without are read as
written (only their differences matter here); a mix of the two is refused, and so is a ``nn/nn/yyyy``
date, whose day and month order cannot be told. Parsing is pyarrow's (exact to the nanosecond).
"""

from __future__ import annotations

import re
import warnings
from fractions import Fraction

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from chronofuse.validation import InputDataError

__all__ = ["is_date_time", "is_date", "is_clock", "date_time_to_ns", "infer_time_unit", "MJD_RANGE"]

_ISO = re.compile(r"^\d{4}[-/]\d{2}[-/]\d{2}(?:[T ]\d{2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?)?(?:Z|[+-]\d{2}:?\d{2}| ?UTC| ?GMT)?$")
_DMY = re.compile(r"^\d{2}\.\d{2}\.\d{4}(?: \d{2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?)?$")
_AMBIGUOUS = re.compile(r"^\d{1,2}/\d{1,2}/\d{4}")
_DATE = re.compile(r"^(?:\d{4}[-/]\d{2}[-/]\d{2}|\d{2}\.\d{2}\.\d{4}|\d{1,2}/\d{1,2}/\d{4})$")
_CLOCK = re.compile(r"^\d{2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?(?:Z|[+-]\d{2}:?\d{2}| ?UTC| ?GMT)?$")
#: A clock time followed by the word UTC or GMT (``2023-03-26 00:00:00 UTC``): the zone Z.
UTC_WORD = re.compile(r"(\d{2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?)\s*(?:UTC|GMT)\b")

#: MJD of the Stable32/TimeLab time-tag layout (1968 to 2132).
MJD_RANGE = (40_000.0, 100_000.0)
_UNIX_S = (9e8, 4.2e9)  # 1998 .. 2103
_NS_PER = {"s": 1_000_000_000, "ms": 1_000_000, "us": 1_000, "ns": 1}


def is_date_time(token: str) -> bool:
    """Whether ``token`` is a date-time stamp (or one this reader refuses as ambiguous, to say so)."""
    return bool(_ISO.match(token) or _DMY.match(token) or _AMBIGUOUS.match(token))


def is_date(token: str) -> bool:
    """A date alone (``2023-01-05``, ``05.01.2023``), the first of two fields of a date and a time."""
    return bool(_DATE.match(token))


def is_clock(token: str) -> bool:
    """A clock time alone (``12:34:56.5``), the second of two fields of a date and a time."""
    return bool(_CLOCK.match(token))


def date_time_to_ns(text: pa.Array, source: str, line_of) -> np.ndarray:
    """Integer nanoseconds (N,) of date-time stamps ``text`` (module docstring).

    ``line_of(k)`` gives the file line of stamp ``k`` for the error that names a stamp it cannot read.
    """
    s = pc.utf8_trim_whitespace(pc.cast(text, pa.string()))
    ambiguous = pc.match_substring_regex(s, r"^\d{1,2}/\d{1,2}/\d{4}")
    if pc.any(ambiguous).as_py():
        k = int(np.flatnonzero(ambiguous.to_numpy(zero_copy_only=False))[0])
        raise InputDataError(f"{s[k].as_py()!r}: day and month order cannot be told; write ISO 8601 dates "
                             "(2023-01-05T12:00:00)", source, line_of(k))
    s = pc.replace_substring_regex(s, r"^(\d{2})\.(\d{2})\.(\d{4})", r"\3-\2-\1")
    s = pc.replace_substring_regex(s, r"^(\d{4})/(\d{2})/(\d{2})", r"\1-\2-\3")
    s = pc.replace_substring_regex(s, r"(:\d{2}),(\d+)", r"\1.\2")  # a decimal comma in the seconds
    s = pc.replace_substring_regex(s, r"\s*(?:UTC|GMT)$", "Z")  # "2023-03-26 00:00:00 UTC"
    zoned = pc.match_substring_regex(s, r"(Z|[+-]\d{2}:?\d{2})$")
    n_zoned = int(pc.sum(zoned).as_py() or 0)
    if 0 < n_zoned < len(s):
        mask = zoned.to_numpy(zero_copy_only=False)
        k = int(np.flatnonzero(mask != mask[0])[0])
        raise InputDataError(f"time stamp {s[k].as_py()!r} {'has' if mask[k] else 'has no'} time zone where the "
                             f"first ({s[0].as_py()!r}) {'has' if mask[0] else 'has none'}", source, line_of(k))
    target = pa.timestamp("ns", tz="UTC") if n_zoned else pa.timestamp("ns")
    try:
        return s.cast(target).cast(pa.int64()).to_numpy(zero_copy_only=False).astype(np.int64, copy=False)
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        for k in range(len(s)):  # name the first stamp pyarrow cannot read
            try:
                pa.array([s[k].as_py()]).cast(target)
            except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
                raise InputDataError(f"cannot read {text[k].as_py()!r} as a time stamp", source, line_of(k)) from None
        raise


def infer_time_unit(text: pa.Array, name: str, source: str) -> int | Fraction | None:
    """For a time column of numbers ``text`` whose name gives no unit: the unit their magnitude says they
    are in (ns per unit), with a warning; None when seconds is right. Only the first values are looked at
    (the reader passes the up to 200 it sniffed; as float64: enough for a magnitude)."""
    head = pc.cast(pc.utf8_trim_whitespace(pc.cast(text.slice(0, 10_001), pa.string())), pa.float64())
    t = head.to_numpy(zero_copy_only=False)
    if t.size == 0:
        return None
    first_s = abs(float(t[0]))
    step_s = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    label = f"time column {name!r}" if name else "the first column"
    if MJD_RANGE[0] <= first_s < MJD_RANGE[1] and 0 < step_s < 0.5:
        warnings.warn(f"{source}: {label} ({first_s:g}, steps of {step_s:.6g}) read as MJD days, the Stable32/"
                      "TimeLab time-tag layout; name the column 'mjd' to say so", stacklevel=4)
        return 86_400 * 1_000_000_000
    for unit, factor in (("ms", 1e3), ("us", 1e6), ("ns", 1e9)):
        if _UNIX_S[0] * factor <= first_s < _UNIX_S[1] * factor:
            warnings.warn(f"{source}: {label} ({first_s:.6g}) read as UNIX {dict(ms='milliseconds', us='microseconds', ns='nanoseconds')[unit]}"
                          f" (as seconds it would be {first_s / 3.15576e7:,.0f} years from 1970); name its unit "
                          f"({name or 'time'}_{unit}) to say so", stacklevel=4)
            return _NS_PER[unit]
    if t.size > 1 and not (1e-9 <= step_s <= 86_400.0):
        warnings.warn(f"{source}: {label} read as seconds gives a sample interval of {step_s:.3g} s, implausible "
                      "for a clock record; if the column is in other units, name them (e.g. t_ms, mjd)", stacklevel=4)
    return None

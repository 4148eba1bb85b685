"""Units as users write them in column names and header blocks: ``Phase (ns)``, ``phase[us]``, ``x_ps``,
``f_offset_Hz``, ``y_ppb``, ``Time (s)``, ``# phase data, unit: s``, ``# data interval 1 s``.

:func:`column_unit` reads a column name's unit; :func:`header_facts` reads what a comment line or an
instrument's header block says about the units of the values and the sample interval. Both return None
when the text says nothing, so that the reader can tell "no unit written" from "a unit of 1".

Units and what they scale to (SI: seconds, dimensionless fractional frequency, hertz):

- time/phase: ``s``, ``sec``, ``ms``, ``us``/``µs``/``μs``, ``ns``, ``ps``, ``fs``; ``min``/``minutes``,
  ``h``/``hr``/``hours``, ``d``/``day``/``days``; a whole or decimal multiple before a unit, ``10ns``,
  ``[100 ps]``: a value of 3 is 30 ns;
- fractional frequency: ``ppm`` (1e-6), ``ppb`` (1e-9), ``ppt`` (1e-12), ``ffd``/``1`` (1);
- frequency in hertz (an offset or an absolute frequency; the nominal frequency is needed to make a
  fractional frequency of it): ``Hz``, ``mHz``, ``uHz``/``µHz``, ``kHz``, ``MHz`` (case matters for the
  prefixes ``m`` and ``M``; ``hz`` alone is hertz);
- a numeric scale factor in brackets, alone or before a unit: ``y[1e-12]``, ``y (1e-12)``, ``x[x1e-15]``,
  ``phase (1e-9 s)``, ``y [×10^-12]``: a value of 3.2 is 3.2e-12. Alone, it is a ``"factor"`` whose
  quantity the column's name or the kind decides (phase in seconds, or fractional frequency).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["ColumnUnit", "column_unit", "header_facts", "HeaderFacts", "INDEX_NAMES"]

_TIME = {"s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6,
         "μs": 1e-6, "usec": 1e-6, "ns": 1e-9, "nsec": 1e-9, "ps": 1e-12, "fs": 1e-15, "d": 86400.0,
         "day": 86400.0, "days": 86400.0, "min": 60.0, "mins": 60.0, "minute": 60.0, "minutes": 60.0,
         "h": 3600.0, "hr": 3600.0, "hrs": 3600.0, "hour": 3600.0, "hours": 3600.0}
_FRACTION = {"ppm": 1e-6, "ppb": 1e-9, "ppt": 1e-12, "ffd": 1.0, "1": 1.0}
_HERTZ = {"Hz": 1.0, "hz": 1.0, "HZ": 1.0, "mHz": 1e-3, "uHz": 1e-6, "µHz": 1e-6, "μHz": 1e-6, "kHz": 1e3,
          "KHz": 1e3, "MHz": 1e6}

#: Column names that count samples, never a time: ``Reading #`` is no time column in seconds.
INDEX_NAMES = {"sample", "samples", "reading", "readings", "index", "idx", "n", "no", "nr", "num", "number", "#",
               "count", "point", "points", "reading #", "sample #", "point #", "record"}

# "Phase (ns)", "phase[us]", "x_ps", "t/s", "Frequency offset in Hz"
_BRACKETED = re.compile(r"[\(\[]\s*([^\)\]]+?)\s*[\)\]]\s*$")
_SUFFIX = re.compile(r"[_/]([A-Za-zµμ]+)$")
_IN_UNIT = re.compile(r"\bin\s+([A-Za-zµμ]+)\s*$", re.IGNORECASE)


@dataclass(frozen=True)
class ColumnUnit:
    """A unit read from a name: ``quantity`` is ``"time"`` (seconds), ``"fraction"`` (fractional frequency),
    ``"hertz"``, or ``"factor"`` (a bare scale factor, ``[1e-12]``: seconds or fractional frequency, as the
    kind says); ``scale`` converts the written values to that quantity's SI unit; ``text`` as written."""

    quantity: str
    scale: float
    text: str


# "1e-12", "x1e-15", "×1e-9", "*1E-12", "10^-12", "x10^-9", optionally followed by a unit ("1e-9 s")
_FACTOR = re.compile(r"^(?:[x×*]\s*)?(?:(\d+(?:\.\d*)?)[eE]([+-]?\d+)|10\s*\^\s*\(?([+-]?\d+)\)?)\s*(.*)$")


def _factor(token: str) -> ColumnUnit | None:
    """A numeric scale factor, alone (quantity ``"factor"``) or before a unit (that unit, scaled)."""
    match = _FACTOR.match(token)
    if not match:
        return None
    mantissa, exponent, power, rest = match.groups()
    scale = float(f"{mantissa}e{exponent}") if mantissa is not None else 10.0 ** int(power)
    if not scale > 0:
        return None
    if not rest.strip():
        return ColumnUnit("factor", scale, f"units of {token}")
    unit = _lookup(rest, factors=False)
    return None if unit is None else ColumnUnit(unit.quantity, scale * unit.scale, token)


# "10ns", "100 ps", "0.5 us": a multiple of a unit
_MULTIPLE = re.compile(r"^(\d+(?:\.\d*)?)\s*([A-Za-zµμ]+)$")


def _lookup(token: str, factors: bool = True) -> ColumnUnit | None:
    token = token.strip()
    if factors and token[:1] in "0123456789x×*":
        found = _factor(token)
        if found is not None:
            return found
        multiple = _MULTIPLE.match(token)
        if multiple and float(multiple.group(1)) > 0:
            unit = _lookup(multiple.group(2), factors=False)
            if unit is not None and unit.quantity != "factor":
                return ColumnUnit(unit.quantity, float(multiple.group(1)) * unit.scale, token)
    if token in _HERTZ:
        return ColumnUnit("hertz", _HERTZ[token], token)
    lowered = token.lower()
    if lowered in _TIME:
        return ColumnUnit("time", _TIME[lowered], token)
    if lowered in _FRACTION:
        return ColumnUnit("fraction", _FRACTION[lowered], token)
    return None


def column_unit(name: str) -> ColumnUnit | None:
    """The unit a column name carries (``(ns)``, ``[us]``, ``_Hz``, ``_ppb``, ``/s``, ``in ns``), or None."""
    name = name.strip().strip('"').strip()
    for pattern in (_BRACKETED, _SUFFIX, _IN_UNIT):
        match = pattern.search(name)
        if match:
            unit = _lookup(match.group(1))
            if unit is not None:
                return unit
    return None


@dataclass(frozen=True)
class HeaderFacts:
    """What a header block said: the values' unit (or None) and the sample interval in seconds (or None),
    each with the 1-based line it was read from."""

    unit: ColumnUnit | None = None
    unit_line: int = 0
    interval_s: float | None = None
    interval_line: int = 0
    time_unit: ColumnUnit | None = None
    time_unit_line: int = 0


_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
# one clause of a header line: "phase units: ns", "time unit = s", "unit: s" (the clauses split at , and ;)
_UNIT_LINE = re.compile(r"(?:^|\b([A-Za-z]+)\s+)units?\s*[:=]?\s*\(?\s*([A-Za-zµμ]+)\s*\)?\s*$", re.IGNORECASE)
#: The word before "unit(s)" that makes a clause the time column's: its unit is not the values'.
_TIME_CLAUSE = {"time", "t", "epoch", "timestamp", "tag", "mjd"}
#: Words before "unit(s)" that name the values (or none: "unit: s").
_VALUE_CLAUSE = {"phase", "frequency", "freq", "value", "values", "data", "x", "y", "te", "offset", "measurement"}
_INTERVAL_LINE = re.compile(
    rf"\b(?:data|sample|sampling|measurement)\s+(?:interval|period)\s*[:=,]?\s*({_NUMBER})\s*([A-Za-zµμ]*)"
    rf"|\btau\s*0?\s*[:=]\s*({_NUMBER})\s*([A-Za-zµμ]*)", re.IGNORECASE)


def header_facts(lines: list[tuple[int, str]]) -> HeaderFacts:
    """Units and sample interval stated in comment or header-block lines ``(line number, text)``.

    ``# phase data, unit: s`` gives the unit; ``# data interval 1 s``, ``Sample Interval,1.0E-01`` or
    ``tau0 = 10 s`` the interval (seconds when no unit follows). Each clause (split at ``,`` and ``;``) is
    read on its own: in ``# phase units: ns, time units: s`` the values are in ns and the time tags in s
    (``time_unit``). A clause naming something else (``temperature units: C``) is left alone, as is
    anything else.
    """
    unit, unit_line, interval, interval_line = None, 0, None, 0
    time_unit, time_unit_line = None, 0
    for lineno, text in lines:
        body = text.strip().lstrip("#;").strip().replace('"', " ")
        for clause in re.split(r"[,;]", body):
            match = _UNIT_LINE.search(clause.strip())
            if not match:
                continue
            word = (match.group(1) or "").lower()
            found = _lookup(match.group(2))
            if found is None:
                continue
            if word in _TIME_CLAUSE:
                if time_unit is None and found.quantity == "time":
                    time_unit, time_unit_line = found, lineno
            elif (not word or word in _VALUE_CLAUSE) and unit is None:
                unit, unit_line = found, lineno
        if interval is None:
            match = _INTERVAL_LINE.search(body)
            if match:
                number, suffix = (match.group(1), match.group(2)) if match.group(1) else (match.group(3), match.group(4))
                scale = _TIME.get(suffix.lower(), None) if suffix else 1.0
                if scale is not None and float(number) > 0:
                    interval, interval_line = float(number) * scale, lineno
    return HeaderFacts(unit, unit_line, interval, interval_line, time_unit, time_unit_line)

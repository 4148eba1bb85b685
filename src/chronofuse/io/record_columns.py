"""Which columns of a record file hold the time and the values, what the values are, and in which unit.

- The time column: a name meaning time (``t``, ``time``, ``mjd``, ``epoch``, ``unix``, ``timestamp``,
  ``date``, ``t_*``, ``Time (s)``), else a column of date-time stamps, else the first of two columns.
  Columns that count samples (``Sample``, ``Reading #``, ``index``, ...) are never a time column: a
  count read as seconds would set a rate the file never stated.
- The value column: ``column`` (name or 1-based number), else the one column left after the time and the
  sample counts.
- The kind (phase or fractional frequency) and the scale to SI: from the value column's unit
  (:func:`chronofuse.io.units.column_unit`: ``(ns)`` is phase, ``_ppb`` frequency; a bare scale factor,
  ``y[1e-12]``, scales whichever kind the name or the caller gives), else from a
  ``unit:`` line of the header block, else from its name (``phase``/``x``/``te``/``tie``: phase;
  ``freq``/``frequency``/``y``: frequency); a kind the caller gives that contradicts the unit is refused.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

from chronofuse.io.columns import Layout
from chronofuse.io.units import INDEX_NAMES, ColumnUnit, HeaderFacts, column_unit
from chronofuse.timescale import NS_PER_S, SECONDS_PER_DAY
import numpy as np

from chronofuse.validation import InputDataError, InputError, InputWarning, check_scalar

__all__ = ["ColumnChoice", "choose_columns", "base_name", "time_ns_per_unit", "TIME_NAMES", "to_si", "check_frequency",
           "check_phase_steps", "record_notes", "PLAUSIBLE_Y"]

#: Fractional frequency beyond this magnitude is implausible for a clock (warned, or refused when narrow).
PLAUSIBLE_Y = 1e-3

TIME_NAMES = {"t", "time", "mjd", "epoch", "unix", "timestamp", "date", "datetime", "date time", "utc", "gps time",
              "time stamp", "tag", "time tag"}
_PHASE_WORDS = {"phase", "x", "te", "tie", "time error", "time interval", "ti", "offset", "clock bias", "bias"}
_FREQ_WORDS = {"freq", "frequency", "y", "ffd", "fractional frequency", "frequency offset", "f_offset", "df"}


def base_name(name: str) -> str:
    """The name without its unit: ``Time (s)`` -> ``time``, ``te_ns`` -> ``te``, ``phase[us]`` -> ``phase``."""
    lowered = name.strip().strip('"').lower()
    lowered = re.sub(r"\s*[\(\[][^\)\]]*[\)\]]\s*$", "", lowered)
    if column_unit(name) is not None:
        lowered = re.sub(r"[_/][a-zµμ]+$", "", lowered)
        lowered = re.sub(r"\s+in\s+[a-zµμ]+$", "", lowered)
    return lowered.strip()


def time_ns_per_unit(name: str) -> int | Fraction | None:
    """Nanoseconds per unit of a time column named ``name`` (``mjd``/days; ``_s``, ``_ms``, ``(us)``, ...),
    or None when the name gives no unit."""
    lowered = name.strip().lower()
    if lowered == "mjd" or lowered.startswith("mjd_") or base_name(name) == "mjd":
        return SECONDS_PER_DAY * NS_PER_S
    unit = column_unit(name)
    if unit is not None and unit.quantity in ("time", "factor"):
        return Fraction(unit.scale).limit_denominator(10**15) * NS_PER_S
    return None


@dataclass(frozen=True)
class ColumnChoice:
    """The columns read and what they hold.

    ``time_field`` / ``value_field``: field indices in the file (None: no time column); ``time_name`` and
    ``value_name`` as written (or the 1-based number); ``kind``: ``"phase"`` or ``"freq"``; ``unit``: the
    values' unit (None: SI as they are); ``unit_from``: where it was read (``"name"``, ``"header line N"``).
    """

    time_field: int | None
    value_field: int
    time_name: str
    value_name: str
    kind: str
    unit: ColumnUnit | None
    unit_from: str


def _field(layout: Layout, logical: int) -> int:
    """Field index of logical column ``logical`` (a date and a clock time in two fields are one column)."""
    return logical + 1 if layout.pair is not None and logical > layout.pair else logical


def column_index(layout: Layout, path: Path, column: str) -> int:
    """Logical index of ``column`` (a header name, or a 1-based number) in ``layout``; an unknown one is an
    :class:`InputDataError` listing the columns."""
    logical = layout.width - (layout.pair is not None)
    names = layout.header if layout.header is not None else [str(i + 1) for i in range(logical)]
    if column in names:
        return names.index(column)
    if column.isdigit() and 1 <= int(column) <= logical:
        return int(column) - 1
    raise InputDataError(f"column {column!r} not found; columns are {names} (or 1..{logical})", str(path),
                         layout.header_line or layout.first_data_line)


def choose_columns(layout: Layout, path: Path, column: str | None, kind: str | None, facts: HeaderFacts,
                   first_row: list[str], is_stamp) -> ColumnChoice:
    """Pick the time and value columns of ``layout`` and resolve the kind and unit (module docstring)."""
    logical = layout.width - (layout.pair is not None)
    header = layout.header
    names = header if header is not None else [str(i + 1) for i in range(logical)]
    if header is not None and len(header) != logical:
        raise InputDataError(f"header has {len(header)} names but the first data line has {logical} values",
                             str(path), layout.first_data_line)
    bases = [base_name(n) for n in names] if header is not None else [""] * logical
    index = {i for i, b in enumerate(bases) if b in INDEX_NAMES}
    time_idx = None
    if logical >= 2:
        stamps = [i for i in range(logical) if is_stamp(first_row[_field(layout, i)]) or layout.pair == _field(layout, i)]
        named = [i for i, b in enumerate(bases) if i not in index and (b in TIME_NAMES or b.startswith(("t_", "mjd")))]
        if named:
            time_idx = named[0]
        elif stamps:
            time_idx = stamps[0]
        elif 0 not in index:
            time_idx = 0
    if column is not None:
        value_idx = column_index(layout, path, column)
    else:
        left = [i for i in range(logical) if i != time_idx and i not in index]
        if len(left) != 1:
            raise InputError(f"{logical} columns {names}: choose the value column ({{column}})", str(path),
                             layout.first_data_line, fields=("column",))
        value_idx = left[0]
    if value_idx == time_idx:
        time_idx = None
    value_name = names[value_idx]
    unit, unit_from = (column_unit(value_name), "name") if header is not None else (None, "")
    if unit is None and facts.unit is not None:
        unit, unit_from = facts.unit, f"header line {facts.unit_line}"
    by_unit = None if unit is None or unit.quantity == "factor" else ("phase" if unit.quantity == "time" else "freq")
    word = bases[value_idx]
    by_name = "phase" if word in _PHASE_WORDS else "freq" if word in _FREQ_WORDS else None
    if kind is not None and by_unit is not None and kind != by_unit:
        what = {"time": "a time unit: the values are phase", "fraction": "a fractional-frequency unit",
                "hertz": "a frequency unit (Hz)"}[unit.quantity]
        raise InputError(f"column {value_name!r} is in {unit.text}, {what}; use {{kind}} {by_unit} (or {{column}} "
                         "another column)", str(path), layout.header_line or facts.unit_line or layout.first_data_line,
                         fields=("kind", "column"))
    resolved = kind or by_unit or by_name or "phase"
    if unit is not None and unit.quantity == "factor":  # "y[1e-12]": the kind says what the factor scales
        unit = ColumnUnit("time" if resolved == "phase" else "fraction", unit.scale, unit.text)
    time_name = names[time_idx] if time_idx is not None else ""
    return ColumnChoice(None if time_idx is None else _field(layout, time_idx), _field(layout, value_idx), time_name,
                        value_name, resolved, unit, unit_from)


def check_frequency(values: np.ndarray, path: Path, nominal_hz: float | None) -> np.ndarray:
    """Fractional frequency from the values (absolute frequency with ``nominal_hz``), see module docstring."""
    if nominal_hz is not None:
        check_scalar(nominal_hz, "nominal_hz", min_val=0, include_min=False)
        y = values / nominal_hz - 1.0
        check_converted_frequency(y, path, nominal_hz)
        return y
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return values
    largest = float(np.max(np.abs(finite)))
    if largest <= PLAUSIBLE_Y:
        return values
    mean = float(np.mean(finite))
    spread = float(np.std(finite))
    one_sign = bool(np.all(finite > 0) or np.all(finite < 0))
    if one_sign and abs(mean) > PLAUSIBLE_Y and spread < PLAUSIBLE_Y * abs(mean):
        raise InputError(
            f"frequency values of mean {mean:.9g} with a relative spread of {spread / abs(mean):.1e} look like an "
            "absolute (or normalised) frequency, not a fractional one: give the nominal frequency ({nominal_hz})",
            str(path), fields=("nominal_hz",))
    warnings.warn(InputWarning(
        f"{path}: fractional frequency up to {largest:.3g} in magnitude is implausible for a clock (|y| > "
        f"{PLAUSIBLE_Y:g}); analysed as given (for absolute frequency in Hz give {{nominal_hz}})",
        fields=("nominal_hz",)), stacklevel=3)
    return values


def check_converted_frequency(y: np.ndarray, path: Path, nominal_hz: float) -> None:
    """Warn when fractional frequency converted from Hz with ``nominal_hz`` is implausible for a clock
    (|y| > ``PLAUSIBLE_Y``): a wrong nominal frequency (1e7 for a 5 MHz counter reading gives y = -0.5)."""
    finite = np.abs(y[np.isfinite(y)])
    if finite.size and float(finite.max()) > PLAUSIBLE_Y:
        typical = float(np.median(finite))
        warnings.warn(InputWarning(
            f"{path}: fractional frequency up to {float(finite.max()):.3g} in magnitude (median {typical:.3g}) after "
            f"dividing by {{nominal_hz}} {nominal_hz:g} Hz is implausible for a clock (|y| > {PLAUSIBLE_Y:g}): is "
            "{nominal_hz} the counter's nominal frequency? Analysed as given", fields=("nominal_hz",)), stacklevel=3)


def record_notes(layout: Layout, choice: ColumnChoice, facts) -> list[str]:
    """What the reader takes from the file itself, said once in the record."""
    notes = []
    block = [n for n, _ in layout.preamble if n != layout.header_line]
    if block:
        notes.append(f"{len(block)} header-block line{'s' * (len(block) > 1)} before the data skipped "
                     f"(lines {block[0]}-{block[-1]})")
    if choice.unit is not None and choice.unit_from != "name":
        notes.append(f"values in {choice.unit.text}, from {choice.unit_from}")
    elif choice.unit is not None:
        notes.append(f"values in {choice.unit.text}, from the column name {choice.value_name!r}")
    return notes


def to_si(values: np.ndarray, choice: ColumnChoice, nominal_hz: float | None, path: Path, layout: Layout) -> np.ndarray:
    """Phase in seconds or fractional frequency from values written in ``choice.unit``."""
    unit = choice.unit
    if unit is None:
        return values
    if unit.quantity == "hertz":
        if nominal_hz is None:
            raise InputError(f"column {choice.value_name!r} is in {unit.text}: give the nominal frequency "
                             "({nominal_hz}) to make fractional frequency of it", str(path),
                             layout.header_line or layout.first_data_line, fields=("nominal_hz",))
        check_scalar(nominal_hz, "nominal_hz", min_val=0, include_min=False)
        hz = values * unit.scale
        finite = hz[np.isfinite(hz)]
        absolute = finite.size and abs(float(np.median(finite)) / nominal_hz - 1.0) < 1e-3
        y = hz / nominal_hz - 1.0 if absolute else hz / nominal_hz
        check_converted_frequency(y, path, nominal_hz)
        return y
    return values * unit.scale if unit.scale != 1.0 else values


def check_phase_steps(values: np.ndarray, rate_hz: float, path: Path, choice: ColumnChoice) -> None:
    """Warn when phase steps imply a frequency offset no clock has (|dx/dt| > 1e-3): values in ns or ps
    read as seconds."""
    head = values[: min(values.size, 100_001)]
    steps = np.abs(np.diff(head))
    steps = steps[np.isfinite(steps)]
    if steps.size == 0:
        return
    implied = float(np.median(steps)) * rate_hz
    if implied > PLAUSIBLE_Y:
        unit = f" (read in {choice.unit.text})" if choice.unit is not None else ""
        warnings.warn(f"{path}: phase steps of {float(np.median(steps)):.3g} s per sample{unit} imply a fractional "
                      f"frequency of {implied:.3g}, implausible for a clock; if the values are in ns or ps, say so in "
                      "the column name (e.g. phase_ns) or a 'unit:' header line", stacklevel=3)

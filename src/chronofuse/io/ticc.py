"""TAPR TICC logs: the counter's serial output as a phase record.

The TICC (TAPR's TDC7200 time-interval counter, firmware at github.com/tapr/TICC) writes one reading a
line, every line that is not a reading starting with ``#`` (its banner, its configuration, the mode's
heading such as ``# timestamp (seconds)``). Readings are seconds with up to 12 decimals (picoseconds),
printed exactly from integer picoseconds:

- timestamp mode: ``8.737740891687 chA`` (``ch`` and the channel's name), each input's pulses timed
  against the TICC's own reference clock; newer firmware can keep only the last ``WRAP`` digits of the
  seconds, zero-padded (``0099.9... chA`` then ``0000.9... chA``), which is unwrapped here;
- time-interval mode: ``0.000000100012 TI(A->B)``, chB's timestamp minus chA's;
- period mode: ``1.000000000003 chA``, each pulse's timestamp minus the one before (a ``# period`` heading);
- TimeLab mode: chA and chB timestamps followed by a ``chC (B-A)`` line, which is skipped.

As a phase record (seconds):

- one channel's timestamps: ``x_i = t_i - t_0 - n_i T``, the phase against the TICC's reference clock once
  the nominal period ``T`` is removed. ``T`` is the median step rounded to the nearest 1, 2 or 5 times a
  power of ten (refused when the median step is more than 1 % from it), or ``1 / rate_hz``; ``n_i`` counts
  the periods of each step (a step of two periods leaves a gap);
- two channels (timestamp or TimeLab mode): ``x = t_A - t_B`` for each chA pulse and the chB pulse within
  half a period of it ("matched per second" for 1 PPS inputs), on chA's slots; pulses of either channel
  without a partner are warned, chA's left as gaps. ``column`` (``A``, ``chB``, ...) takes one channel alone;
- time-interval mode: each interval is a phase sample, at ``rate_hz`` (1 Hz, the usual 1 PPS, with a
  warning, when not given);
- period mode: ``x_0 = 0, x_k = x_{k-1} + (p_k - T)``.

Every line the reader cannot take is an :class:`~chronofuse.validation.InputDataError` naming it.
"""

from __future__ import annotations

import io
import re
from contextlib import contextmanager
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.io.clock_record import ClockRecord
from chronofuse.validation import InputDataError, InputError, InputWarning

__all__ = ["ticc_mode", "read_ticc", "nominal_period"]

_PS = 10**12
_READING = r"^\s*(-?)(\d+)\.(\d{1,12})\s+"
_CHANNEL = re.compile(_READING + r"(?:ch([A-Za-z0-9])|([A-Za-z]))\s*$")
_INTERVAL = re.compile(_READING + r"TI\(A->B\)\s*$")
_CHANNEL_C = re.compile(_READING + r"chC\s*\(.*\)\s*$")
_SNIFF_LINES = 400


@dataclass
class _Reading:
    line: int
    ps: int  # signed integer picoseconds as printed
    width: int  # digits of the printed seconds (a wrapped timestamp is zero-padded to WRAP digits)


def _parse(match: re.Match, line: int) -> _Reading:
    sign, sec, frac = match.group(1), match.group(2), match.group(3)
    ps = int(sec) * _PS + int(frac.ljust(12, "0"))
    return _Reading(line, -ps if sign else ps, len(sec))


@contextmanager
def _lines(path: Path):
    """``(line number, text)`` of every line (decompressed as the file's first bytes say)."""
    from chronofuse.io.columns import _compression, open_binary

    with open_binary(path, _compression(path)) as raw, \
            io.TextIOWrapper(raw, encoding="utf-8-sig", errors="replace", newline=None) as text:
        yield enumerate(text, start=1)


def ticc_mode(path: str | Path) -> str | None:
    """``"timestamp"``, ``"interval"`` or ``"period"`` when the file is a TICC log (its first readings are
    TICC lines and no other line of numbers comes before them), else None; never raises."""
    try:
        with _lines(Path(path)) as numbered:
            found = _sniff(numbered)
    except (OSError, EOFError, InputDataError, ValueError, UnicodeError):
        return None
    return found


def _sniff(numbered) -> str | None:
    """The mode of the TICC lines in ``numbered`` (at most :data:`_SNIFF_LINES` readings looked at), or None."""
    readings, heading = 0, ""
    kinds = set()
    for _, text in numbered:
        line = text.strip()
        if not line:
            continue
        if line.startswith("#"):
            heading += line.lower()
            continue
        if _INTERVAL.match(line):
            kinds.add("interval")
        elif _CHANNEL.match(line) or _CHANNEL_C.match(line):
            kinds.add("channel")
        elif readings:
            break  # a damaged line after readings: the reader names it
        elif line[:1].isdigit() or line[:1] in "+-.":
            return None  # a line of numbers before any TICC reading: another layout
        else:
            continue  # a text line before the readings ("No config found.  Writing default...")
        readings += 1
        if readings >= _SNIFF_LINES:
            break
    if readings < 2 or len(kinds) != 1:
        return None
    if "interval" in kinds:
        return "interval"
    return "period" if "# period" in heading else "timestamp"


def nominal_period(step_s: float) -> float | None:
    """The 1, 2 or 5 times a power of ten nearest ``step_s`` (in ratio), or None when ``step_s`` is more
    than 1 % from it (or not positive)."""
    if not step_s > 0:
        return None
    decade = 10.0 ** np.floor(np.log10(step_s))
    candidates = [m * decade for m in (1, 2, 5, 10)]
    best = min(candidates, key=lambda c: abs(np.log(step_s / c)))
    best = float(f"{best:.12g}")
    return best if abs(step_s / best - 1.0) <= 0.01 else None


def _unwrap(readings: list[_Reading], path: Path) -> np.ndarray:
    """Picoseconds since the first reading (int64), a wrapped seconds field (WRAP digits) unwrapped; a step
    back that is no wrap is refused naming its line."""
    out = np.empty(len(readings), dtype=np.int64)
    offset, first, prev = 0, readings[0].ps, None
    for k, r in enumerate(readings):
        value = r.ps + offset
        if prev is not None and value < prev:
            before = readings[k - 1]
            wrap = 10**before.width * _PS
            if r.width == before.width and 0 < value + wrap - prev < wrap // 10:  # the seconds field wrapped
                offset += wrap
                value += wrap
            else:
                raise InputDataError(
                    f"timestamp {r.ps / _PS:.12f} s after {before.ps / _PS:.12f} s goes back (a restart of the "
                    "TICC?); split the log there", str(path), r.line)
        out[k] = value - first
        prev = value
    return out


def _slots(t_ps: np.ndarray, period_ps: int, lines: list[int], path: Path) -> np.ndarray:
    """The period count of each timestamp: the running sum of each step's whole number of periods, each
    within a quarter period of one (else refused naming the line)."""
    steps = np.diff(t_ps)
    counts = np.rint(steps / period_ps).astype(np.int64)
    bad = np.flatnonzero((counts < 1) | (np.abs(steps - counts * period_ps) > period_ps // 4))
    if bad.size:
        k = int(bad[0]) + 1
        raise InputDataError(f"a step of {steps[k - 1] / _PS:.12g} s is no whole number of {period_ps / _PS:g} s "
                             "periods", str(path), lines[k])
    return np.concatenate(([0], np.cumsum(counts)))


def _period_ps(t_ps: np.ndarray, rate_hz: float | None, lines: list[int], path: Path) -> int:
    if rate_hz is not None:
        return int(round(_PS / rate_hz))
    median = float(np.median(np.diff(t_ps))) / _PS
    nominal = nominal_period(median)
    if nominal is None:
        raise InputError(f"the median step of the timestamps, {median:.12g} s, is no nominal period (1, 2 or 5 "
                         "times a power of ten within 1 %): give the rate ({rate_hz})", str(path), lines[1],
                         fields=("rate_hz",))
    return int(round(nominal * _PS))


def _on_slots(values_s: np.ndarray, slots: np.ndarray) -> np.ndarray:
    placed = np.full(int(slots[-1]) + 1, np.nan)
    placed[slots] = values_s
    return placed


def read_ticc(path: str | Path, mode: str, *, kind: str | None = None, rate_hz: float | None = None,
              column: str | None = None) -> ClockRecord:
    """A TICC log (:func:`ticc_mode` says which mode) as a phase record (module docstring)."""
    path = Path(path)
    if kind not in (None, "phase"):
        raise InputError("a TICC log holds timestamps or time intervals, a phase record: use {kind} phase",
                         str(path), fields=("kind",))
    channels: dict[str, list[_Reading]] = {}
    intervals: list[_Reading] = []
    started, skipped_c = False, 0
    with _lines(path) as numbered:
        lines_read = list(numbered)
    for lineno, text in lines_read:
        line = text.strip()
        if not line or line.startswith("#"):
            continue
        match = _INTERVAL.match(line) if mode == "interval" else _CHANNEL.match(line)
        if match is None and mode != "interval" and _CHANNEL_C.match(line):
            skipped_c += 1
            continue
        if match is None:
            if not started:
                continue  # text before the readings
            expected = "'<seconds> TI(A->B)'" if mode == "interval" else "'<seconds> chA'"
            raise InputDataError(f"{line[:60]!r} is no TICC {mode} reading ({expected})", str(path), lineno)
        started = True
        if mode == "interval":
            intervals.append(_parse(match, lineno))
        else:
            channels.setdefault(match.group(4) or match.group(5), []).append(_parse(match, lineno))
    notes = [f"a TAPR TICC log in {mode} mode"]
    if skipped_c:
        notes.append(f"{skipped_c} TimeLab chC (B-A) lines skipped (the interval is chA - chB's negative)")

    if mode == "interval":
        if rate_hz is None:
            rate_hz = 1.0
            warnings.warn(InputWarning(f"{path}: a TICC time-interval log states no rate: read at 1 Hz, one interval "
                                       "per pulse of a 1 PPS (give {rate_hz} otherwise)", fields=("rate_hz",)),
                          stacklevel=3)
        values = np.array([r.ps for r in intervals], dtype=np.float64) / _PS
        return ClockRecord(values=values, rate_hz=float(rate_hz), kind="phase", t_ns=None, source=str(path),
                           n_gaps=0, column="TI(A->B)", notes=tuple(notes))

    names = list(channels)
    if column is not None:
        name = column[2:] if column.lower().startswith("ch") else column
        if name not in channels:
            raise InputError(f"no channel {column!r} in this TICC log; it has {', '.join('ch' + n for n in names)} "
                             "({column})", str(path), fields=("column",))
        names = [name]
    if len(names) > 2:
        raise InputError(f"{len(names)} channels ({', '.join('ch' + n for n in names)}): choose one ({{column}})",
                         str(path), channels[names[2]][0].line, fields=("column",))
    first = channels[names[0]]
    if len(first) < 2:
        raise InputDataError(f"one ch{names[0]} reading: too few for a record", str(path), first[0].line)
    lines = [r.line for r in first]

    if mode == "period":
        if len(names) > 1:
            raise InputError("a TICC period log of two channels: choose one ({column})", str(path),
                             channels[names[1]][0].line, fields=("column",))
        p_ps = np.array([r.ps for r in first], dtype=np.int64)
        period = _period_ps(np.concatenate(([0], np.cumsum(p_ps))), rate_hz, [lines[0]] + lines, path)
        x = np.concatenate(([0], np.cumsum(p_ps - period))).astype(np.float64) / _PS
        return ClockRecord(values=x, rate_hz=_PS / period, kind="phase", t_ns=None, source=str(path), n_gaps=0,
                           column=f"ch{names[0]}", notes=tuple(notes))

    t_a = _unwrap(first, path)
    period = _period_ps(t_a, rate_hz, lines, path)
    slots = _slots(t_a, period, lines, path)
    start_ns = first[0].ps // 1000
    if len(names) == 1:
        x = (t_a - slots * period).astype(np.float64) / _PS
        column_name = f"ch{names[0]}"
    else:
        second = channels[names[1]]
        t_b = _unwrap(second, path) + (second[0].ps - first[0].ps)  # on chA's axis
        x, unmatched_a, unmatched_b = _matched(t_a, t_b, period)
        if unmatched_a.size or unmatched_b.size:
            firsts = ([lines[int(unmatched_a[0])]] if unmatched_a.size else []) + (
                [second[int(unmatched_b[0])].line] if unmatched_b.size else [])
            where = min(firsts)
            warnings.warn(InputWarning(
                f"{path}: {unmatched_a.size} ch{names[0]} and {unmatched_b.size} ch{names[1]} pulses have no partner "
                f"within half a period (the first at line {where}); ch{names[0]}'s are gaps"), stacklevel=3)
        column_name = f"ch{names[0]} - ch{names[1]}"
        notes.append(f"phase ch{names[0]} - ch{names[1]}, pulses matched within half a period")
    values = _on_slots(x, slots)
    t_ns = start_ns + np.arange(values.size, dtype=np.int64) * (period // 1000)
    return ClockRecord(values=values, rate_hz=_PS / period, kind="phase", t_ns=t_ns, source=str(path),
                       n_gaps=int(np.isnan(values).sum()), column=column_name, notes=tuple(notes))


def _matched(t_a: np.ndarray, t_b: np.ndarray, period: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``t_a - t_b`` (s) for each chA pulse and the chB pulse nearest it within half a period (NaN without
    one), and the indices of the pulses of each channel left without a partner."""
    k = np.clip(np.searchsorted(t_b, t_a), 1, max(t_b.size - 1, 1))
    left, right = t_b[np.maximum(k - 1, 0)], t_b[np.minimum(k, t_b.size - 1)]
    nearest = np.where(np.abs(t_a - left) <= np.abs(t_a - right), np.maximum(k - 1, 0), np.minimum(k, t_b.size - 1))
    diff = t_a - t_b[nearest]
    ok = np.abs(diff) < period // 2
    # a chB pulse is one partner at most: the nearest of the chA pulses that chose it
    taken = np.zeros(t_b.size, dtype=bool)
    for i in np.argsort(np.abs(diff), kind="stable"):
        if ok[i]:
            if taken[nearest[i]]:
                ok[i] = False
            else:
                taken[nearest[i]] = True
    x = np.where(ok, diff.astype(np.float64) / _PS, np.nan)
    return x, np.flatnonzero(~ok), np.flatnonzero(~taken)

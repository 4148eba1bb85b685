"""RINEX clock products (``.clk``): the receiver (station) clocks of their ``AR`` records.

Format: RINEX Clock 2.00/3.00/3.04 (IGS, "RINEX Clock Extension", 2017 for 3.04). After ``END OF HEADER``
each data line starts with the record type; an ``AR`` line is ``AR NAME yyyy mm dd hh mi ss.ssssss n
bias [sigma]``: the station clock bias (s) against the product's time scale at that GPS-time epoch,
with ``n`` values (bias, its sigma, then rate, ...; extra values may continue on the next line). Station
names are 4 characters (RINEX 2/3.00) or 9 (3.04, ``WAB200CHE``). Fields are whitespace separated in all
three versions (the IGS, CODE and GRG files here; RINEX 3.04 widens the name, which breaks the fixed
columns of 3.00), so lines are split, not cut at columns. The header's own ``AR`` records do not exist
(its labels are in columns 61-80), but a header line may begin with a station name starting ``AR``
(``ARTU ... SOLN STA NAME / NUM``): only lines after ``END OF HEADER`` are read.

No maintained Python reader of clock products' station records was in the environment (georinex reads
observation and navigation files only), so this module parses the records itself.

Epochs become int64 GPS nanoseconds (:mod:`chronofuse.timescale`), never one float.
"""

from __future__ import annotations

import gzip
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns
from chronofuse.validation import InputDataError, InputError


@dataclass(frozen=True)
class StationClocks:
    """The ``AR`` records of one clock product, per station.

    ``stations`` (names, file order); ``gps_ns[name]`` int64 (epochs,) and ``bias_s[name]`` (epochs,)
    each station's epochs and clock biases in time order; ``n_bad_lines`` data lines that could not be read.
    """

    stations: list[str]
    gps_ns: dict[str, np.ndarray]
    bias_s: dict[str, np.ndarray]
    n_bad_lines: int
    source: str = ""


def _lines(path: Path) -> list[str]:
    opener = gzip.open if path.suffix == ".gz" else open
    try:
        with opener(path, "rt", errors="replace") as fh:
            return fh.read().splitlines()
    except (OSError, EOFError) as exc:
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc


def is_rinex_clock(first_line: str) -> bool:
    """Whether a file's first line is a RINEX clock header: the type field (columns 21-40) starts with ``C``
    (``C`` at column 21 in 2.00/3.00 ``CLOCK DATA``, at column 22 in 3.04)."""
    return "RINEX VERSION / TYPE" in first_line and first_line[20:40].strip().upper().startswith("C")


def read_station_clocks(path) -> StationClocks:
    """All ``AR`` (receiver clock) records of a RINEX clock file (module docstring).

    Raises :class:`InputDataError` naming the file when it is not a RINEX clock file or holds no ``AR`` record.
    """
    path = Path(path)
    if not path.is_file():
        raise InputDataError("no such file", str(path))
    lines = _lines(path)
    if not lines or not is_rinex_clock(lines[0]):
        raise InputDataError("not a RINEX clock file (no 'C' in the RINEX VERSION / TYPE line)", str(path))
    try:
        body = next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1
    except StopIteration:
        raise InputDataError("no END OF HEADER line", str(path)) from None
    names: dict[str, list] = {}
    bad = 0
    for number, line in enumerate(lines[body:], start=body + 1):
        if not line.startswith("AR "):
            continue
        parts = line.split()
        try:
            year, month, day, hour, minute = (int(v) for v in parts[2:7])
            sec = float(parts[7])
            bias = float(parts[9].replace("D", "E"))
        except (ValueError, IndexError):
            bad += 1
            continue
        whole = int(sec)
        stamp = np.datetime64(f"{year:04d}-{month:02d}-{day:02d}T{hour:02d}:{minute:02d}:{whole:02d}", "ns")
        ns = int(datetime64_to_gps_ns(np.array([stamp]))[0]) + int(round((sec - whole) * NS_PER_S))
        names.setdefault(parts[1], []).append((ns, bias))
    if not names:
        raise InputDataError("no AR (receiver clock) record in the file", str(path))
    gps, bias = {}, {}
    for name, rows in names.items():
        arr = np.array(rows, dtype=np.float64)
        order = np.argsort(arr[:, 0], kind="stable")
        gps[name] = np.array([rows[i][0] for i in order], dtype=np.int64)
        bias[name] = arr[order, 1]
    return StationClocks(stations=list(names), gps_ns=gps, bias_s=bias, n_bad_lines=bad, source=str(path))


def station_clock_bias(clocks: StationClocks, station: str):
    """One station's clock bias as a :class:`chronofuse.io.clockbias.ClockBiasInput` on its own interval grid.

    The interval is the smallest epoch spacing; missing epochs (the GRG file's 1 h 45 min gap) become NaN
    epochs counted in ``n_skipped``, so the detector restarts its difference chain after them and goes on.
    ``t_s`` is seconds since the station's first epoch. Raises :class:`InputDataError` naming the file for
    a station not in the file (the message lists the first names that are).
    """
    from chronofuse.io.clockbias import ClockBiasInput
    from chronofuse.io.grid import regular_grid

    if station not in clocks.gps_ns:
        known = ", ".join(clocks.stations[:8])
        raise InputError(f"{{station}} == {station!r} is not in the file ({len(clocks.stations)} stations: "
                         f"{known}{', ...' if len(clocks.stations) > 8 else ''})", clocks.source, fields=("station",))
    gps = clocks.gps_ns[station]
    rel_ns = gps - gps[0]
    if gps.size < 2:
        interval_ns = 0
    else:
        interval_ns = int(np.diff(rel_ns).min())
    if interval_ns <= 0:
        return ClockBiasInput(bias_s=clocks.bias_s[station].copy(), t_s=rel_ns / NS_PER_S, n_skipped=0,
                              source=f"{clocks.source} {station}", interval_s=float("nan"))
    t_s, bias = regular_grid(rel_ns / NS_PER_S, clocks.bias_s[station], interval_ns / NS_PER_S,
                             f"{clocks.source} {station}")
    return ClockBiasInput(bias_s=bias, t_s=t_s, n_skipped=int(np.isnan(bias).sum()),
                          source=f"{clocks.source} {station}", interval_s=interval_ns / NS_PER_S)


__all__ = ["StationClocks", "is_rinex_clock", "read_station_clocks", "station_clock_bias"]

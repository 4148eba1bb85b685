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

from chronofuse.record import EpochRecord
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns
from chronofuse.validation import InputDataError, InputError


@dataclass(frozen=True)
class StationClocks:
    """The ``AR`` records of one clock product, per station.

    ``stations`` (names, file order); ``gps_ns[name]`` int64 (epochs,) and ``bias_s[name]`` (epochs,)
    each station's epochs and clock biases in time order, ``lines[name]`` the file line of each;
    ``n_bad_lines`` data lines that could not be read.
    """

    stations: list[str]
    gps_ns: dict[str, np.ndarray]
    bias_s: dict[str, np.ndarray]
    n_bad_lines: int
    source: str = ""
    lines: dict[str, np.ndarray] | None = None  # the 1-based line of each epoch's AR record, per station


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
        try:
            parsed = parse_ar_line(line)
        except ValueError:
            bad += 1
            continue
        if parsed is not None:
            names.setdefault(parsed[0], []).append((parsed[1], parsed[2], number))
    if not names:
        raise InputDataError("no AR (receiver clock) record in the file", str(path))
    gps, bias, where = {}, {}, {}
    for name, rows in names.items():
        order = np.argsort(np.array([r[0] for r in rows], dtype=np.int64), kind="stable")
        gps[name] = np.array([rows[i][0] for i in order], dtype=np.int64)
        bias[name] = np.array([rows[i][1] for i in order], dtype=np.float64)
        where[name] = np.array([rows[i][2] for i in order], dtype=np.int64)
    return StationClocks(stations=list(names), gps_ns=gps, bias_s=bias, n_bad_lines=bad, source=str(path), lines=where)


def parse_ar_line(line: str) -> tuple[str, int, float] | None:
    """``(station, GPS ns, bias s)`` of an ``AR`` data line, None for any other record; ``ValueError`` when an
    ``AR`` line cannot be read. The epoch's seconds are split at the decimal point, so the time tag is exact."""
    if not line.startswith("AR "):
        return None
    parts = line.split()
    try:
        year, month, day, hour, minute = (int(v) for v in parts[2:7])
        sec = float(parts[7])
        bias = float(parts[9].replace("D", "E"))
    except IndexError:
        raise ValueError(f"short AR line {line!r}") from None
    whole = int(sec)
    stamp = np.datetime64(f"{year:04d}-{month:02d}-{day:02d}T{hour:02d}:{minute:02d}:{whole:02d}", "ns")
    ns = int(datetime64_to_gps_ns(np.array([stamp]))[0]) + int(round((sec - whole) * NS_PER_S))
    return parts[1], ns, bias


def station_record(clocks: StationClocks, station: str) -> EpochRecord:
    """One station's clock bias as it is in the file: a record (GPS time) with the column ``clock_bias_s``,
    each epoch's provenance its ``AR`` line. Raises :class:`InputDataError` naming the file for a station not
    in the file (the message lists the first names that are)."""
    if station not in clocks.gps_ns:
        known = ", ".join(clocks.stations[:8])
        raise InputError(f"{{station}} == {station!r} is not in the file ({len(clocks.stations)} stations: "
                         f"{known}{', ...' if len(clocks.stations) > 8 else ''})", clocks.source, fields=("station",))
    lines = None if clocks.lines is None else clocks.lines[station]
    return EpochRecord.from_arrays(clocks.gps_ns[station], {"clock_bias_s": clocks.bias_s[station]},
                                   {"clock_bias_s": "s"}, source=clocks.source, position=lines,
                                   position_unit="index" if lines is None else "line", info={"station": station})


def station_clock_bias(clocks: StationClocks, station: str, interval_ns: int | None = None) -> EpochRecord:
    """One station's clock bias on its own regular grid (:class:`chronofuse.io.grid.GridPlacer`, epochs on
    their exact slots): missing epochs (the GRG file's 1 h 45 min gap) become NaN epochs counted in
    ``info["n_gaps"]``, so the detector restarts its difference chain after them and goes on. The interval is
    learnt from the station's first epochs unless ``interval_ns`` is given; a station with one epoch and no
    interval is refused (:class:`InputDataError`)."""
    from chronofuse.io.grid import GridPlacer

    placer = GridPlacer(interval_ns, tolerance=CLOCK_TOLERANCE)
    return EpochRecord.concat([placer.push(station_record(clocks, station)), placer.close()])


#: A clock product's epochs sit on their slots: a step may differ from a whole number of intervals by this
#: fraction of one (rounding of the epoch's seconds in the file).
CLOCK_TOLERANCE = 1e-6


__all__ = ["StationClocks", "is_rinex_clock", "read_station_clocks", "station_clock_bias", "station_record",
           "parse_ar_line", "CLOCK_TOLERANCE"]

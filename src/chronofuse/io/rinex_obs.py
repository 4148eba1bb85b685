"""Multi-GNSS RINEX observation files (3.0x, plain / gz / Hatanaka), every system, code and flag.

Format (RINEX 3.05, IGS/RTCM 2020, sections 5.2-5.7 and Table A3/A4):

* header: ``SYS / # / OBS TYPES`` lists each system's observables (continuation lines of 13 types);
  ``APPROX POSITION XYZ``, ``ANTENNA: DELTA H/E/N``, ``INTERVAL``, ``REC # / TYPE / VERS``,
  ``ANT # / TYPE``, ``MARKER NAME``, ``TIME OF FIRST OBS`` (whose time system, GPS / GAL / BDT / QZS, is the
  scale of every epoch), ``LEAP SECONDS``;
* epoch record: ``> yyyy mm dd hh mm ss.sssssss  f nnn`` with the epoch flag ``f``: 0 OK, 1 power failure
  since the previous epoch (the observations are valid), 2-5 special events followed by ``nnn`` header or
  comment lines (not observations), 6 cycle-slip records followed by ``nnn`` observation lines that repeat
  an epoch (not new observations);
* observation line: satellite ``Gnn`` then, per observable of its system, a 16-character field ``F14.3``
  value, ``LLI`` (loss-of-lock indicator, bit 0 lost lock, bit 1 half-cycle ambiguity, bit 2 BOC / Galileo
  tracking) and ``SSI`` (signal strength 1-9, 0 or blank unknown).

Missing values, as the format defines them: a blank field, or a value written as 0.000 (section 5.7:
"Observations not available ... are set to zero or blank"), is missing and becomes NaN here; LLI and SSI
blanks become 0 (unknown). RINEX 3.01 files name BeiDou B1 ``C1x``; 3.02 and later ``C2x``: the 3.01 names
are renamed so a code means the same signal in every version (as RTKLIB does).

Why not georinex here. georinex (used for RINEX 2 and navigation files) parses observation lines one field
at a time in Python: on a 24 h, 30 s, 4-system file (NYA1, 2880 epochs) it took 245 s on this machine for
three observables. This reader slices the fixed columns of all lines of a system at once with numpy (a few
seconds for every observable); the tests compare both readers value by value on georinex's own files.

Epochs become int64 GPS nanoseconds (BDT + 14 s; GAL and QZS are GPS-aligned), never one float64.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from chronofuse.io.rinex_text import rinex_bytes
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns
from chronofuse.validation import InputDataError

__all__ = ["ObservationHeader", "GnssObservations", "read_observations", "read_any_observations", "parse_header",
           "SYSTEM_LETTERS", "rinex2_epoch_tags_ns", "exact_rinex2_times"]

#: RINEX system letters and the names used on the command line.
SYSTEM_LETTERS = {"gps": "G", "glo": "R", "gal": "E", "bds": "C", "qzss": "J", "sbas": "S", "navic": "I"}

_TIME_SYSTEM_OFFSET_NS = {"GPS": 0, "GAL": 0, "QZS": 0, "BDT": 14 * NS_PER_S, "": 0}
_EPOCH = re.compile(rb"^> ?(\d{4}) +(\d{1,2}) +(\d{1,2}) +(\d{1,2}) +(\d{1,2}) +(\d+\.\d+) +(\d) *(\d+)")
_FIELD = 16
# RINEX 2.11 epoch line (section 5.2, Table A2): " yy mm dd hh mm ss.sssssss  f nnn", flag 0 or 1 (observations)
_EPOCH2 = re.compile(rb"^ ([ \d]\d) ([ \d]\d) ([ \d]\d) ([ \d]\d) ([ \d]\d)(.{11})  ([01])([ \d]{2}\d)")
_SECONDS = re.compile(rb"\d+\.\d+")
#: georinex reads a RINEX 2 epoch's seconds through a float truncated to microseconds, then keeps its times as
#: ``datetime64[ms]`` (obs2.py): its time is up to a millisecond and a microsecond below the epoch line's exact
#: value (measured: RTKLIB's 07590920.05o line ``05  4  2  0 21 30.0020000`` comes back as 00:21:30.001, as
#: float 30.002 % 1 is 0.0019999...).
GEORINEX_TIME_SLACK_NS = 1_001_000


@dataclass(frozen=True)
class ObservationHeader:
    """What the header says (module docstring): ``version`` (float), ``marker``, ``receiver`` (type),
    ``receiver_version``, ``antenna`` (type and radome), ``approx_position_m`` (3,) or None,
    ``antenna_delta_hen_m`` (3,) (height, east, north of the antenna reference point above the marker),
    ``interval_s`` or None, ``time_system``, ``leap_s`` or None, ``obs_types`` (system letter -> list of
    observable names, in file order)."""

    version: float
    marker: str
    receiver: str
    receiver_version: str
    antenna: str
    approx_position_m: np.ndarray | None
    antenna_delta_hen_m: np.ndarray
    interval_s: float | None
    time_system: str
    leap_s: int | None
    obs_types: dict[str, list[str]]
    n_header_lines: int


@dataclass(frozen=True)
class GnssObservations:
    """Observations of one receiver.

    Attributes
    ----------
    gps_ns : int64 (epochs,)
        Receiver epoch tags on GPS time (ns since 1980-01-06), increasing.
    satellites : list of str (sats,)
        ``"G05"``, ``"C19"``, ``"E11"`` ...
    values : dict observable -> float64 (epochs, sats)
        NaN where missing (blank or 0.000, or the satellite's system has no such observable).
    lli, ssi : dict observable -> uint8 (epochs, sats)
        Loss-of-lock and signal-strength indicators (0 where blank or missing).
    epoch_flag : uint8 (epochs,)
        0 or 1 (power failure before this epoch; observations kept).
    header : ObservationHeader
    n_unreadable_epochs : int
        Epoch records that could not be read (corrupt epoch line, a record cut short).
    n_event_records : int
        Event records (flags 2-6) skipped.
    source : str
    """

    gps_ns: np.ndarray
    satellites: list[str]
    values: dict[str, np.ndarray]
    lli: dict[str, np.ndarray]
    ssi: dict[str, np.ndarray]
    epoch_flag: np.ndarray
    header: ObservationHeader
    n_unreadable_epochs: int = 0
    n_event_records: int = 0
    problems: list[str] = field(default_factory=list)
    source: str = ""

    @property
    def systems(self) -> list[str]:
        """The system letters observed, in the order G, E, C, R, J, S, I."""
        present = {s[0] for s in self.satellites}
        return [c for c in "GECRJSI" if c in present]

    def system_mask(self, letter: str) -> np.ndarray:
        """Boolean (sats,): which satellites belong to the system ``letter``."""
        return np.array([s[0] == letter for s in self.satellites], dtype=bool)

    def select(self, rows) -> GnssObservations:
        """The same observations for the epochs ``rows`` only (a slice, index or boolean array)."""
        pick = lambda d: {k: v[rows] for k, v in d.items()}  # noqa: E731
        return GnssObservations(self.gps_ns[rows], list(self.satellites), pick(self.values), pick(self.lli),
                                pick(self.ssi), self.epoch_flag[rows], self.header, self.n_unreadable_epochs,
                                self.n_event_records, list(self.problems), self.source)


def _float(text: str, default=None):
    try:
        return float(text)
    except ValueError:
        return default


def parse_header(lines: list[bytes], source: str = "") -> ObservationHeader:
    """Read the header lines (module docstring); raises :class:`InputDataError` naming the file when the
    first line is no RINEX observation header or there is no ``END OF HEADER``."""
    first = lines[0].decode("ascii", "replace") if lines else ""
    if "RINEX VERSION / TYPE" not in first or first[20:21].upper() != "O":
        raise InputDataError("not a RINEX observation file (no 'O' in the RINEX VERSION / TYPE line)", source)
    version = _float(first[:9], 0.0)
    info = {"marker": "", "receiver": "", "receiver_version": "", "antenna": "", "approx": None,
            "delta": np.zeros(3), "interval": None, "time_system": "GPS", "leap": None}
    obs_types: dict[str, list[str]] = {}
    current = None
    end = None
    for i, raw in enumerate(lines):
        line = raw.decode("ascii", "replace").rstrip("\r\n")
        label = line[60:].strip()
        if label == "END OF HEADER":
            end = i
            break
        if label == "MARKER NAME":
            info["marker"] = line[:60].strip()
        elif label == "REC # / TYPE / VERS":
            info["receiver"], info["receiver_version"] = line[20:40].strip(), line[40:60].strip()
        elif label == "ANT # / TYPE":
            info["antenna"] = line[20:40].strip()
        elif label == "APPROX POSITION XYZ":
            xyz = [_float(line[k:k + 14]) for k in (0, 14, 28)]
            info["approx"] = np.array(xyz, dtype=np.float64) if None not in xyz and any(xyz) else None
        elif label == "ANTENNA: DELTA H/E/N":
            hen = [_float(line[k:k + 14], 0.0) for k in (0, 14, 28)]
            info["delta"] = np.array(hen, dtype=np.float64)
        elif label == "INTERVAL":
            value = _float(line[:10])
            info["interval"] = value if value and value > 0 else None
        elif label == "TIME OF FIRST OBS":
            info["time_system"] = line[48:51].strip() or "GPS"
        elif label == "LEAP SECONDS":
            value = _float(line[:6])
            info["leap"] = int(value) if value is not None else None
        elif label == "SYS / # / OBS TYPES":
            if line[0] != " ":
                current = line[0]
                obs_types[current] = []
            if current is not None:
                obs_types[current] += line[7:58].split()
    if end is None:
        raise InputDataError("no END OF HEADER line", source)
    if version < 3.02 and "C" in obs_types:  # RINEX 3.01 named BeiDou B1 band 1
        obs_types["C"] = [t[0] + "2" + t[2:] if t[1] == "1" else t for t in obs_types["C"]]
    if info["time_system"] not in _TIME_SYSTEM_OFFSET_NS:
        raise InputDataError(f"time system {info['time_system']!r} of TIME OF FIRST OBS is not read "
                             "(GPS, GAL, BDT, QZS are)", source)
    return ObservationHeader(version=version, marker=info["marker"], receiver=info["receiver"],
                             receiver_version=info["receiver_version"], antenna=info["antenna"],
                             approx_position_m=info["approx"], antenna_delta_hen_m=info["delta"],
                             interval_s=info["interval"], time_system=info["time_system"], leap_s=info["leap"],
                             obs_types=obs_types, n_header_lines=end + 1)


def _epoch_ns(match) -> int | None:
    y, mo, d, h, mi = (int(match.group(k)) for k in range(1, 6))
    sec = match.group(6).decode()
    whole, _, frac = sec.partition(".")
    try:
        stamp = np.datetime64(f"{y:04d}-{mo:02d}-{d:02d}T{h:02d}:{mi:02d}:00", "ns")
    except ValueError:
        return None
    frac_ns = int((frac + "000000000")[:9])
    return int(datetime64_to_gps_ns(np.array([stamp]))[0]) + int(whole) * NS_PER_S + frac_ns


def rinex2_epoch_tags_ns(lines: list[bytes]) -> np.ndarray:
    """Every observation epoch (flag 0 or 1) of a RINEX 2 file's lines (the whole text, header included), in file
    order, as int64 GPS ns read from the epoch line's digits (``yy`` < 80 is 20yy, as RINEX 2.11 says): the
    seconds' seven decimals are kept exactly, never read through a float. Lines that are no readable epoch line
    are skipped (the callers count unreadable epochs against georinex)."""
    body = next((i + 1 for i, line in enumerate(lines) if b"END OF HEADER" in line[60:]), len(lines))
    tags: list[int] = []
    for line in lines[body:]:
        match = _EPOCH2.match(line)
        if match is None:
            continue
        seconds = match.group(6).replace(b" ", b"")  # F11.7; a blank inside (" 0 .0000000") as georinex reads it
        if not _SECONDS.fullmatch(seconds):
            continue
        yy, mo, d, h, mi = (int(match.group(k)) for k in range(1, 6))
        whole, _, frac = seconds.decode().partition(".")
        try:
            stamp = np.datetime64(f"{yy + (2000 if yy < 80 else 1900):04d}-{mo:02d}-{d:02d}T{h:02d}:{mi:02d}:00", "ns")
        except ValueError:
            continue
        tags.append(int(datetime64_to_gps_ns(np.array([stamp]))[0]) + int(whole) * NS_PER_S
                    + int((frac + "000000000")[:9]))
    return np.asarray(tags, dtype=np.int64)


def exact_rinex2_times(georinex_ns: np.ndarray, lines: list[bytes], source: str) -> np.ndarray:
    """georinex's RINEX 2 epoch times (int64 GPS ns, truncated to milliseconds: :data:`GEORINEX_TIME_SLACK_NS`)
    replaced by the exact tags of the file's own epoch lines (:func:`rinex2_epoch_tags_ns`): each georinex time
    takes the first epoch line at or above it, which must lie at most :data:`GEORINEX_TIME_SLACK_NS` above it.
    Raises :class:`InputDataError` naming the file when a time matches no epoch line (georinex read an epoch this
    reader cannot see: never guessed)."""
    georinex_ns = np.asarray(georinex_ns, dtype=np.int64)
    tags = np.unique(rinex2_epoch_tags_ns(lines))
    if georinex_ns.size == 0:
        return georinex_ns
    k = np.clip(np.searchsorted(tags, georinex_ns), 0, max(tags.size - 1, 0))
    if tags.size:
        exact = tags[k]
        ok = (exact - georinex_ns >= 0) & (exact - georinex_ns <= GEORINEX_TIME_SLACK_NS)
    else:
        exact, ok = georinex_ns, np.zeros(georinex_ns.size, dtype=bool)
    if not ok.all():
        bad = int(np.flatnonzero(~ok)[0])
        raise InputDataError(f"epoch {bad + 1} (GPS {int(georinex_ns[bad])} ns as georinex reads it) is on no "
                             "readable RINEX 2 epoch line", source)
    return exact


def _wanted(name: str, observables) -> bool:
    if observables is None:
        return True
    return any(name.startswith(prefix) for prefix in observables)


def read_observations(path, *, systems=None, observables=("C",), start_gps_ns=None, end_gps_ns=None
                      ) -> GnssObservations:
    """Read a RINEX 3 observation file (module docstring).

    ``systems``: system letters to keep (None: all); ``observables``: prefixes of the observable names to
    keep (default ``("C",)``: every pseudorange; None: all, with carrier phase, Doppler and SNR);
    ``start_gps_ns``/``end_gps_ns``: keep epochs in ``[start, end]``. Raises :class:`InputDataError` naming
    the file when it is no RINEX 3 observation file or holds no epoch; damaged epoch records are counted
    in ``n_unreadable_epochs``, never read as data.
    """
    source = str(path)
    lines = rinex_bytes(path).splitlines()
    header = parse_header(lines, source)
    if header.version < 3.0:
        raise InputDataError(f"RINEX {header.version:g}: this reader takes RINEX 3 (RINEX 2 goes through "
                             "chronofuse.io.rinex)", source)
    offset_ns = _TIME_SYSTEM_OFFSET_NS[header.time_system]
    keep_sys = None if systems is None else set(systems)
    epochs_ns: list[int] = []
    flags: list[int] = []
    data_lines: list[bytes] = []
    line_epoch: list[int] = []
    unreadable = events = 0
    problems: list[str] = []
    i, n = header.n_header_lines, len(lines)
    while i < n:
        line = lines[i]
        if not line.startswith(b">"):
            i += 1  # a stray line between records (unreadable content is counted at its epoch line)
            continue
        match = _EPOCH.match(line)
        if match is None:
            unreadable += 1
            problems.append(f"line {i + 1}: epoch record not readable")
            i += 1
            continue
        flag, count = int(match.group(7)), int(match.group(8))
        if flag >= 2:
            events += 1
            i += 1 + count
            continue
        t_ns = _epoch_ns(match)
        body = lines[i + 1:i + 1 + count]
        complete = len(body) == count and all(b[:1].isalpha() and not b.startswith(b">") for b in body)
        if t_ns is None or not complete:
            unreadable += 1
            problems.append(f"line {i + 1}: epoch record cut short or damaged")
            # resume at the next epoch line
            i += 1
            continue
        k = len(epochs_ns)
        epochs_ns.append(t_ns + offset_ns)
        flags.append(flag)
        for b in body:
            if keep_sys is None or chr(b[0]) in keep_sys:
                data_lines.append(b)
                line_epoch.append(k)
        i += 1 + count
    if not epochs_ns:
        raise InputDataError("no observation epoch in the file", source)
    gps_ns = np.asarray(epochs_ns, dtype=np.int64)
    epoch_of_line = np.asarray(line_epoch, dtype=np.int64)
    sat_names = np.array([b[:3].replace(b" ", b"0").decode("ascii", "replace") for b in data_lines])
    satellites = sorted(set(sat_names.tolist()), key=lambda s: ("GECRJSI".find(s[0]), s))
    sat_index = {s: j for j, s in enumerate(satellites)}
    col_of_line = np.array([sat_index[s] for s in sat_names], dtype=np.int64)
    shape = (gps_ns.size, len(satellites))
    values: dict[str, np.ndarray] = {}
    lli: dict[str, np.ndarray] = {}
    ssi: dict[str, np.ndarray] = {}
    letters = np.array([s[0] for s in sat_names]) if sat_names.size else np.array([], dtype="<U1")
    for letter, types in header.obs_types.items():
        rows = np.flatnonzero(letters == letter)
        if rows.size == 0:
            continue
        width = 3 + _FIELD * len(types)
        block = np.frombuffer(b"".join(data_lines[r][:width].ljust(width) for r in rows), dtype="S1")
        block = block.reshape(rows.size, width)
        for k, name in enumerate(types):
            if not _wanted(name, observables):
                continue
            start = 3 + _FIELD * k
            text = block[:, start:start + 14].copy().view("S14").ravel()
            blank = np.char.strip(text) == b""
            text[blank] = b"nan"
            try:
                val = text.astype(np.float64)
            except ValueError:
                val = np.array([_float(t.decode("ascii", "replace"), np.nan) for t in text])
                problems.append(f"{letter} {name}: {int(np.isnan(val).sum() - blank.sum())} unreadable values")
            val[val == 0.0] = np.nan
            flags_lli = np.char.isdigit(block[:, start + 14].copy().view("S1").ravel().astype("U1"))
            lli_val = np.where(flags_lli, block[:, start + 14].view(np.uint8).ravel() - ord("0"), 0)
            ssi_raw = block[:, start + 15]
            ssi_val = np.where(np.char.isdigit(ssi_raw.astype("U1")), ssi_raw.view(np.uint8) - ord("0"), 0)
            for store, arr, fill, dtype in ((values, val, np.nan, np.float64), (lli, lli_val, 0, np.uint8),
                                            (ssi, ssi_val, 0, np.uint8)):
                if name not in store:
                    store[name] = np.full(shape, fill, dtype=dtype)
                store[name][epoch_of_line[rows], col_of_line[rows]] = arr
    order = np.argsort(gps_ns, kind="stable")
    keep = np.ones(gps_ns.size, dtype=bool)
    keep[1:] = np.diff(gps_ns[order]) > 0
    if not keep.all():
        problems.append(f"{int((~keep).sum())} repeated epochs dropped")
    rows = order[keep]
    if start_gps_ns is not None:
        rows = rows[gps_ns[rows] >= int(start_gps_ns)]
    if end_gps_ns is not None:
        rows = rows[gps_ns[rows] <= int(end_gps_ns)]
    if rows.size == 0:
        raise InputDataError("no observation epoch in the time span asked for", source)
    return GnssObservations(gps_ns=gps_ns[rows], satellites=satellites,
                            values={k: v[rows] for k, v in values.items()},
                            lli={k: v[rows] for k, v in lli.items()}, ssi={k: v[rows] for k, v in ssi.items()},
                            epoch_flag=np.asarray(flags, dtype=np.uint8)[rows], header=header,
                            n_unreadable_epochs=unreadable, n_event_records=events, problems=problems,
                            source=source)


# RINEX 2 observable names -> the RINEX 3 code they carry (RINEX 2.11 section 5.1, 2.12 for BeiDou):
# C1 is C/A on L1 (Galileo E1), P1/P2 the P(Y) codes, C2 L2C, C5 L5 / E5a, C7 E5b, C2 on BeiDou B1I.
_RINEX2_CODES = {"G": {"C1": "C1C", "P1": "C1W", "P2": "C2W", "C2": "C2L", "C5": "C5X"},
                 "E": {"C1": "C1X", "C5": "C5X", "C7": "C7X", "C8": "C8X"},
                 "C": {"C2": "C2I", "C1": "C2I", "C7": "C7I", "C6": "C6I"},
                 "J": {"C1": "C1C", "C2": "C2L", "C5": "C5X"}}


def read_any_observations(path, *, systems=None, observables=("C",)) -> GnssObservations:
    """:func:`read_observations` for RINEX 3; a RINEX 2 file through georinex with its observables renamed
    to the RINEX 3 codes they carry (``C1`` -> ``C1C`` ...), 0.000 read as missing too, so the rest of the
    package sees one record type. Hatanaka, gzip and compress are undone either way."""
    import logging
    import tempfile
    import warnings
    from pathlib import Path

    source = str(path)
    text = rinex_bytes(path)
    lines = text[:20000].splitlines()
    version = _float(lines[0][:9].decode("ascii", "replace"), 0.0) if lines else 0.0
    if version >= 3.0:
        return read_observations(path, systems=systems, observables=observables)
    if "RINEX VERSION / TYPE" not in (lines[0].decode("ascii", "replace") if lines else "") or \
            lines[0][20:21].upper() != b"O":
        raise InputDataError("not a RINEX observation file (no 'O' in the RINEX VERSION / TYPE line)", source)
    import georinex

    with tempfile.TemporaryDirectory() as tmp:
        plain = Path(tmp) / (Path(source).name.split(".")[0] + ".obs")
        plain.write_bytes(text)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            logging.disable(logging.CRITICAL)
            try:
                ds = georinex.load(plain, use=set(systems) if systems else None)
            except Exception as err:  # georinex raises many kinds on damaged files
                raise InputDataError(f"georinex cannot read it ({type(err).__name__}: {err})", source) from err
            finally:
                logging.disable(logging.NOTSET)
    if ds is None or "time" not in ds.dims or ds.sizes["time"] == 0:
        raise InputDataError("no observation epoch in the file", source)
    sats = [str(s) for s in ds.sv.values]
    letters = np.array([s[0] for s in sats])
    values: dict[str, np.ndarray] = {}
    for var in ds.data_vars:
        name = str(var)
        pseudorange = "C" + name[1:] if name[0] == "P" else name  # RINEX 2 P1/P2 are pseudoranges too
        if len(name) != 2 or not _wanted(pseudorange, observables or (name[0],)):
            continue
        data = ds[var].transpose("time", "sv").values.astype(np.float64)
        data[data == 0.0] = np.nan
        for letter, table in _RINEX2_CODES.items():
            code = table.get(name)
            cols = letters == letter
            if code is None or not cols.any():
                continue
            values.setdefault(code, np.full(data.shape, np.nan))[:, cols] = data[:, cols]
    head = parse_header([b"     3.00           O" + ln[21:] if i == 0 else ln for i, ln in enumerate(lines)], source)
    gps_ns = exact_rinex2_times(datetime64_to_gps_ns(ds.time.values), text.splitlines(), source)
    zeros = {k: np.zeros(v.shape, dtype=np.uint8) for k, v in values.items()}
    header = ObservationHeader(version=version, marker=head.marker, receiver=head.receiver,
                               receiver_version=head.receiver_version, antenna=head.antenna,
                               approx_position_m=head.approx_position_m, antenna_delta_hen_m=head.antenna_delta_hen_m,
                               interval_s=head.interval_s, time_system=head.time_system, leap_s=head.leap_s,
                               obs_types={}, n_header_lines=head.n_header_lines)
    return GnssObservations(gps_ns=gps_ns, satellites=sats, values=values, lli=zeros, ssi=dict(zeros),
                            epoch_flag=np.zeros(gps_ns.size, dtype=np.uint8), header=header, source=source)

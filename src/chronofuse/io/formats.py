"""What kind of data file this is, from its first bytes: UBX, NMEA, RINEX observation/navigation/clock, or
text (CSV); and whether it is gzip-compressed, told by content (the magic bytes), never by its name."""

from __future__ import annotations

import gzip
import io
import re
from pathlib import Path

from chronofuse.validation import InputDataError, InputError

__all__ = ["FORMATS", "CAPTURE_FORMATS", "LOG_FORMATS", "READ_SETTINGS", "check_applies", "sniff_format", "format_of_head", "capture_format",
           "log_format", "is_gzip", "open_data", "open_text"]

#: The field's own logs, read by :mod:`chronofuse.io.field_logs` (told apart by :func:`chronofuse.io.log_sniff.sniff_log`).
LOG_FORMATS = ("linuxptp", "chrony", "rtklib-pos", "rtklib-stat", "gpsd-json", "tsip")
#: The kinds :func:`sniff_format` tells apart.
FORMATS = ("ubx", "nmea", "rinex-obs", "rinex-nav", "rinex-clock", "csv") + LOG_FORMATS
#: Recordings :func:`chronofuse.io.inspect.read_capture` reads into receiver epochs (every kind but CSV text;
#: a RINEX navigation file is refused there, naming the file).
CAPTURE_FORMATS = ("ubx", "nmea", "rinex-obs", "rinex-nav", "rinex-clock")

#: The reading settings that apply to some kinds of input only, and those kinds (a stream's reader kind
#: ``receiver`` is a UBX/NMEA one, ``text`` a CSV): given for any other kind, a setting is refused by name
#: rather than silently left unused.
READ_SETTINGS = {
    "column": ("csv", "text") + LOG_FORMATS,  # the clock-bias column of a table
    "rate_hz": ("ubx", "nmea", "receiver", "csv", "text") + LOG_FORMATS,  # the grid of epochs without one of their own
    "codes": ("rinex-obs",),  # the codes an observation file's channels are tested on
}

_KIND_WORDS = {"ubx": "a receiver recording (UBX/NMEA)", "nmea": "a receiver recording (UBX/NMEA)",
               "receiver": "a receiver recording (UBX/NMEA)", "csv": "a CSV/text file", "text": "a CSV/text file",
               "rinex-obs": "a RINEX observation file", "rinex-clock": "a RINEX clock product",
               "rinex-nav": "a RINEX navigation file"}


def check_applies(kind: str, source: str | None = None, **given) -> None:
    """Refuse, naming it, a setting of :data:`READ_SETTINGS` given (not None) for an input of ``kind`` it does
    not apply to (:class:`~chronofuse.validation.InputError`, its field named as ``{field}``)."""
    for name, value in given.items():
        if value is None or kind in READ_SETTINGS[name]:
            continue
        what = _KIND_WORDS.get(kind, f"a {kind} log")
        kinds = sorted({_KIND_WORDS.get(k, "a field log") for k in READ_SETTINGS[name]})
        raise InputError(f"{{{name}}} does not apply to {what}: it is for {' or '.join(kinds)}", source, fields=(name,))


_SNIFF_BYTES = 4096
_GZIP_MAGIC = b"\x1f\x8b"  # RFC 1952 section 2.3.1: ID1 = 31, ID2 = 139
_UBX_SYNC = b"\xb5\x62"
# RINEX header line 1, column 21 (0-based 20): the file type; N (GPS), G (GLONASS), H (SBAS) are navigation.
_RINEX_NAV_TYPES = ("N", "G", "H")
# An NMEA 0183 sentence (or an AIS/encapsulated "!" one): start, a 2-6 character address, a comma (some
# receivers double the start: gpsd's st-teseo-liv4f.log has "$$GNGSA,...").
_NMEA_LINE = re.compile(rb"^[$!]{1,2}[A-Z][A-Z0-9]{1,5},")


def is_gzip(path: str | Path) -> bool:
    """True when the file starts with the gzip magic bytes 0x1F 0x8B (RFC 1952), whatever its name."""
    with open(path, "rb") as fh:
        return fh.read(2) == _GZIP_MAGIC


def open_data(path: str | Path):
    """A binary stream of the file's bytes, gzip-decompressed when its content is gzip (not its suffix)."""
    return gzip.open(path, "rb") if is_gzip(path) else open(path, "rb")


def open_text(path: str | Path):
    """A text stream of the file (undecodable bytes replaced), gzip-decompressed when its content is gzip."""
    return io.TextIOWrapper(open_data(path), errors="replace")


def _looks_like_nmea(head: bytes) -> bool:
    """At least half of the lines that are neither blank nor ``#`` comments (gpsd's log headers) are NMEA
    sentences; the last line, possibly cut by the sniff, is not counted."""
    lines = [line.strip(b"\r") for line in head.split(b"\n")[:-1]]
    lines = [line for line in lines if line.strip() and not line.startswith(b"#")]
    hits = sum(1 for line in lines if _NMEA_LINE.match(line))
    return hits > 0 and 2 * hits >= len(lines)


def sniff_format(path: str | Path) -> str:
    """One of :data:`FORMATS` for the file at ``path``, read from its first 4096 bytes.

    A UBX sync pair (0xB5 0x62) anywhere in them means a u-blox capture (NMEA and RTCM may be mixed in);
    a first line carrying ``RINEX VERSION / TYPE`` (or Hatanaka's ``CRINEX VERS``) a RINEX file, whose type
    letter in column 21 (RINEX 2.11 and 3.05 header, "RINEX VERSION / TYPE") tells navigation from
    observations (a Hatanaka file is always observations); lines that are mostly NMEA 0183 sentences
    (``$GPGGA,...``; ``#`` comment lines as gpsd's logs carry them are passed over) an NMEA recording;
    a field log (linuxptp, chrony, RTKLIB, gpsd JSON, Trimble TSIP: :func:`chronofuse.io.log_sniff.sniff_log`)
    by its own; anything else is read as text. A gzip file (magic bytes 0x1F 0x8B, whatever its name) is looked at
    decompressed (the readers decompress it too).

    Raises :class:`InputDataError` naming the file when it does not exist, is a folder, is empty or is
    broken gzip.
    """
    path = Path(path)
    if not path.exists():
        raise InputDataError("no such file", str(path))
    if path.is_dir():
        raise InputDataError("is a directory, not a data file", str(path))
    try:
        with open_data(path) as fh:
            head = fh.read(_SNIFF_BYTES)
    except (OSError, EOFError) as exc:  # gzip.BadGzipFile is an OSError
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc
    if not head:
        raise InputDataError("empty file", str(path))
    return format_of_head(head)


def format_of_head(head: bytes) -> str:
    """One of :data:`FORMATS` for a stream whose first bytes (up to 4096, decompressed) are ``head``, by the
    rules of :func:`sniff_format` (which reads them from a file)."""
    from chronofuse.io.log_sniff import is_tsip, sniff_log

    if is_tsip(head):  # binary TSIP may hold a UBX sync pair by chance: told first, by its DLE framing
        return "tsip"
    if _UBX_SYNC in head:
        return "ubx"
    first = head.split(b"\n", 1)[0].decode("ascii", errors="replace")
    if "RINEX VERSION / TYPE" in first and first[20:40].strip().upper().startswith("C"):
        return "rinex-clock"  # RINEX clock 2.00/3.00 "CLOCK DATA" at column 21, 3.04 "C" at column 22
    if "RINEX VERSION / TYPE" in first or "CRINEX VERS" in first:
        kind = first[20:21].upper()
        return "rinex-nav" if kind in _RINEX_NAV_TYPES and "CRINEX" not in first else "rinex-obs"
    log = sniff_log(head)
    if log == "rtklib-stat":  # "$POS,...", "$CLK,..." lines would pass for NMEA sentences
        return log
    if _looks_like_nmea(head):
        return "nmea"
    return log or "csv"


def capture_format(path: str | Path) -> str | None:
    """The file's kind when it is a receiver recording (one of :data:`CAPTURE_FORMATS`), else None; never
    raises (a missing, empty or unreadable file is None: the reader the caller falls back to says why)."""
    try:
        kind = sniff_format(path)
    except (InputDataError, OSError):
        return None
    return kind if kind in CAPTURE_FORMATS else None


def log_format(path: str | Path) -> str | None:
    """The file's kind when it is a field log (one of :data:`LOG_FORMATS`), else None; never raises (the
    reader the caller falls back to says what is wrong with the file)."""
    try:
        kind = sniff_format(path)
    except (InputDataError, OSError):
        return None
    return kind if kind in LOG_FORMATS else None

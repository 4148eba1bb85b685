"""What kind of data file this is, from its first bytes: UBX, RINEX observation/navigation/clock, or text (CSV)."""

from __future__ import annotations

import gzip
from pathlib import Path

from chronofuse.validation import InputDataError

#: The kinds :func:`sniff_format` tells apart.
FORMATS = ("ubx", "rinex-obs", "rinex-nav", "rinex-clock", "csv")

_SNIFF_BYTES = 4096
_UBX_SYNC = b"\xb5\x62"
# RINEX header line 1, column 21 (0-based 20): the file type; N (GPS), G (GLONASS), H (SBAS) are navigation.
_RINEX_NAV_TYPES = ("N", "G", "H")


def sniff_format(path: str | Path) -> str:
    """One of :data:`FORMATS` for the file at ``path``, read from its first 4096 bytes.

    A UBX sync pair (0xB5 0x62) anywhere in them means a u-blox capture; a first line carrying
    ``RINEX VERSION / TYPE`` (or Hatanaka's ``CRINEX VERS``) a RINEX file, whose type letter in column 21
    (RINEX 2.11 and 3.05 header, "RINEX VERSION / TYPE") tells navigation from observations (a Hatanaka
    file is always observations); anything else is read as text. A ``.gz`` file is looked at decompressed
    (the readers decompress it too).

    Raises :class:`InputDataError` naming the file when it does not exist, is a folder or is empty.
    """
    path = Path(path)
    if not path.exists():
        raise InputDataError("no such file", str(path))
    if path.is_dir():
        raise InputDataError("is a directory, not a data file", str(path))
    try:
        with gzip.open(path, "rb") if path.suffix == ".gz" else open(path, "rb") as fh:
            head = fh.read(_SNIFF_BYTES)
    except (OSError, EOFError) as exc:  # gzip.BadGzipFile is an OSError
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc
    if not head:
        raise InputDataError("empty file", str(path))
    if _UBX_SYNC in head:
        return "ubx"
    first = head.split(b"\n", 1)[0].decode("ascii", errors="replace")
    if "RINEX VERSION / TYPE" in first and first[20:40].strip().upper().startswith("C"):
        return "rinex-clock"  # RINEX clock 2.00/3.00 "CLOCK DATA" at column 21, 3.04 "C" at column 22
    if "RINEX VERSION / TYPE" in first or "CRINEX VERS" in first:
        kind = first[20:21].upper()
        return "rinex-nav" if kind in _RINEX_NAV_TYPES and "CRINEX" not in first else "rinex-obs"
    return "csv"

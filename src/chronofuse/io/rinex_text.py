"""The text of a RINEX file however it is stored: plain, gzip, Unix compress, or Hatanaka (Compact RINEX).

Hatanaka compression (Compact RINEX 1.0 for RINEX 2, 3.0 for RINEX 3; Hatanaka 2008, Bull. GSI 55) is what
IGS and EUREF archives hold (``.crx``, ``.crx.gz``, ``.YYd.Z``). The maintained ``hatanaka`` package restores
it (the reference CRX2RNX algorithm) and undoes gzip/compress around it; a plain file passes through
unchanged. Every RINEX reader of the package gets its text from :func:`rinex_bytes`, so a compressed file is
read wherever a plain one is.
"""

from __future__ import annotations

import atexit
import sys
from pathlib import Path

from chronofuse.validation import InputDataError

__all__ = ["rinex_bytes", "is_compact_rinex", "first_line"]


def _raw(path: Path) -> bytes:
    if not path.is_file():
        raise InputDataError("no such file", str(path))
    try:
        return path.read_bytes()
    except OSError as exc:
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc


def _release_lzw() -> None:
    """Drop the Unix-compress extension hatanaka loads (``ncompress``, a nanobind module) before exit: the
    console script freezes the heap at exit (``gc.freeze``), and a nanobind module still alive then prints
    a "leaked functions" warning on stderr (georinex holds it too). Without its last references it is freed by reference count."""
    for module, attr in (("hatanaka.general_compression", "lzw"), ("georinex.rio", "unlzw")):
        holder = sys.modules.get(module)
        if holder is not None and hasattr(holder, attr):
            delattr(holder, attr)
    for name in [m for m in sys.modules if m == "ncompress" or m.startswith("ncompress.")]:
        del sys.modules[name]


atexit.register(_release_lzw)


def _hatanaka():
    import hatanaka

    return hatanaka


def rinex_bytes(path) -> bytes:
    """The plain RINEX text (bytes) of ``path``: gzip, compress and Hatanaka undone.

    Raises :class:`InputDataError` naming the file when it is missing, or its compression is damaged.
    """
    path = Path(path)
    raw = _raw(path)
    hatanaka = _hatanaka()
    try:
        return hatanaka.decompress(raw)
    except Exception as exc:  # hatanaka raises ValueError / HatanakaException / OSError on damaged input
        raise InputDataError(f"cannot decompress it ({type(exc).__name__}: {exc})", str(path)) from exc


def first_line(path) -> str:
    """The first line of the file after gzip/compress (not Hatanaka) is undone, or "" when unreadable."""
    import gzip

    path = Path(path)
    try:
        with open(path, "rb") as f:
            head = f.read(2)
        if head == b"\x1f\x8b":
            with gzip.open(path, "rb") as f:
                return f.readline(200).decode("ascii", "replace")
        if head == b"\x1f\x9d":  # Unix compress: small enough to undo whole for one line
            return rinex_bytes(path)[:200].split(b"\n", 1)[0].decode("ascii", "replace")
        with open(path, "rb") as f:
            return f.readline(200).decode("ascii", "replace")
    except (OSError, EOFError, InputDataError):
        return ""


def is_compact_rinex(path) -> bool:
    """Whether the file (possibly gzipped) is Hatanaka-compressed: its first line says ``CRINEX VERS / TYPE``."""
    return "CRINEX VERS" in first_line(path)

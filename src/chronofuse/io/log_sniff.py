"""Telling the field's logs apart from their first bytes (called by :func:`chronofuse.io.formats.sniff_format`).

Each format is recognised by what its tool writes, never by the file's name:

* Trimble TSIP: binary packets framed ``DLE id ... DLE ETX`` (DLE = 0x10, ETX = 0x03), so a run of packets
  shows ``DLE ETX DLE`` between them;
* linuxptp: lines of ``ptp4l[...]:``, ``phc2sys[...]:`` or ``ts2phc[...]:`` (also behind a syslog or journal
  prefix);
* chrony: the column header of its ``tracking``, ``statistics``, ``refclocks`` or ``measurements`` log, or
  lines ``YYYY-MM-DD HH:MM:SS ...`` with one of those logs' column patterns (a log without its banner);
* RTKLIB: a solution file's ``%`` header (``% program``, ``%  GPST``) or ``$POS``/``$CLK`` status lines;
* gpsd JSON: lines of ``{"class":...}`` reports (``gpspipe -w``; a ``#`` comment header is passed over).
"""

from __future__ import annotations

import re

__all__ = ["is_tsip", "sniff_log"]

_DLE_ETX_DLE = b"\x10\x03\x10"
_UBX_SYNC = b"\xb5\x62"
_LINUXPTP = re.compile(r"(^|\s)(ptp4l|phc2sys|ts2phc)(\[[\d.]+\])?:\s")
_CHRONY_DATE = re.compile(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d(\.\d+)? ")
_CHRONY_HEADERS = ("Freq ppm", "Std dev'n", "Raw offset", "Peer del.")
_RTKLIB_STAT = re.compile(r"^\$(POS|CLK|VELACC|ION|TROP|HWBIAS|SAT),")
_GPSD_JSON = re.compile(r'^\{"class":"[A-Z]+"')


def is_tsip(head: bytes) -> bool:
    """True when ``head`` holds at least four TSIP packet boundaries (``DLE ETX DLE``) and more of them than
    UBX sync pairs (a u-blox capture may hold the byte run by chance, and TSIP the sync pair)."""
    n = head.count(_DLE_ETX_DLE)
    return n >= 4 and n > 2 * head.count(_UBX_SYNC)


def _text_lines(head: bytes) -> list[str]:
    text = head.decode("utf-8", errors="replace")
    return [line.rstrip("\r") for line in text.split("\n")[:-1] if line.strip()]


def _chrony_row(tokens: list[str]) -> bool:
    """A data row of one of chrony's logs (date, time, then that log's column pattern)."""
    n = len(tokens)
    if 11 <= n <= 14 and tokens[7] in ("N", "+", "-", "?"):  # tracking: ... Offset L Co ...
        return True
    if n == 9 and tokens[4] in ("N", "+", "-", "?"):  # refclocks: Refid DP L P Raw Cooked Disp
        return True
    return n in (12, 13) and all(t.lstrip("-").isdigit() for t in tokens[9:12])  # statistics: ... Ns Bs Nr


def sniff_log(head: bytes) -> str | None:
    """The field log ``head`` (the first bytes of a text file) starts, or None."""
    lines = _text_lines(head)
    if not lines:
        return None
    if sum(1 for line in lines if _LINUXPTP.search(line)) >= max(1, len(lines) // 4):
        return "linuxptp"
    if any(h in line for line in lines[:40] for h in _CHRONY_HEADERS) and any("Date (UTC)" in line for line in lines):
        return "chrony"
    dated = [line for line in lines if _CHRONY_DATE.match(line)]
    if dated and 2 * len(dated) >= len(lines) and all(_chrony_row(line.split()) for line in dated[:20]):
        return "chrony"
    if lines[0].startswith("% program") or any(line.startswith(("%  GPST", "%  UTC", "%  JST")) for line in lines[:40]):
        return "rtklib-pos"
    if sum(1 for line in lines if _RTKLIB_STAT.match(line)) * 2 >= len(lines):
        return "rtklib-stat"
    reports = [line for line in lines if not line.startswith("#")]
    if reports and sum(1 for line in reports if _GPSD_JSON.match(line)) * 2 >= len(reports):
        return "gpsd-json"
    return None

"""Framing of a raw receiver byte stream (NMEA 0183, u-blox UBX, RTCM 3) before any parser sees it.

A receiver's serial output mixes protocols, and recordings carry line noise, frames cut by a reconnect
and comment lines. :class:`FrameScanner` splits the bytes into complete frames whose checksums hold and
counts everything else; the field's parsers (pynmeagps, pyubx2) then decode only trusted frames.

Frame formats and checksums:

* NMEA 0183 (IEC 61162-1 / NMEA 0183 v4.10 section 5.3): ``$`` (or ``!`` for encapsulated sentences),
  address field, comma-separated data, ``*hh`` and CR LF. The checksum ``hh`` is the 8-bit XOR of every
  character between ``$`` and ``*``. A sentence without ``*hh`` is counted (``nmea_no_checksum``) and not
  trusted (NMEA 0183 makes the checksum optional only for a few obsolete sentences; a receiver we time
  from must send it).
* UBX (u-blox interface description, "UBX frame structure" and "UBX checksum"): ``0xB5 0x62``, class,
  id, little-endian 16-bit length, payload, ``CK_A CK_B``: the 8-bit Fletcher checksum over class, id,
  length and payload, ``CK_A = sum(b_i) mod 256``, ``CK_B = sum(CK_A after each byte) mod 256``.
* RTCM 3 (RTCM 10403.3 section 4): ``0xD3``, 6 zero bits, 10-bit length, payload, CRC-24Q; passed
  through as a frame so that its bytes are not counted as noise.

The checksums are computed for a whole chunk at once with cumulative arrays (numpy): for bytes ``b`` the
XOR of ``b[a:e]`` is ``X[e] ^ X[a]`` with ``X`` the running XOR, and the Fletcher pair of ``b[a:e]`` is
``CK_A = S1[e] - S1[a]``, ``CK_B = (S2[e] - S2[a]) - (e - a) S1[a]`` (mod 256) with ``S1`` the running
sum and ``S2`` the running sum of ``S1``; so each frame costs O(1) Python work whatever its length.
"""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Frame", "FrameStats", "FrameScanner", "scan_bytes", "KNOWN_TALKERS"]

#: NMEA talkers of the constellations we decode (GB and BD are both BeiDou, GQ QZSS, GI NavIC).
KNOWN_TALKERS = frozenset({"GP", "GN", "BD", "GB", "GL", "GA", "GQ", "GI"})

_NMEA_MAX = 512  # longest line we accept as one sentence (NMEA says 82; proprietary ones run longer)
_UBX_MAX_PAYLOAD = 16_384  # larger lengths are corrupt length fields in practice (RXM-RAWX: 16 + 32 n)
_CRC24Q_POLY = 0x1864CFB


def _crc24q_table() -> list[int]:
    table = []
    for i in range(256):
        crc = i << 16
        for _ in range(8):
            crc <<= 1
            if crc & 0x1000000:
                crc ^= _CRC24Q_POLY
        table.append(crc & 0xFFFFFF)
    return table


_CRC24Q = _crc24q_table()


def _crc24q(data: bytes) -> int:
    crc = 0
    for byte in data:
        crc = ((crc << 8) & 0xFFFFFF) ^ _CRC24Q[(crc >> 16) ^ byte]
    return crc


def _hexval(c: int) -> int:
    if 48 <= c <= 57:
        return c - 48
    if 65 <= c <= 70:
        return c - 55
    if 97 <= c <= 102:
        return c - 87
    return -1


@dataclass(frozen=True)
class Frame:
    """One complete, checksummed frame: ``kind`` is ``"nmea"``, ``"ubx"`` or ``"rtcm3"``; ``name`` is the
    NMEA address (``GPGGA``, ``PUBX``), the UBX identity (``NAV-PVT``, or ``UBX-0x01-0x99`` when pyubx2
    does not know it) or ``RTCM3-<type>``; ``offset`` is the byte offset in the stream."""

    kind: str
    name: str
    offset: int
    raw: bytes


@dataclass
class FrameStats:
    """Counts of what a scan met. ``messages`` counts good frames per name."""

    n_bytes: int = 0
    unframed_bytes: int = 0
    comment_lines: int = 0
    nmea_bad_checksum: int = 0
    nmea_no_checksum: int = 0
    nmea_malformed: int = 0
    ubx_bad_checksum: int = 0
    rtcm3_bad_crc: int = 0
    truncated: int = 0
    messages: Counter = field(default_factory=Counter)
    unknown_talkers: Counter = field(default_factory=Counter)
    #: (byte offset, reason) of the first problems met (capped, for reports)
    problems: list = field(default_factory=list)

    def note(self, offset: int, reason: str) -> None:
        if len(self.problems) < 200:
            self.problems.append((offset, reason))

    def as_dict(self) -> dict:
        return {
            "n_bytes": self.n_bytes,
            "unframed_bytes": self.unframed_bytes,
            "comment_lines": self.comment_lines,
            "nmea_bad_checksum": self.nmea_bad_checksum,
            "nmea_no_checksum": self.nmea_no_checksum,
            "nmea_malformed": self.nmea_malformed,
            "ubx_bad_checksum": self.ubx_bad_checksum,
            "rtcm3_bad_crc": self.rtcm3_bad_crc,
            "truncated": self.truncated,
            "messages": dict(sorted(self.messages.items())),
            "unknown_talkers": dict(sorted(self.unknown_talkers.items())),
        }


def _ubx_names() -> dict[bytes, str]:
    from pyubx2.ubxtypes_core import UBX_MSGIDS

    return dict(UBX_MSGIDS)


_UBX_NAMES = _ubx_names()


class FrameScanner:
    """Incremental framer: :meth:`feed` bytes as they arrive (any split), get the complete frames back;
    :meth:`close` at the end of the stream counts a frame left unfinished. Counts are in :attr:`stats`."""

    def __init__(self) -> None:
        self.stats = FrameStats()
        self._tail = b""
        self._offset = 0  # stream offset of self._tail[0]
        self._at_line_start = True  # the byte before self._tail[0] ends a line (or there is none)

    def feed(self, data: bytes) -> list[Frame]:
        self.stats.n_bytes += len(data)
        buf = self._tail + bytes(data) if self._tail else bytes(data)
        frames, used = self._scan(buf, final=False)
        self._tail = buf[used:]
        self._consumed(buf, used)
        return frames

    def close(self) -> list[Frame]:
        buf, self._tail = self._tail, b""
        frames, used = self._scan(buf, final=True)
        self._consumed(buf, used)
        return frames

    def _consumed(self, buf: bytes, used: int) -> None:
        used = min(used, len(buf))  # a last sentence without its line end reports one past the end
        self._offset += used
        if used:
            self._at_line_start = buf[used - 1] == 0x0A

    # -- the scan ---------------------------------------------------------------------------------
    def _scan(self, buf: bytes, final: bool) -> tuple[list[Frame], int]:
        st = self.stats
        n = len(buf)
        frames: list[Frame] = []
        if n == 0:
            return frames, 0
        arr = np.frombuffer(buf, dtype=np.uint8)
        xor = np.zeros(n + 1, dtype=np.uint8)
        np.bitwise_xor.accumulate(arr, out=xor[1:])
        s1 = np.zeros(n + 1, dtype=np.uint64)
        np.cumsum(arr, dtype=np.uint64, out=s1[1:])
        s2 = np.zeros(n + 1, dtype=np.uint64)
        np.cumsum(s1[1:], dtype=np.uint64, out=s2[1:])
        base = self._offset
        i = 0
        find = buf.find
        while i < n:
            # the next candidate start: '$' / '!' (NMEA), 0xB5 (UBX), 0xD3 (RTCM3), '#' (comment line)
            j = _next_start(buf, i)
            if j < 0:
                st.unframed_bytes += n - i
                i = n
                break
            if j > i:
                st.unframed_bytes += j - i
                i = j
            c = buf[i]
            if c == 0xB5:
                if i + 1 >= n:
                    if not final:
                        return frames, i
                    self._truncated(base + i, "the stream ends inside a UBX header")
                    i = n
                    break
                if buf[i + 1] != 0x62:
                    st.unframed_bytes += 1
                    i += 1
                    continue
                if i + 6 > n:
                    if not final:
                        return frames, i
                    self._truncated(base + i, "the stream ends inside a UBX header")
                    i = n
                    break
                length = buf[i + 4] | (buf[i + 5] << 8)
                end = i + 8 + length
                if length > _UBX_MAX_PAYLOAD:
                    st.ubx_bad_checksum += 1
                    st.note(base + i, f"UBX length {length} is implausible")
                    i += 2
                    continue
                if end > n:
                    if not final:
                        return frames, i
                    self._truncated(base + i, f"the stream ends {n - i} of {8 + length} bytes into a UBX frame")
                    i += 2
                    continue
                a, e = i + 2, end - 2
                ck_a = int(s1[e] - s1[a]) & 0xFF
                ck_b = (int(s2[e] - s2[a]) - (e - a) * int(s1[a])) & 0xFF
                if ck_a != buf[e] or ck_b != buf[e + 1]:
                    st.ubx_bad_checksum += 1
                    st.note(base + i, "UBX checksum mismatch")
                    i += 2
                    continue
                key = buf[i + 2 : i + 4]
                name = _UBX_NAMES.get(key) or f"UBX-0x{key[0]:02X}-0x{key[1]:02X}"
                st.messages[name] += 1
                frames.append(Frame("ubx", name, base + i, buf[i:end]))
                i = end
            elif c == 0x24 or c == 0x21:  # '$' or '!'
                if _ADDRESS.match(buf, i) is None:
                    if not final and n - i < 8:
                        return frames, i
                    st.unframed_bytes += 1  # a '$' byte in binary data, not a sentence start
                    i += 1
                    continue
                nl = find(b"\n", i + 1, i + _NMEA_MAX)
                if nl < 0:
                    if not final and n - i < _NMEA_MAX:
                        return frames, i
                    nl = n  # a last sentence without its line end
                    if not final:
                        st.nmea_malformed += 1
                        st.note(base + i, "NMEA sentence longer than 512 bytes")
                        i += 1
                        continue
                restart = _sentence_break(buf, i + 1, nl)
                if restart >= 0:
                    st.nmea_malformed += 1
                    st.note(base + i, "NMEA sentence cut short (a new frame or binary bytes inside)")
                    st.unframed_bytes += restart - i
                    i = restart
                    continue
                e = nl
                while e > i and buf[e - 1] in (0x0D, 0x0A):
                    e -= 1
                star = e - 3
                if star <= i or buf[star] != 0x2A:
                    star = buf.rfind(b"*", i, e)
                    if star < 0:
                        st.nmea_no_checksum += 1
                        st.note(base + i, "NMEA sentence without a checksum (not trusted)")
                    else:
                        st.nmea_malformed += 1
                        st.note(base + i, "NMEA checksum field is not two hex digits")
                    i = nl + 1
                    continue
                hi, lo = _hexval(buf[star + 1]), _hexval(buf[star + 2])
                if hi < 0 or lo < 0:
                    st.nmea_malformed += 1
                    st.note(base + i, "NMEA checksum field is not two hex digits")
                    i = nl + 1
                    continue
                if int(xor[star] ^ xor[i + 1]) != (hi << 4) | lo:
                    st.nmea_bad_checksum += 1
                    st.note(base + i, "NMEA checksum mismatch")
                    i = nl + 1
                    continue
                comma = find(b",", i + 1, star)
                address = buf[i + 1 : comma if comma > 0 else star].decode("ascii", "replace")
                if address[:1] != "P" and len(address) >= 5:
                    talker = address[:2]
                    if talker not in KNOWN_TALKERS and c == 0x24:
                        st.unknown_talkers[talker] += 1
                st.messages[address] += 1
                frames.append(Frame("nmea", address, base + i, buf[i : min(nl + 1, n)]))
                i = nl + 1
            elif c == 0xD3:
                if i + 3 > n:
                    if not final:
                        return frames, i
                    st.unframed_bytes += n - i
                    i = n
                    break
                if buf[i + 1] & 0xFC:
                    st.unframed_bytes += 1
                    i += 1
                    continue
                length = ((buf[i + 1] & 0x03) << 8) | buf[i + 2]
                end = i + 6 + length
                if end > n:
                    if not final:
                        return frames, i
                    st.unframed_bytes += 1
                    i += 1
                    continue
                if length < 2 or _crc24q(buf[i : end - 3]) != int.from_bytes(buf[end - 3 : end], "big"):
                    if length >= 2:
                        st.rtcm3_bad_crc += 1
                    st.unframed_bytes += 1
                    i += 1
                    continue
                msg_type = (buf[i + 3] << 4) | (buf[i + 4] >> 4)
                name = f"RTCM3-{msg_type}"
                st.messages[name] += 1
                frames.append(Frame("rtcm3", name, base + i, buf[i:end]))
                i = end
            else:  # '#': a comment line of a recording (gpsd's logs), or one stray byte
                if (buf[i - 1] == 0x0A) if i else self._at_line_start:
                    nl = find(b"\n", i)
                    if nl < 0:
                        if not final:
                            return frames, i
                        nl = n - 1
                    st.comment_lines += 1
                    i = nl + 1
                else:
                    st.unframed_bytes += 1
                    i += 1
        return frames, i

    def _truncated(self, offset: int, reason: str) -> None:
        self.stats.truncated += 1
        self.stats.note(offset, reason)


_START = re.compile(rb"[$!\xb5\xd3#]")
_ADDRESS = re.compile(rb"[$!][A-Z][A-Z0-9]{1,6}[,*]")
_NOT_IN_SENTENCE = re.compile(rb"[\x00-\x0c\x0e-\x1f\x7f-\xff$]")


def _next_start(buf: bytes, i: int) -> int:
    m = _START.search(buf, i)
    return m.start() if m else -1


def _sentence_break(buf: bytes, a: int, b: int) -> int:
    """Offset of the first byte in ``buf[a:b]`` that cannot be inside a sentence ('$', or a control or
    non-ASCII byte other than CR), or -1."""
    m = _NOT_IN_SENTENCE.search(buf, a, b)
    return m.start() if m else -1


def scan_bytes(data: bytes) -> tuple[list[Frame], FrameStats]:
    """Frame a whole recording held in memory (see :class:`FrameScanner`)."""
    scanner = FrameScanner()
    frames = scanner.feed(data)
    frames += scanner.close()
    return frames, scanner.stats

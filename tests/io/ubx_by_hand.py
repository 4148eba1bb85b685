"""UBX-NAV-CLOCK decoded by hand from the u-blox interface description (an oracle for the readers' tests,
sharing no code with pyubx2 or chronofuse)."""

from __future__ import annotations

import struct

import numpy as np

NAV_CLOCK = b"\xb5\x62\x01\x22"  # sync, class 0x01, id 0x22 (u-blox 8 / F9 interface description)


def _fletcher_ok(frame: bytes) -> bool:
    """UBX checksum: 8-bit Fletcher over class, id, length and payload (interface description 32.4)."""
    a = b = 0
    for byte in frame[2:-2]:
        a = (a + byte) & 0xFF
        b = (b + a) & 0xFF
    return frame[-2:] == bytes((a, b))


def nav_clock_by_hand(blob: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(iTOW ms, clkB s, clkD s/s) of every checksummed NAV-CLOCK frame: payload U4 iTOW, I4 clkB (ns),
    I4 clkD (ns/s), U4 tAcc, U4 fAcc, little-endian."""
    itow, bias, drift = [], [], []
    k = blob.find(NAV_CLOCK)
    while k >= 0:
        frame = blob[k:k + 28]
        if len(frame) == 28 and frame[4:6] == b"\x14\x00" and _fletcher_ok(frame):
            t, b, d, _, _ = struct.unpack("<IiiII", frame[6:26])
            itow.append(t)
            bias.append(b * 1e-9)
            drift.append(d * 1e-9)
        k = blob.find(NAV_CLOCK, k + 1)
    return np.array(itow, np.int64), np.array(bias), np.array(drift)

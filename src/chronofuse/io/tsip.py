"""Trimble TSIP timing receivers (Thunderbolt, Resolution SMT 360, ICM SMT 360): the timing packets as series.

TSIP frames each packet as ``DLE id data DLE ETX`` (DLE = 0x10, ETX = 0x03); a 0x10 byte inside the data is
sent twice. Two packets of the timing superpacket 0x8F carry the disciplining (Trimble, "Thunderbolt GPS
Disciplined Clock User Guide", report packets 0x8F-AB and 0x8F-AC; the same layouts in the Resolution SMT 360
and ICM SMT 360 manuals; all fields big-endian, floats IEEE 754):

* **0x8F-AB, primary timing**: time of week (UINT32 s, byte 1), week (UINT16, byte 5), UTC offset
  (SINT16 s, byte 7), timing flags (byte 8: bit 0 the time fields are UTC rather than GPS time, bit 2 time
  not set, bit 3 no UTC information), then second, minute, hour, day, month (bytes 10-14) and year
  (UINT16, byte 15). The packet follows each PPS and labels it: the series' time tags are its GPS time
  ``week * 604800 + TOW`` (ns since 1980-01-06).
* **0x8F-AC, supplemental timing**: receiver mode (byte 1), disciplining mode (2), self-survey progress (3,
  %), holdover duration (UINT32 s, 4), critical and minor alarms (UINT16 bit fields, 8 and 10), GNSS
  decoding status (12), disciplining activity (13), PPS offset (float ns, 16; positive: the PPS is late),
  clock offset (float ppb, 20: the oscillator's frequency offset), DAC value (UINT32, 24), DAC voltage
  (float V, 28), temperature (float deg C, 32), latitude and longitude (double rad, 36 and 44), altitude
  (double m, 52).

One series, ``tsip``, one sample per 0x8F-AC packet, time-tagged by the 0x8F-AB packet of the same second
(an 0x8F-AC before any 0x8F-AB is counted in a note): ``pps_offset_s`` (phase), ``freq`` (the clock offset
as a fractional frequency, ppb x 1e-9), ``dac_v``, ``dac_value``, ``temperature_c``, ``holdover_s``,
``survey_pct``, ``disc_mode`` and ``disc_activity`` (the codes below), ``minor_alarms``, ``critical_alarms``.
``ok`` is True where the disciplining mode is normal (0: locked to GPS), the decoding status is 0
(doing fixes) and the minor alarms do not say "not tracking satellites" (bit 3). Mode changes are events. Packets of other ids are counted; a frame with a bad stuffing or a
0x8F-AB/AC of the wrong length names its byte offset in a note, never read as a sample.
"""

from __future__ import annotations

import struct
from pathlib import Path

from chronofuse.io.log_series import LogSeries, log_series
from chronofuse.io.formats import open_data

__all__ = ["read_tsip", "tsip_packets", "DISCIPLINING_MODES", "DISCIPLINING_ACTIVITY"]

DLE, ETX = 0x10, 0x03
GPS_WEEK_NS = 604_800 * 1_000_000_000
#: 0x8F-AC byte 2 (Thunderbolt user guide).
DISCIPLINING_MODES = {0: "normal", 1: "power-up", 2: "auto holdover", 3: "manual holdover", 4: "recovery",
                      5: "not used", 6: "disciplining disabled"}
#: 0x8F-AC byte 13 (Thunderbolt user guide).
DISCIPLINING_ACTIVITY = {0: "phase locking", 1: "oscillator warm-up", 2: "frequency locking", 3: "placing PPS",
                         4: "initializing loop filter", 5: "compensating OCXO", 6: "inactive", 7: "not used",
                         8: "recovery mode", 9: "calibration/control voltage"}
_AB = struct.Struct(">BIHhBBBBBBH")  # 17 bytes: subcode, TOW, week, UTC offset, flags, s, min, h, d, mon, year
_AC = struct.Struct(">BBBBIHHBBBBffIfffddd")  # 60 bytes up to the altitude


def tsip_packets(data: bytes):
    """Yield ``(offset, packet id, data)`` for each TSIP frame in ``data`` (the DLE stuffing removed); bytes
    outside a frame (a capture's text header, line noise) are passed over. ``offset`` is the frame's first
    byte in ``data``."""
    i, n = 0, len(data)
    while i < n - 1:
        if data[i] != DLE or data[i + 1] in (DLE, ETX):
            i += 1
            continue
        start, pid, j, body = i, data[i + 1], i + 2, bytearray()
        while j < n:
            b = data[j]
            if b == DLE:
                if j + 1 < n and data[j + 1] == DLE:
                    body.append(DLE)
                    j += 2
                    continue
                if j + 1 < n and data[j + 1] == ETX:
                    yield start, pid, bytes(body)
                    j += 2
                break
            body.append(b)
            j += 1
        i = j if j > start + 2 else start + 1


def read_tsip(path: str | Path) -> list[LogSeries]:
    """The timing series of a TSIP capture (plain or gzip; see the module docstring)."""
    path = Path(path)
    with open_data(path) as fh:
        data = fh.read()
    cols = {name: [] for name in ("pps_offset_s", "freq", "dac_v", "dac_value", "temperature_c", "holdover_s",
                                  "survey_pct", "disc_mode", "disc_activity", "minor_alarms", "critical_alarms")}
    t, lines, ok, events, notes = [], [], [], [], []
    gps_ns = None  # GPS time of the last 0x8F-AB
    used_ns = None
    early = bad = other = 0
    last_mode = None
    for k, (offset, pid, body) in enumerate(tsip_packets(data), start=1):
        if pid != 0x8F or not body or body[0] not in (0xAB, 0xAC):
            other += 1
            continue
        if body[0] == 0xAB:
            if len(body) < _AB.size:
                bad += 1
                notes.append(f"0x8F-AB of {len(body)} bytes at byte {offset}, not {_AB.size}")
                continue
            _, tow, week, _, flags, *_ = _AB.unpack_from(body)
            gps_ns = None if flags & 0x04 else week * GPS_WEEK_NS + tow * 1_000_000_000
            continue
        if len(body) < _AC.size:
            bad += 1
            notes.append(f"0x8F-AC of {len(body)} bytes at byte {offset}, not {_AC.size}")
            continue
        if gps_ns is None or gps_ns == used_ns:
            early += 1
            continue
        (_, _rec_mode, disc_mode, survey, holdover, crit, minor, decode, activity, _, _, pps_ns, clk_ppb, dac,
         dac_v, temp, *_pos) = _AC.unpack_from(body)
        used_ns = gps_ns
        t.append(gps_ns)
        lines.append(k)
        for name, value in (("pps_offset_s", pps_ns * 1e-9), ("freq", clk_ppb * 1e-9), ("dac_v", dac_v),
                            ("dac_value", dac), ("temperature_c", temp), ("holdover_s", holdover),
                            ("survey_pct", survey), ("disc_mode", disc_mode), ("disc_activity", activity),
                            ("minor_alarms", minor), ("critical_alarms", crit)):
            cols[name].append(value)
        ok.append(disc_mode == 0 and decode == 0 and not minor & 0x08)
        if disc_mode != last_mode:
            events.append((k, f"disciplining mode {DISCIPLINING_MODES.get(disc_mode, disc_mode)}"))
            last_mode = disc_mode
    kinds = {name: "other" for name in cols}
    kinds.update(pps_offset_s="phase", freq="freq")
    notes = ["TSIP 0x8F-AB/0x8F-AC; line numbers are packet numbers; PPS offset in ns, clock offset in ppb "
             "(read as fractional frequency), DAC in V, temperature in deg C"] + notes[:5]
    if early:
        notes.append(f"{early} 0x8F-AC packets without a new 0x8F-AB time before them are not samples")
    if other:
        notes.append(f"{other} other TSIP packets are not timing samples")
    return [log_series(t, cols, kinds, lines, clock="tsip", time_scale="gps", fmt="tsip", source=str(path),
                       phase="pps_offset_s", freq="freq", ok=ok, notes=notes, events=events)]

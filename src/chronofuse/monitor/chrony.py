"""Integrity-gated time for chronyd, through its SOCK reference clock.

chronyd's ``refclock SOCK PATH`` driver reads datagrams from a Unix socket it creates at PATH; each is a
``struct sock_sample`` (chrony's ``refclock_sock.c``; x86-64/aarch64 layout, 40 bytes)::

    struct timeval tv;   /* system time of the sample: tv_sec, tv_usec (two longs) */
    double offset;       /* reference time minus system time at tv, s */
    int pulse;           /* 0: offset is a full offset; 1: valid only modulo 1 s (a bare PPS edge) */
    int leap;            /* 0 none, 1 insert, 2 delete at the end of the day */
    int _pad;
    int magic;           /* 0x534f434b, "SOCK" */

For each decided epoch the feed sends one sample made of the receivers that qualify, and only them: a
receiver whose record is not usable, was not tested by the integrity test (training, a failed training, no
clock bias), is in alarm, dissents on UTC or the leap count, is stale, or jumped
stops feeding (with none left, nothing is sent: chronyd sees the source fall silent and deselects it,
rather than being handed a time nobody vouches for). From each feeding receiver:

- with a 1PPS edge timed by the system (gpsd's ``PPS`` report, ``pps_unix_ns``): ``tv`` = the edge,
  offset = the second it marks (UTC) - ``tv``;
- otherwise its message time: ``tv`` = the arrival of the epoch's first bytes (``received_unix_ns``;
  for a gpsd source its ``TOFF`` report), offset = the epoch's UTC second - ``tv``, that is minus the
  receiver's output latency (the coarse serial time gpsd also feeds; set chrony's ``offset`` and
  ``delay`` options for it, or lock a PPS refclock to this one).

Fusion: receivers with a PPS edge outrank those without (microseconds against milliseconds); among the
best kind, the sample of the median offset is sent (a lone outlier cannot move it). The leap status sent
is the feeding receivers' announced pending leap when a strict majority of them announce it, else 0; a
receiver announcing a leap second that cannot be (outside the last days of June or December, or one the
leap-second table does not have while it is known complete) is not usable, so it does not feed.

A replayed recording is years away from the system clock; ``shift_to_now`` moves its UTC labels by a
whole number of seconds, chosen at the first sample, so that chronyd sees the replay's own timing as a
live source would give it.
"""

from __future__ import annotations

import errno
import socket
import struct
from collections import Counter

from chronofuse.timescale import NS_PER_S

__all__ = ["ChronySockFeed", "sock_sample", "SOCK_MAGIC", "GPS_EPOCH_UNIX_S", "feeding"]

SOCK_MAGIC = 0x534F434B
#: UNIX time of the GPS epoch, 1980-01-06T00:00:00 UTC.
GPS_EPOCH_UNIX_S = 315_964_800
_LEAP = {0: 0, 1: 1, -1: 2}
_FORMAT = "qqdiiii"


def sock_sample(tv_unix_ns: int, offset_s: float, leap: int = 0, pulse: bool = False) -> bytes:
    """One ``struct sock_sample`` datagram (module docstring)."""
    sec, rest = divmod(int(tv_unix_ns), NS_PER_S)
    return struct.pack(_FORMAT, sec, rest // 1000, float(offset_s), int(bool(pulse)), int(leap), 0, SOCK_MAGIC)


def feeding(record: dict, stale: bool = False) -> bool:
    """Whether a receiver's record may feed the time server: usable, tested by the integrity test and found
    without alarm (its latched ``state`` is ``ok``: an epoch of the training stretch, of a failed training or
    without a clock bias was never checked and never feeds), no dissent, no jump, not stale."""
    return (bool(record.get("usable")) and record.get("state") == "ok" and not record.get("alarm")
            and not record.get("dissent") and not record.get("jump") and not stale)


def _utc_unix_ns(record: dict) -> int:
    return int(record["gps_ns"]) - int(record["leap_s"]) * NS_PER_S + GPS_EPOCH_UNIX_S * NS_PER_S


class ChronySockFeed:
    """Send fused, integrity-gated samples to chronyd's SOCK refclock at ``path`` (module docstring).

    Call it with the decided records of each commit (``feed(records, is_stale)``); :meth:`state` gives
    what ``/api/status`` shows. Send errors (chronyd not running yet, the socket gone) are counted and
    reported once through ``on_error``; the feed goes on trying with the next epoch."""

    def __init__(self, path: str, shift_to_now: bool = False, on_error=None) -> None:
        self.path = str(path)
        self.shift_to_now = shift_to_now
        self.on_error = on_error
        self.shift_ns: int | None = None if shift_to_now else 0
        self.samples_sent = 0
        self.send_errors = 0
        self.last_offset_s: float | None = None
        self.last_feeding: list[str] = []
        self.last_leap = 0
        self._reported = False
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)

    def feed(self, records: list[dict], is_stale=lambda name: False) -> int:
        """One sample per epoch among ``records`` that has a feeding receiver; returns the samples sent."""
        by_epoch: dict[int, list[dict]] = {}
        for r in records:
            by_epoch.setdefault(int(r["gps_ns"]), []).append(r)
        sent = 0
        for gps_ns in sorted(by_epoch):
            sample = self.sample(by_epoch[gps_ns], is_stale)
            if sample is not None and self._send(*sample):
                sent += 1
        return sent

    def sample(self, group: list[dict], is_stale=lambda name: False):
        """``(tv_unix_ns, offset_s, leap, feeding receivers)`` of one epoch's records, or None."""
        candidates = []
        for r in group:
            if not feeding(r, is_stale(r["receiver"])):
                continue
            pps = r.get("pps_unix_ns")
            arrival = r.get("received_unix_ns")
            if pps is not None:
                candidates.append((0, int(pps), r))
            elif arrival is not None:
                candidates.append((1, int(arrival), r))
        if not candidates:
            self.last_feeding = []
            return None
        best = min(kind for kind, _, _ in candidates)
        chosen = [(tv, r) for kind, tv, r in candidates if kind == best]
        if self.shift_ns is None:
            tv, r = chosen[0]
            self.shift_ns = round((tv - _utc_unix_ns(r)) / NS_PER_S) * NS_PER_S
        offsets = sorted((((_utc_unix_ns(r) + self.shift_ns - tv) / NS_PER_S, tv, r) for tv, r in chosen),
                         key=lambda item: item[:2])  # two equal samples: never compare the records
        offset_s, tv, _ = offsets[(len(offsets) - 1) // 2]
        votes = Counter(int(r.get("leap_pending", 0)) for _, r in chosen)
        pending, n = votes.most_common(1)[0]
        leap = _LEAP.get(pending, 0) if 2 * n > len(chosen) else 0  # a leap only a strict majority announces
        return tv, offset_s, leap, sorted(r["receiver"] for _, r in chosen)

    def _send(self, tv_ns: int, offset_s: float, leap: int, names: list[str]) -> bool:
        try:
            self._sock.sendto(sock_sample(tv_ns, offset_s, leap), self.path)
        except OSError as err:
            self.send_errors += 1
            if not self._reported and self.on_error is not None:
                why = "chronyd is not listening there" if err.errno in (errno.ENOENT, errno.ECONNREFUSED) else str(err)
                self.on_error(f"chrony SOCK {self.path}: {why} ({err.strerror}); samples are dropped until it is")
                self._reported = True
            return False
        self._reported = False
        self.samples_sent += 1
        self.last_offset_s, self.last_feeding, self.last_leap = offset_s, names, leap
        return True

    def state(self) -> dict:
        return {"socket": self.path, "samples_sent": self.samples_sent, "send_errors": self.send_errors,
                "last_offset_s": self.last_offset_s, "feeding": list(self.last_feeding), "leap": self.last_leap}

    def close(self) -> None:
        self._sock.close()

"""linuxptp's logs: ptp4l, phc2sys and ts2phc servo lines as clock series.

linuxptp prints one line per servo sample (``clock.c``, ``phc2sys.c``, ``ts2phc.c`` of linuxptp)::

    ptp4l[11797.906]: master offset   -1122365 s2 freq  -80826 path delay   -374994
    phc2sys[423671.221]: [ptp4l.0.config] CLOCK_REALTIME phc offset        -1 s2 freq   +5185 delay    552
    ts2phc[847904.839]: [ts2phc.0.config] ens7f1 master offset          0 s2 freq      -0

The bracket after the program is CLOCK_MONOTONIC in seconds (ms resolution); a message tag (the config file,
``[ptp4l.0.config]``) and a syslog/journal prefix (``Feb 15 20:04:04 host ptp4l[383]: [24.634] ...``, where
the first bracket is the process id) are passed over. The offset is the local clock minus its master or
source (ns; printed as an integer), ``s0``..``s3`` the servo state (unlocked, jump, locked, locked stable:
linuxptp's ``enum servo_state``), and ``freq`` the servo's output ``adj`` in ppb: the clock is set to
``-adj``, so ``adj`` is the servo's estimate of the free-running clock's frequency offset (read here as the
fractional frequency ``adj * 1e-9``). ``delay`` is the path delay (ptp4l) or the PHC read delay (phc2sys).

Also read: ts2phc's ``extts index N at T corr C src S diff D`` lines (D, ns: the PHC's time stamp of the
pulse minus the source's), the summary lines of a ``summary_interval`` run (``rms R max M freq F +/- S delay
D +/- E``: kept as columns ``rms_s``, ``max_s``...), and events: port state transitions, a new best master,
a clock step. Each program/clock (and each message tag) is its own series. Anything else (NMEA sentences
ts2phc echoes, errors) is counted in a note, never read as a sample.
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path

from chronofuse.io.log_series import LogSeries, log_series
from chronofuse.io.formats import open_text

__all__ = ["read_linuxptp", "SERVO_STATES"]

#: linuxptp's servo states (``servo.h``: SERVO_UNLOCKED, SERVO_JUMP, SERVO_LOCKED, SERVO_LOCKED_STABLE).
SERVO_STATES = {0: "unlocked", 1: "jump", 2: "locked", 3: "locked stable"}

_PREFIX = re.compile(r"(?:^|\s)(?P<prog>ptp4l|phc2sys|ts2phc)(?:\[(?P<b1>[\d.]+)\])?:\s*"
                     r"(?:\[(?P<b2>\d+\.\d+)\]\s*)?(?:\[(?P<tag>[^\]]+)\]\s*)?(?P<msg>.*)$")
_INT = r"([+-]?\d+)"
# message -> (kind, regex); the groups are read in order by _sample
_MESSAGES = (
    ("ptp4l", re.compile(rf"^(?:master|main) offset\s+{_INT} s(\d) freq\s+{_INT} path delay\s+{_INT}$")),
    ("clock", re.compile(rf"^(\S+) (phc|sys|pps) offset\s+{_INT} s(\d) freq\s+{_INT}(?: delay\s+{_INT})?$")),
    ("ts2phc", re.compile(rf"^(\S+) (?:master )?offset\s+{_INT} s(\d) freq\s+{_INT}$")),
    ("extts", re.compile(r"^(\S+) extts index (\d+) at (\d+)\.(\d{9}) corr ([+-]?\d+) src (\d+)\.(\d{9}) diff ([+-]?\d+)$")),
    ("summary", re.compile(rf"^(?:(\S+) )?rms\s+{_INT} max\s+{_INT} freq\s+{_INT} \+/-\s+{_INT}"
                           rf"(?: delay\s+{_INT} \+/-\s+{_INT})?$")),
)
_EVENTS = re.compile(r"^(port \d+.*: \S+ to \S+ on \S+|selected best master clock \S+|selected local clock .*|"
                     r"clock jumped.*|.*timed out while polling for tx timestamp.*|.*[Ss]tep.*|new foreign master .*)$")


def _ns(text: str) -> int:
    """Integer ns of a decimal seconds string (``"11797.906"``), exactly."""
    whole, _, frac = text.partition(".")
    return int(whole) * 1_000_000_000 + int((frac + "000000000")[:9])


class _Clock:
    __slots__ = ("t", "lines", "cols", "state")

    def __init__(self):
        self.t, self.lines, self.state = [], [], []
        self.cols = defaultdict(list)


def _time(m) -> str | None:
    """The monotonic seconds of a matched prefix: the bracket with a decimal point (the first is the process
    id in a journal line); a whole number alone is taken as seconds."""
    b1, b2 = m.group("b1"), m.group("b2")
    if b1 and "." in b1:
        return b1
    return b2 or b1


def read_linuxptp(path: str | Path) -> list[LogSeries]:
    """Every servo series of a linuxptp log (ptp4l, phc2sys, ts2phc; any mix, plain or gzip), in the order
    the clocks first appear. See the module docstring for the lines read and their units."""
    path = Path(path)
    clocks: dict[str, _Clock] = {}
    events: dict[str, list] = defaultdict(list)
    other = 0
    with open_text(path) as fh:
        for lineno, line in enumerate(fh, start=1):
            m = _PREFIX.search(line.rstrip("\r\n"))
            if m is None:
                other += 1 if line.strip() else 0
                continue
            prog, msg, tag = m.group("prog"), m.group("msg").strip(), m.group("tag")
            t = _time(m)
            got = _sample(prog, msg)
            if got is None or t is None:
                if _EVENTS.match(msg):
                    events[prog].append((lineno, msg))
                else:
                    other += 1
                continue
            name, cols, state = got
            key = f"{name} [{tag}]" if tag else name
            clock = clocks.setdefault(key, _Clock())
            clock.t.append(_ns(t))
            clock.lines.append(lineno)
            clock.state.append(state)
            for col in cols:  # a column first seen now: NaN for the samples before (in the line's order)
                if col not in clock.cols:
                    clock.cols[col] = [float("nan")] * (len(clock.t) - 1)
            for col, values in clock.cols.items():  # one value per sample in every column (NaN where absent)
                values.append(cols.get(col, float("nan")))
    out = []
    for key, c in clocks.items():
        names = list(c.cols)
        kinds = {n: ("phase" if n in ("offset_s", "diff_s") else "freq" if n == "freq" else "other") for n in names}
        phase = "offset_s" if "offset_s" in names else ("diff_s" if "diff_s" in names else None)
        ok = [s in (2, 3) for s in c.state] if any(s is not None for s in c.state) else None
        prog = key.split()[0]
        notes = ["offsets and delays printed in ns, freq in ppb (the servo's adj; the clock is set to -adj)"]
        if other:
            notes.append(f"{other} other lines (errors, NMEA echoes, configuration) are not samples")
        out.append(log_series(c.t, c.cols, kinds, c.lines, clock=key, time_scale="monotonic", fmt="linuxptp",
                              source=str(path), phase=phase, freq="freq" if "freq" in names else None, ok=ok,
                              notes=notes, events=events.get(prog, ())))
    return out


def _sample(prog: str, msg: str):
    """(clock name, {column: SI value}, servo state or None) of a sample line, or None."""
    for kind, rx in _MESSAGES:
        m = rx.match(msg)
        if m is None:
            continue
        g = m.groups()
        if kind == "ptp4l" and prog == "ptp4l":
            return "ptp4l", {"offset_s": int(g[0]) * 1e-9, "freq": int(g[2]) * 1e-9, "delay_s": int(g[3]) * 1e-9}, int(g[1])
        if kind == "clock":
            cols = {"offset_s": int(g[2]) * 1e-9, "freq": int(g[4]) * 1e-9}
            if g[5] is not None:
                cols["delay_s"] = int(g[5]) * 1e-9
            return f"{prog} {g[0]} {g[1]}", cols, int(g[3])
        if kind == "ts2phc":
            return f"{prog} {g[0]}", {"offset_s": int(g[1]) * 1e-9, "freq": int(g[3]) * 1e-9}, int(g[2])
        if kind == "extts":
            return f"{prog} {g[0]} extts", {"diff_s": int(g[7]) * 1e-9, "corr_s": int(g[4]) * 1e-9}, None
        if kind == "summary":
            cols = {"rms_s": int(g[1]) * 1e-9, "max_s": int(g[2]) * 1e-9, "freq": int(g[3]) * 1e-9,
                    "freq_sd": int(g[4]) * 1e-9}
            if g[5] is not None:
                cols.update(delay_s=int(g[5]) * 1e-9, delay_sd_s=int(g[6]) * 1e-9)
            return f"{prog} {g[0]} summary" if g[0] else f"{prog} summary", cols, None
    return None

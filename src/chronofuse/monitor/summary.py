"""A logged monitoring session, read back: per receiver its clock-bias series, Allan deviation, alarms
and outages (``chronofuse monitor --report``)."""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.analysis.stability import compute, tau_grid
from chronofuse.timescale import NS_PER_S
from chronofuse.validation import InputDataError

__all__ = ["ReceiverSession", "read_session"]


@dataclass(frozen=True)
class ReceiverSession:
    """One receiver's logged epochs: ``gps_ns``, ``clock_bias_s`` (NaN where absent), ``alarm`` and
    ``usable`` per epoch; ``outages``: (wall time s, reason) of each drop; ``adev``: the Allan deviation
    of the clock bias (a :class:`~chronofuse.analysis.stability.Deviation`) or None when too short."""

    name: str
    gps_ns: np.ndarray
    clock_bias_s: np.ndarray
    alarm: np.ndarray
    usable: np.ndarray
    outages: list
    adev: object

    def to_dict(self) -> dict:
        return {
            "receiver": self.name,
            "epochs": int(self.gps_ns.size),
            "usable": int(self.usable.sum()),
            "alarms": int(self.alarm.sum()),
            "alarm_gps_ns": self.gps_ns[self.alarm].tolist()[:100],
            "outages": [{"wall_time_s": t, "reason": why} for t, why in self.outages],
            "clock_bias_epochs": int(np.isfinite(self.clock_bias_s).sum()),
            "adev": None if self.adev is None else {"tau_s": self.adev.tau_s.tolist(), "adev": self.adev.dev.tolist()},
        }


def read_session(db_path) -> list[ReceiverSession]:
    """Every receiver of the log ``db_path``; raises :class:`InputDataError` naming it when it is no log."""
    path = Path(db_path)
    if not path.is_file():
        raise InputDataError("no such file", str(path))
    try:
        db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        rows = db.execute("SELECT receiver, gps_ns, clock_bias_s, alarm, usable FROM epochs ORDER BY receiver, gps_ns").fetchall()
        events = db.execute("SELECT receiver, wall_time_s, detail FROM events WHERE kind = 'down'").fetchall()
        db.close()
    except sqlite3.DatabaseError as err:
        raise InputDataError(f"not a monitor log ({err})", str(path)) from err
    out = []
    for name in sorted({r[0] for r in rows}):
        mine = [r for r in rows if r[0] == name]
        gps = np.array([r[1] for r in mine], dtype=np.int64)
        bias = np.array([np.nan if r[2] is None else r[2] for r in mine], dtype=np.float64)
        out.append(ReceiverSession(
            name=name, gps_ns=gps, clock_bias_s=bias,
            alarm=np.array([bool(r[3]) for r in mine]), usable=np.array([bool(r[4]) for r in mine]),
            outages=[(t, why) for who, t, why in events if who == name], adev=_adev(gps, bias)))
    return out


def _adev(gps_ns: np.ndarray, bias_s: np.ndarray):
    """Allan deviation of the clock bias as phase data at the median epoch interval (NaN gaps kept)."""
    ok = np.isfinite(bias_s)
    if ok.sum() < 16:
        return None
    t, x = gps_ns[ok], bias_s[ok]
    step = int(np.median(np.diff(t)))
    if step <= 0:
        return None
    grid = np.full(int((t[-1] - t[0]) // step) + 1, np.nan)
    grid[((t - t[0]) // step).astype(np.int64)] = x
    rate_hz = NS_PER_S / step
    return compute("oadev", grid, rate_hz, tau_grid("octave", grid.size, rate_hz, "oadev"))

"""A logged monitoring session, read back: per receiver its clock-bias series, Allan deviation, alarms
and outages (``chronofuse monitor --report``)."""

from __future__ import annotations

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
    dissent: np.ndarray | None = None
    jump: np.ndarray | None = None

    def to_dict(self) -> dict:
        return {
            "receiver": self.name,
            "epochs": int(self.gps_ns.size),
            "usable": int(self.usable.sum()),
            "alarms": int(self.alarm.sum()),
            "alarm_gps_ns": self.gps_ns[self.alarm].tolist()[:100],
            "dissent_epochs": int(0 if self.dissent is None else self.dissent.sum()),
            "jumps": int(0 if self.jump is None else self.jump.sum()),
            "outages": [{"wall_time_s": t, "duration_s": d, "reason": why} for t, d, why in self.outages],
            "clock_bias_epochs": int(np.isfinite(self.clock_bias_s).sum()),
            "adev": None if self.adev is None else {"tau_s": self.adev.tau_s.tolist(), "adev": self.adev.dev.tolist()},
        }


def read_session(db_path) -> list[ReceiverSession]:
    """Every receiver of the log ``db_path``; raises :class:`InputDataError` naming it when it is no log.
    An outage is counted once, with its duration (:func:`chronofuse.monitor.logquery.outages`), however
    many reconnections it took."""
    from chronofuse.monitor.logquery import epochs, outages

    frame = epochs(db_path)
    drops = outages(db_path, unix=True)
    out = []
    for name, mine in frame.groupby("receiver", sort=True):
        gps = mine["gps_ns"].to_numpy(np.int64)
        bias = mine["clock_bias_s"].to_numpy(np.float64)
        theirs = drops[drops["receiver"] == name]
        out.append(ReceiverSession(
            name=name, gps_ns=gps, clock_bias_s=bias, alarm=mine["alarm"].to_numpy(bool),
            usable=mine["usable"].to_numpy(bool),
            outages=[(float(t), None if d != d else float(d), why)
                     for t, d, why in zip(theirs["start_unix_s"], theirs["duration_s"], theirs["reason"])],
            adev=_adev(gps, bias), dissent=mine["dissent"].to_numpy(bool), jump=mine["jump"].to_numpy(bool)))
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

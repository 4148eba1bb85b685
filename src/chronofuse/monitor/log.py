"""The monitor's append-only log: one SQLite file in WAL mode.

A record is *acknowledged* (its ``--json-lines`` line printed) only after the transaction holding it has
committed (``synchronous=FULL``: the commit returns once the WAL is on disk), so a monitor killed at any
instant (SIGKILL, power cut after the fsync) loses no acknowledged record; records decoded but not yet
committed are lost, and were never acknowledged. Rows are only ever inserted.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

__all__ = ["EpochLog", "RECORD_COLUMNS"]

#: (column, SQLite type) of one logged receiver epoch.
RECORD_COLUMNS = (
    ("receiver", "TEXT"), ("gps_ns", "INTEGER"), ("utc", "TEXT"), ("fix_mode", "INTEGER"),
    ("time_valid", "INTEGER"), ("n_sats", "INTEGER"), ("gdop", "REAL"), ("pdop", "REAL"), ("hdop", "REAL"),
    ("vdop", "REAL"), ("tdop", "REAL"), ("leap_s", "INTEGER"), ("leap_pending", "INTEGER"), ("qerr_s", "REAL"),
    ("clock_bias_s", "REAL"), ("clock_drift_s_per_s", "REAL"), ("usable", "INTEGER"), ("statistic", "REAL"),
    ("alarm", "INTEGER"), ("dissent", "INTEGER"), ("jump", "INTEGER"),
)
_NAMES = tuple(name for name, _ in RECORD_COLUMNS)


class EpochLog:
    """Append-only epoch log (and connection events) in one SQLite file."""

    def __init__(self, path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(str(self.path), isolation_level=None, check_same_thread=False)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")
        cols = ", ".join(f"{name} {kind}" for name, kind in RECORD_COLUMNS)
        self._db.execute(f"CREATE TABLE IF NOT EXISTS epochs (id INTEGER PRIMARY KEY, {cols})")
        self._db.execute("CREATE TABLE IF NOT EXISTS events (id INTEGER PRIMARY KEY, receiver TEXT, "
                         "wall_time_s REAL, kind TEXT, detail TEXT)")
        self._insert = f"INSERT INTO epochs ({', '.join(_NAMES)}) VALUES ({', '.join('?' * len(_NAMES))})"

    def append(self, records: list[dict], events: list[tuple] = ()) -> None:
        """Insert ``records`` (dicts with :data:`RECORD_COLUMNS`) and ``events`` ((receiver, wall time s,
        kind, detail)) in one transaction; returns once it is committed."""
        if not records and not events:
            return
        db = self._db
        db.execute("BEGIN")
        try:
            db.executemany(self._insert, [tuple(_sql(r[name]) for name in _NAMES) for r in records])
            db.executemany("INSERT INTO events (receiver, wall_time_s, kind, detail) VALUES (?, ?, ?, ?)", events)
        except BaseException:
            db.execute("ROLLBACK")
            raise
        db.execute("COMMIT")

    def close(self) -> None:
        self._db.close()


def _sql(value):
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, float) and value != value:
        return None
    return value

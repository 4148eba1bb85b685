"""The monitor's append-only log: one SQLite file in WAL mode.

A record is *acknowledged* (its ``--json-lines`` line printed) only after the transaction holding it has
committed (``synchronous=FULL``: the commit returns once the WAL is on disk), so a monitor killed at any
instant (SIGKILL, power cut after the fsync) loses no acknowledged record; records decoded but not yet
committed are lost, and were never acknowledged. Rows are only ever inserted.

Keys: one row per receiver and epoch (``UNIQUE (receiver, gps_ns)``). A record already in the log (the
same recording replayed again into the same file, a monitor restarted over a stream it had logged) is
not inserted twice: the first row stands (``INSERT OR IGNORE``). Events
(:class:`~chronofuse.monitor.events.MonitorEvent`: link down/up with the outage's duration, stale/fresh,
alarm raised/cleared, dissent, jumps) are in the ``events`` table, one row per event, so an outage is one
``link_down`` row and one ``link_up`` row however many reconnections were tried.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

from chronofuse.validation import InputDataError, InputError

__all__ = ["EpochLog", "RECORD_COLUMNS", "EVENT_COLUMNS"]

#: (column, SQLite type) of one logged receiver epoch.
RECORD_COLUMNS = (
    ("receiver", "TEXT"), ("gps_ns", "INTEGER"), ("utc", "TEXT"), ("fix_mode", "INTEGER"),
    ("time_valid", "INTEGER"), ("n_sats", "INTEGER"), ("gdop", "REAL"), ("pdop", "REAL"), ("hdop", "REAL"),
    ("vdop", "REAL"), ("tdop", "REAL"), ("leap_s", "INTEGER"), ("leap_pending", "INTEGER"), ("qerr_s", "REAL"),
    ("clock_bias_s", "REAL"), ("clock_drift_s_per_s", "REAL"), ("usable", "INTEGER"), ("statistic", "REAL"),
    ("alarm", "INTEGER"), ("dissent", "INTEGER"), ("jump", "INTEGER"), ("reasons", "TEXT"),
    ("received_unix_ns", "INTEGER"), ("qualified", "INTEGER"), ("state", "TEXT"),
)
#: (column, SQLite type) of one logged event.
EVENT_COLUMNS = (("receiver", "TEXT"), ("wall_time_s", "REAL"), ("kind", "TEXT"), ("detail", "TEXT"),
                 ("gps_ns", "INTEGER"), ("duration_s", "REAL"))
_NAMES = tuple(name for name, _ in RECORD_COLUMNS)
_EVENT_NAMES = tuple(name for name, _ in EVENT_COLUMNS)


class EpochLog:
    """Append-only epoch log (and events) in one SQLite file; raises :class:`InputDataError` naming the
    file when it is not a monitor log (or one whose epochs break the one-row-per-epoch key)."""

    def __init__(self, path) -> None:
        self.path = Path(path)
        if not self.path.parent.is_dir():  # never made up: a mistyped folder would be created silently
            raise InputError(f"{{db}} {self.path}: no such folder {self.path.parent}", fields=("db",))
        try:
            self._db = sqlite3.connect(str(self.path), isolation_level=None, check_same_thread=False)
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=FULL")
            cols = ", ".join(f"{name} {kind}" for name, kind in RECORD_COLUMNS)
            self._db.execute(f"CREATE TABLE IF NOT EXISTS epochs (id INTEGER PRIMARY KEY, {cols})")
            self._add_missing("epochs", RECORD_COLUMNS)
            self._db.execute("CREATE UNIQUE INDEX IF NOT EXISTS epochs_key ON epochs (receiver, gps_ns)")
            ecols = ", ".join(f"{name} {kind}" for name, kind in EVENT_COLUMNS)
            self._db.execute(f"CREATE TABLE IF NOT EXISTS events (id INTEGER PRIMARY KEY, {ecols})")
            self._add_missing("events", EVENT_COLUMNS)
        except sqlite3.IntegrityError as err:
            raise InputDataError(f"holds two rows for one receiver and epoch, cannot be keyed ({err})",
                                 str(self.path)) from err
        except sqlite3.DatabaseError as err:
            raise InputDataError(f"not a monitor log ({err})", str(self.path)) from err
        self._insert = (f"INSERT OR IGNORE INTO epochs ({', '.join(_NAMES)}) "
                        f"VALUES ({', '.join('?' * len(_NAMES))})")
        self._insert_event = (f"INSERT INTO events ({', '.join(_EVENT_NAMES)}) "
                              f"VALUES ({', '.join('?' * len(_EVENT_NAMES))})")

    def _add_missing(self, table: str, columns) -> None:
        """Columns added since a log was written are added to it (older rows hold NULL there)."""
        have = {row[1] for row in self._db.execute(f"PRAGMA table_info({table})")}
        for name, kind in columns:
            if name not in have:
                self._db.execute(f"ALTER TABLE {table} ADD COLUMN {name} {kind}")

    def append(self, records: list[dict], events=()) -> int:
        """Insert ``records`` (dicts with :data:`RECORD_COLUMNS`; a missing optional column is NULL) and
        ``events`` (:class:`~chronofuse.monitor.events.MonitorEvent`) in one transaction; returns the
        number of records inserted (those already logged are skipped) once it is committed."""
        if not records and not events:
            return 0
        db = self._db
        db.execute("BEGIN")
        try:
            before = db.total_changes
            db.executemany(self._insert, [tuple(_sql(r.get(name)) for name in _NAMES) for r in records])
            inserted = db.total_changes - before
            db.executemany(self._insert_event, [(e.receiver, e.wall_s, e.kind, e.detail, e.gps_ns, e.duration_s)
                                                for e in events])
        except BaseException:
            db.execute("ROLLBACK")
            raise
        db.execute("COMMIT")
        return inserted

    def close(self) -> None:
        self._db.close()


def _sql(value):
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, float) and value != value:
        return None
    if isinstance(value, (list, tuple)):
        return "; ".join(str(v) for v in value)
    return value

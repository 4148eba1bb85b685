"""Questions asked of a monitor log (``chronofuse log``): epochs in a time range, per-receiver
availability per interval, outages with their durations, alarm and dissent intervals, exports.

Every query opens the SQLite file read-only and answers with a :class:`pandas.DataFrame`:

- :func:`epochs`: the logged rows, ordered by receiver and epoch, the columns of
  :data:`~chronofuse.monitor.log.RECORD_COLUMNS` (what an export writes, row for row);
- :func:`outages`: one row per outage, from its ``link_down`` event to the ``link_up`` that ended it
  (ISO 8601 UTC; ``end_utc`` None while it lasted to the end of the log), with the reason and the attempts;
- :func:`intervals`: runs of consecutive epochs of one receiver with a flag set (``alarm``: the latched
  state, ``dissent``, ``jump``, or unusable): start and end epoch, UTC labels, epochs, duration;
- :func:`availability`: per receiver and bin of ``bin_s`` (on the GPS time scale, aligned to
  whole intervals since the GPS epoch), the epochs logged, the usable ones, the epochs expected at the
  receiver's own epoch interval (the median step), and usable / expected.

A time range is given as GPS ns (``start_gps_ns`` inclusive, ``end_gps_ns`` exclusive); :func:`parse_utc`
turns an ISO 8601 UTC time into GPS ns with the leap-second table.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd

from chronofuse.monitor.log import RECORD_COLUMNS
from chronofuse.timescale import NS_PER_S, utc_to_gps_ns
from chronofuse.validation import InputDataError, InputError

__all__ = ["connect", "epochs", "outages", "intervals", "availability", "parse_utc", "export", "FLAGS"]

#: Flags :func:`intervals` can follow: a column of the log, or "unusable" (``usable`` = 0).
FLAGS = ("alarm", "dissent", "jump", "unusable")
_COLUMNS = tuple(name for name, _ in RECORD_COLUMNS)


def connect(path) -> sqlite3.Connection:
    """The log ``path`` opened read-only; :class:`InputDataError` naming it when it is no monitor log."""
    path = Path(path)
    if not path.is_file():
        raise InputDataError("no such file", str(path))
    try:
        db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    except sqlite3.DatabaseError as err:
        raise InputDataError(f"not a monitor log ({err})", str(path)) from err
    if "epochs" not in tables:
        db.close()
        raise InputDataError("not a monitor log (no epochs table)", str(path))
    return db


def parse_utc(text: str, name: str = "time") -> int:
    """GPS ns of an ISO 8601 UTC time (``2024-02-04T12:00:00``, a trailing ``Z`` allowed)."""
    try:
        stamp = np.datetime64(text.strip().rstrip("Z"), "ns")
    except ValueError as err:
        raise InputDataError(f"{text!r} is not an ISO 8601 UTC time", name) from err
    return int(utc_to_gps_ns(stamp))


def _check_query(db, path, receiver, start_gps_ns=None, end_gps_ns=None) -> None:
    """Refuse a receiver the log does not hold (naming those it does) and an empty time span."""
    if start_gps_ns is not None and end_gps_ns is not None and start_gps_ns >= end_gps_ns:
        raise InputError("{start_gps_ns} is not before {end_gps_ns}: the time span is empty", str(path),
                         fields=("start_gps_ns", "end_gps_ns"))
    if receiver is None:
        return
    names = [r[0] for r in db.execute("SELECT DISTINCT receiver FROM epochs ORDER BY receiver")]
    if receiver not in names:
        held = ", ".join(names) if names else "none"
        raise InputError(f"{{station}} {receiver!r}: no such receiver in the log (it holds: {held})", str(path),
                         fields=("station",))


def _utc_of_unix(seconds: float) -> str | None:
    """UNIX seconds (the events' wall time) as ISO 8601 UTC to the millisecond, like the epochs' labels."""
    if seconds is None or seconds != seconds:
        return None
    return str(np.datetime64(int(round(seconds * 1000)), "ms")) + "Z"


def _where(receiver, start_gps_ns, end_gps_ns) -> tuple[str, list]:
    clauses, args = [], []
    if receiver is not None:
        clauses.append("receiver = ?")
        args.append(receiver)
    if start_gps_ns is not None:
        clauses.append("gps_ns >= ?")
        args.append(int(start_gps_ns))
    if end_gps_ns is not None:
        clauses.append("gps_ns < ?")
        args.append(int(end_gps_ns))
    return (" WHERE " + " AND ".join(clauses)) if clauses else "", args


def epochs(path, receiver: str | None = None, start_gps_ns: int | None = None,
           end_gps_ns: int | None = None) -> pd.DataFrame:
    """The logged epochs (optionally of one receiver, in a time range), by receiver then epoch."""
    db = connect(path)
    try:
        _check_query(db, path, receiver, start_gps_ns, end_gps_ns)
        have = {r[1] for r in db.execute("PRAGMA table_info(epochs)")}
        cols = ", ".join(c if c in have else f"NULL AS {c}" for c in _COLUMNS)
        where, args = _where(receiver, start_gps_ns, end_gps_ns)
        rows = db.execute(f"SELECT {cols} FROM epochs{where} ORDER BY receiver, gps_ns", args).fetchall()
    finally:
        db.close()
    frame = pd.DataFrame.from_records(rows, columns=list(_COLUMNS))
    for col in ("gdop", "pdop", "hdop", "vdop", "tdop", "qerr_s", "clock_bias_s", "clock_drift_s_per_s", "statistic"):
        frame[col] = pd.to_numeric(frame[col], errors="coerce").astype(np.float64)
    for col in ("gps_ns", "fix_mode", "n_sats", "leap_s", "leap_pending"):
        frame[col] = frame[col].astype(np.int64)
    for col in ("time_valid", "usable", "alarm", "dissent", "jump"):
        frame[col] = frame[col].fillna(0).astype(bool)
    frame["received_unix_ns"] = frame["received_unix_ns"].astype("Int64")
    frame["reasons"] = frame["reasons"].fillna("").astype(str)
    frame["qualified"] = frame["qualified"].astype("boolean")
    frame["state"] = frame["state"].astype(object).where(frame["state"].notna(), None)
    return frame


def _events(path, kinds: tuple[str, ...], receiver: str | None) -> list[tuple]:
    db = connect(path)
    try:
        tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if "events" not in tables:
            return []
        have = {r[1] for r in db.execute("PRAGMA table_info(events)")}
        duration = "duration_s" if "duration_s" in have else "NULL"
        query = (f"SELECT receiver, wall_time_s, kind, detail, {duration} FROM events WHERE kind IN "
                 f"({', '.join('?' * len(kinds))})")
        args = list(kinds)
        if receiver is not None:
            query += " AND receiver = ?"
            args.append(receiver)
        return db.execute(query + " ORDER BY id", args).fetchall()
    finally:
        db.close()


def outages(path, receiver: str | None = None, unix: bool = False) -> pd.DataFrame:
    """One row per outage: ``receiver``, ``start_utc``, ``end_utc`` (ISO 8601 UTC of the system clock; None:
    not over when the log ends), ``duration_s``, ``reason`` (the first failure's), ``attempts`` (failed
    reconnections); with ``unix`` also ``start_unix_s`` and ``end_unix_s``."""
    if receiver is not None:
        db = connect(path)
        try:
            _check_query(db, path, receiver)
        finally:
            db.close()
    rows, open_ = [], {}
    for who, wall_s, kind, detail, _ in _events(path, ("link_down", "link_up"), receiver):
        if kind == "link_down" and who not in open_:
            open_[who] = (wall_s, detail)
        elif kind == "link_up" and who in open_:
            start, reason = open_.pop(who)
            attempts = int(detail.split()[2]) if detail.startswith("back after ") else 0
            rows.append((who, start, wall_s, wall_s - start, reason, attempts))
    for who, (start, reason) in open_.items():
        rows.append((who, start, np.nan, np.nan, reason, 0))
    frame = pd.DataFrame(rows, columns=["receiver", "start_unix_s", "end_unix_s", "duration_s", "reason", "attempts"])
    frame = frame.sort_values(["receiver", "start_unix_s"], kind="stable").reset_index(drop=True)
    frame.insert(1, "start_utc", [_utc_of_unix(v) for v in frame["start_unix_s"]])
    frame.insert(2, "end_utc", [_utc_of_unix(v) for v in frame["end_unix_s"]])
    return frame if unix else frame.drop(columns=["start_unix_s", "end_unix_s"])


def intervals(path, flag: str, receiver: str | None = None, start_gps_ns: int | None = None,
              end_gps_ns: int | None = None) -> pd.DataFrame:
    """Runs of consecutive logged epochs of one receiver with ``flag`` set (one of :data:`FLAGS`):
    ``receiver``, ``start_gps_ns``, ``end_gps_ns`` (the run's last epoch), ``start_utc``, ``end_utc``,
    ``epochs``, ``duration_s`` (last - first epoch plus one epoch interval), ``reasons`` (for unusable
    runs: the reasons met in the run)."""
    if flag not in FLAGS:
        raise InputDataError(f"{flag!r} is not one of {', '.join(FLAGS)}", "flag")
    frame = epochs(path, receiver, start_gps_ns, end_gps_ns)
    rows = []
    for name, mine in frame.groupby("receiver", sort=True):
        if flag == "unusable":
            on = (~mine["usable"]).to_numpy()
        elif flag == "alarm" and mine["state"].notna().any():
            on = (mine["state"] == "alarm").to_numpy()  # the latched alarm, as the verdict uses it
        else:
            on = mine[flag].to_numpy()
        gps = mine["gps_ns"].to_numpy()
        step = int(np.median(np.diff(gps))) if gps.size > 1 else NS_PER_S
        edges = np.diff(np.concatenate([[0], on.astype(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            reasons = sorted({p for text in mine["reasons"].iloc[a:b] for p in text.split("; ") if p})
            rows.append((name, int(gps[a]), int(gps[b - 1]), mine["utc"].iloc[a], mine["utc"].iloc[b - 1], int(b - a),
                         (gps[b - 1] - gps[a] + step) / NS_PER_S, "; ".join(reasons)))
    return pd.DataFrame(rows, columns=["receiver", "start_gps_ns", "end_gps_ns", "start_utc", "end_utc", "epochs",
                                       "duration_s", "reasons"])


def availability(path, bin_s: float, receiver: str | None = None, start_gps_ns: int | None = None,
                 end_gps_ns: int | None = None) -> pd.DataFrame:
    """Per receiver and bin of ``bin_s``: ``interval_start_gps_ns``, ``epochs``, ``usable``, ``expected``
    (the bin's time from the receiver's first epoch on over its median epoch interval: the time before its
    first epoch is not counted against it), ``availability`` = usable / expected."""
    if not bin_s > 0:
        raise InputError(f"{{bin_s}} == {bin_s:g}, must be > 0 s", fields=("bin_s",))
    width = int(round(bin_s * NS_PER_S))
    frame = epochs(path, receiver, start_gps_ns, end_gps_ns)
    rows = []
    for name, mine in frame.groupby("receiver", sort=True):
        gps = mine["gps_ns"].to_numpy()
        step = int(np.median(np.diff(gps))) if gps.size > 1 else NS_PER_S
        bins = gps // width
        usable = mine["usable"].to_numpy()
        for b in np.unique(bins):
            sel = bins == b
            covered = width - max(int(gps[0]) - int(b * width), 0)  # the first bin: from its first epoch
            expected = max(covered / step, 1.0)
            rows.append((name, int(b * width), int(sel.sum()), int(usable[sel].sum()), expected,
                         min(float(usable[sel].sum()) / expected, 1.0)))
    return pd.DataFrame(rows, columns=["receiver", "interval_start_gps_ns", "epochs", "usable", "expected",
                                       "availability"])


def export(frame: pd.DataFrame, out) -> Path:
    """Write a query's table to ``out``: CSV (``.csv``) or Parquet (``.parquet``); other suffixes are refused."""
    out = Path(out)
    suffix = out.suffix.lower()
    if suffix not in (".csv", ".parquet"):
        raise InputDataError("export to .csv or .parquet", str(out))
    out.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".csv":
        frame.to_csv(out, index=False)
    else:
        frame.to_parquet(out, index=False)
    return out

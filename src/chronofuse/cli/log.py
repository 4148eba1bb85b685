"""``chronofuse log QUERY DB``: ask a monitor log (``monitor --db``) what happened.

``epochs``        the logged epochs (a time range, one receiver), printed or exported to CSV/Parquet
``availability``  per receiver and interval: epochs logged, usable, expected, usable / expected
``outages``       one row per outage, with its duration, reason and reconnection attempts
``alarms``, ``dissent``, ``jumps``, ``unusable``   runs of consecutive epochs with that flag
``summary``       per receiver: epochs, usable, alarm and dissent epochs, jumps, outages and their time

Every query takes ``--from``/``--to`` (ISO 8601 UTC) and ``--station`` (one receiver, by its name in the
log) where they apply, ``--out OUT.csv|OUT.parquet``, ``--json`` and ``--quiet``.
"""

from __future__ import annotations

from pathlib import Path

import typer

from chronofuse.cli.common import console, err_console, print_json, quiet_output, user_errors

log_app = typer.Typer(help="Query a monitor log: epochs, availability, outages, alarms, dissent; export CSV/Parquet.",
                      no_args_is_help=True)


def register(app: typer.Typer) -> None:
    app.add_typer(log_app, name="log")


_DB = typer.Argument(..., help="The monitor's SQLite log (monitor --db).")
_FROM = typer.Option(None, "--from", help="Start (ISO 8601 UTC, inclusive).")
_TO = typer.Option(None, "--to", help="End (ISO 8601 UTC, exclusive).")
_RECEIVER = typer.Option(None, "--station", help="Only this receiver (its name in the log; a clock product's station).")
_EXPORT = typer.Option(None, "--out", help="Write the table to OUT.csv or OUT.parquet.")
_JSON = typer.Option(False, "--json", help="Print the table as one JSON document on stdout.")
_QUIET = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document).")


def _range(start: str | None, end: str | None) -> tuple[int | None, int | None]:
    from chronofuse.monitor.logquery import parse_utc

    return (None if start is None else parse_utc(start, "--from"), None if end is None else parse_utc(end, "--to"))


def _emit(frame, export: Path | None, json_out: bool, title: str) -> None:
    from chronofuse.monitor.logquery import export as write

    if export is not None:
        with user_errors():
            write(frame, export)
    if json_out:
        records = frame.astype(object).where(frame.notna(), None).to_dict(orient="records")
        print_json({"query": title, "rows": len(frame), "table": records,
                    "export": None if export is None else str(export)})
        return
    if export is not None:
        err_console.print(f"{title}: {len(frame)} row(s) written to {export}")
        return
    if frame.empty:
        console.print(f"{title}: none")
        return
    console.print(frame.to_string(index=False), markup=False, highlight=False, soft_wrap=True)


@log_app.command("epochs")
def epochs_cmd(db: Path = _DB, start: str | None = _FROM, end: str | None = _TO, receiver: str | None = _RECEIVER,
               export: Path | None = _EXPORT, json_out: bool = _JSON, quiet: bool = _QUIET) -> None:
    """The logged epochs, by receiver and epoch, every column of the log."""
    quiet_output(quiet)
    from chronofuse.monitor.logquery import epochs

    with user_errors():
        frame = epochs(db, receiver, *_range(start, end))
    _emit(frame, export, json_out, "epochs")


@log_app.command("availability")
def availability_cmd(db: Path = _DB, bin_s: float = typer.Option(3600.0, "--bin", help="Length of each row's time bin (s)."),
                     start: str | None = _FROM, end: str | None = _TO, receiver: str | None = _RECEIVER,
                     export: Path | None = _EXPORT, json_out: bool = _JSON, quiet: bool = _QUIET) -> None:
    """Per receiver and time bin: epochs logged, usable, expected at its epoch rate, and usable / expected."""
    quiet_output(quiet)
    from chronofuse.monitor.logquery import availability

    with user_errors():
        frame = availability(db, bin_s, receiver, *_range(start, end))
    _emit(frame, export, json_out, "availability")


@log_app.command("outages")
def outages_cmd(db: Path = _DB, receiver: str | None = _RECEIVER, export: Path | None = _EXPORT,
                json_out: bool = _JSON, quiet: bool = _QUIET) -> None:
    """One row per outage (link down to link up), with its duration, its first reason and the attempts."""
    quiet_output(quiet)
    from chronofuse.monitor.logquery import outages

    with user_errors():
        frame = outages(db, receiver)
    _emit(frame, export, json_out, "outages")


def _runs(flag: str, doc: str):
    def command(db: Path = _DB, start: str | None = _FROM, end: str | None = _TO, receiver: str | None = _RECEIVER,
                export: Path | None = _EXPORT, json_out: bool = _JSON, quiet: bool = _QUIET) -> None:
        from chronofuse.monitor.logquery import intervals

        quiet_output(quiet)
        with user_errors():
            frame = intervals(db, flag, receiver, *_range(start, end))
        _emit(frame, export, json_out, flag)

    command.__doc__ = doc
    return command


log_app.command("alarms")(_runs("alarm", "Runs of consecutive epochs in integrity alarm, per receiver."))
log_app.command("dissent")(_runs("dissent", "Runs of consecutive epochs whose UTC or leap count dissented."))
log_app.command("jumps")(_runs("jump", "Epochs with a clock-bias jump of the receiver's own."))
log_app.command("unusable")(_runs("unusable", "Runs of consecutive unusable epochs, with the reasons met."))


@log_app.command("summary")
def summary_cmd(db: Path = _DB, start: str | None = _FROM, end: str | None = _TO, export: Path | None = _EXPORT,
                json_out: bool = _JSON, quiet: bool = _QUIET) -> None:
    """Per receiver: epochs, usable, alarm and dissent epochs, jumps, outages and their total time."""
    quiet_output(quiet)
    import pandas as pd

    from chronofuse.monitor.logquery import epochs, outages

    with user_errors():
        frame = epochs(db, None, *_range(start, end))
        drops = outages(db)
    rows = []
    for name, mine in frame.groupby("receiver", sort=True):
        theirs = drops[drops["receiver"] == name]
        latched = (mine["state"] == "alarm") if mine["state"].notna().any() else mine["alarm"]
        rows.append({"receiver": name, "epochs": len(mine), "usable": int(mine["usable"].sum()),
                     # in alarm as the verdict and 'log alarms' count it: the latched state; the epochs whose
                     # statistic was over the threshold beside it
                     "alarm_epochs_latched": int(latched.sum()), "detections": int(mine["alarm"].sum()),
                     "dissent_epochs": int(mine["dissent"].sum()),
                     "jumps": int(mine["jump"].sum()), "outages": len(theirs),
                     "outage_s": float(theirs["duration_s"].sum(skipna=True)),
                     "first_utc": mine["utc"].iloc[0], "last_utc": mine["utc"].iloc[-1]})
    _emit(pd.DataFrame(rows), export, json_out, "summary")

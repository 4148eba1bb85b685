"""``chronofuse inspect FILE``: what a receiver recording holds, and its per-epoch table."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import fail, human_console, print_json, user_errors
from chronofuse.io.inspect import read_capture, summarize


def register(app: typer.Typer) -> None:
    app.command("inspect")(inspect)


def inspect(
    file: Path = typer.Argument(..., help="NMEA / UBX recording (mixed with RTCM or noise is fine, .gz ok), RINEX obs/clock, "
                                "or a field log (ptp4l/phc2sys/ts2phc, chrony, RTKLIB, gpsd JSON, Trimble TSIP)."),
    export: Path | None = typer.Option(None, "--export", help="Write the per-epoch table to OUT.csv or OUT.parquet."),
    receiver: str | None = typer.Option(None, "--receiver", help="A RINEX clock file's station, or a field log's clock, to "
                                        "export (default: the first)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
) -> None:
    """Receivers, message counts per type, time span, gaps, checksum failures, unknown talkers."""
    if export is not None and export.suffix.lower() not in (".csv", ".parquet"):
        fail(f"--export {export}: the name must end in .csv or .parquet")
    with user_errors():
        series = _field_log(file)
        if series is not None:
            _inspect_log(file, series, export, receiver, json_out)
            return
        capture = read_capture(file, receiver=receiver)
        doc = summarize(capture)
        if export is not None:
            table = capture.to_frame()
            export.parent.mkdir(parents=True, exist_ok=True)
            if export.suffix.lower() == ".csv":
                table.to_csv(export, index=False)
            else:
                table.to_parquet(export, index=False)
            doc["export"] = {"file": str(export), "rows": int(len(table))}
    if json_out:
        print_json(doc)
        return
    out = human_console(False)
    out.print(f"[bold]{file}[/bold]: {doc['bytes']:,} bytes, {', '.join(doc['protocols']) or 'no NMEA/UBX'}, "
              f"{doc['epochs']:,} epochs")
    if doc["epochs"]:
        out.print(f"  {doc['start_utc']} .. {doc['end_utc']} ({doc['span_s']:.3f} s, every {doc['interval_s']} s), "
                  f"{doc['gaps']['count']} gap(s); leap {doc['leap_s']}; fix modes {doc['fix_modes']}")
    messages = Table("message", "count", title="messages")
    for name, count in doc["messages"].items():
        messages.add_row(name, f"{count:,}")
    out.print(messages)
    damage = {k: v for k, v in doc["damage"].items() if v}
    out.print(f"  damage: {damage or 'none'}")
    if doc["unknown_talkers"]:
        out.print(f"  unknown talkers: {doc['unknown_talkers']}")
    if export is not None:
        out.print(f"  wrote {doc['export']['rows']:,} rows to {export}")


def _field_log(file: Path):
    """The clock series of a field log, or None for a recording (a TSIP capture without timing packets is
    a receiver recording like any other gpsd capture)."""
    from chronofuse.io.formats import log_format

    fmt = log_format(file)
    if fmt is None:
        return None
    from chronofuse.io.field_logs import read_log
    from chronofuse.validation import InputDataError

    try:
        return read_log(file, fmt)
    except InputDataError:
        if fmt == "tsip":
            return None
        raise


def _inspect_log(file: Path, series: list, export: Path | None, clock: str | None, json_out: bool) -> None:
    """A field log: per clock its samples, span, interval, columns and events; ``--export`` writes one clock's
    columns (``t_ns`` on the log's time scale, the values in SI units, ``ok``, ``line``)."""
    import numpy as np
    import pandas as pd
    from rich.markup import escape  # clock names carry linuxptp's "[ptp4l.0.config]" tags

    from chronofuse.io.field_logs import pick_series, summarize_log

    doc = summarize_log(series)
    if export is not None:
        s = pick_series(series, clock, str(file))
        table = pd.DataFrame({"t_ns": s.t_ns, **s.columns, "ok": s.ok if s.ok is not None else np.ones(s.n, bool),
                              "line": s.lines})
        export.parent.mkdir(parents=True, exist_ok=True)
        if export.suffix.lower() == ".csv":
            table.to_csv(export, index=False)
        else:
            table.to_parquet(export, index=False)
        doc["export"] = {"file": str(export), "clock": s.clock, "rows": int(len(table))}
    if json_out:
        print_json(doc)
        return
    out = human_console(False)
    out.print(f"[bold]{escape(str(file))}[/bold]: {doc['format']} log, {len(doc['clocks'])} clock(s)")
    table = Table("clock", "samples", "span (s)", "interval (s)", "not ok", "events", "columns", title="clocks")
    for c in doc["clocks"]:
        interval = "-" if c["interval_s"] is None else f"{c['interval_s']:.6g}"
        table.add_row(escape(c["clock"]), f"{c['samples']:,}", f"{c['span_s']:.3f}", interval,
                      "-" if c["not_ok"] is None else str(c["not_ok"]), str(len(c["events"])), ", ".join(c["columns"]))
    out.print(table)
    for note in dict.fromkeys(n for c in doc["clocks"] for n in c["notes"]):
        out.print(f"  {escape(note)}")
    if export is not None:
        out.print(f"  wrote {doc['export']['rows']:,} rows of {escape(doc['export']['clock'])} to {export}")

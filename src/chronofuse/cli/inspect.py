"""``chronofuse inspect FILE``: what a receiver recording holds, and its per-epoch table."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import fail, human_console, print_json, quiet_output, user_errors


def register(app: typer.Typer) -> None:
    app.command("inspect")(inspect)


def inspect(
    file: Path = typer.Argument(..., help="NMEA / UBX recording (mixed with RTCM or noise is fine, .gz ok), RINEX obs/clock, "
                                "or a field log (ptp4l/phc2sys/ts2phc, chrony, RTKLIB, gpsd JSON, Trimble TSIP)."),
    out: Path | None = typer.Option(None, "--out", help="Write the per-epoch table to this file: OUT.csv or OUT.parquet."),
    station: str | None = typer.Option(None, "--station", help="A RINEX clock product's station, or a field log's clock, "
                                       "to export (default: the first)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Receivers, message counts per type, time span, gaps, checksum failures, unknown talkers."""
    quiet_output(quiet)
    if out is not None and out.suffix.lower() not in (".csv", ".parquet"):
        fail(f"--out {out}: the name must end in .csv or .parquet")
    with user_errors():
        series = _field_log(file)
        if series is not None:
            _inspect_log(file, series, out, station, json_out)
            return
        from chronofuse.io.inspect import read_capture, summarize  # here: `inspect --help` needs none of it

        capture = read_capture(file, receiver=station)
        doc = summarize(capture)
        if out is not None:
            table = capture.to_frame()
            out.parent.mkdir(parents=True, exist_ok=True)
            if out.suffix.lower() == ".csv":
                table.to_csv(out, index=False)
            else:
                table.to_parquet(out, index=False)
            doc["export"] = {"file": str(out), "rows": int(len(table))}
    if json_out:
        print_json(doc)
        return
    con = human_console(False)
    con.print(f"[bold]{file}[/bold]: {doc['bytes']:,} bytes, {', '.join(doc['protocols']) or 'no NMEA/UBX'}, "
              f"{doc['epochs']:,} epochs")
    if doc["epochs"]:
        con.print(f"  {doc['start_utc']} .. {doc['end_utc']} ({doc['span_s']:.3f} s, every {doc['interval_s']} s), "
                  f"{doc['gaps']['count']} gap(s); leap {doc['leap_s']}; fix modes {doc['fix_modes']}")
    messages = Table("message", "count", title="messages")
    for name, count in doc["messages"].items():
        messages.add_row(name, f"{count:,}")
    con.print(messages)
    damage = {k: v for k, v in doc["damage"].items() if v}
    con.print(f"  damage: {damage or 'none'}")
    if doc["unknown_talkers"]:
        con.print(f"  unknown talkers: {doc['unknown_talkers']}")
    if out is not None:
        con.print(f"  wrote {doc['export']['rows']:,} rows to {out}")


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


def _inspect_log(file: Path, series: list, out: Path | None, clock: str | None, json_out: bool) -> None:
    """A field log: per clock its samples, span, interval, columns and events; ``--out`` writes one clock's
    columns (``t_ns`` on the log's time scale, the values in SI units, ``ok``, ``line``)."""
    import numpy as np
    import pandas as pd
    from rich.markup import escape  # clock names carry linuxptp's "[ptp4l.0.config]" tags

    from chronofuse.io.field_logs import pick_series, summarize_log

    doc = summarize_log(series)
    if out is not None:
        s = pick_series(series, clock, str(file))
        table = pd.DataFrame({"t_ns": s.t_ns, **s.columns, "ok": s.ok if s.ok is not None else np.ones(s.n, bool),
                              "line": s.lines})
        out.parent.mkdir(parents=True, exist_ok=True)
        if out.suffix.lower() == ".csv":
            table.to_csv(out, index=False)
        else:
            table.to_parquet(out, index=False)
        doc["export"] = {"file": str(out), "clock": s.clock, "rows": int(len(table))}
    if json_out:
        print_json(doc)
        return
    con = human_console(False)
    con.print(f"[bold]{escape(str(file))}[/bold]: {doc['format']} log, {len(doc['clocks'])} clock(s)")
    table = Table("clock", "samples", "span (s)", "interval (s)", "not ok", "events", "columns", title="clocks")
    for c in doc["clocks"]:
        interval = "-" if c["interval_s"] is None else f"{c['interval_s']:.6g}"
        table.add_row(escape(c["clock"]), f"{c['samples']:,}", f"{c['span_s']:.3f}", interval,
                      "-" if c["not_ok"] is None else str(c["not_ok"]), str(len(c["events"])), ", ".join(c["columns"]))
    con.print(table)
    for note in dict.fromkeys(n for c in doc["clocks"] for n in c["notes"]):
        con.print(f"  {escape(note)}")
    if out is not None:
        con.print(f"  wrote {doc['export']['rows']:,} rows of {escape(doc['export']['clock'])} to {out}")

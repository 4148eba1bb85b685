"""``chronofuse inspect FILE``: what a receiver recording holds, and its per-epoch table."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import fail, human_console, print_json, quiet_output, user_errors
from chronofuse.io.inspect import read_capture, summarize


def register(app: typer.Typer) -> None:
    app.command("inspect")(inspect)


def inspect(
    file: Path = typer.Argument(..., help="NMEA / UBX recording (mixed with RTCM or noise is fine, .gz ok), or RINEX obs/clock."),
    out: Path | None = typer.Option(None, "--out", help="Write the per-epoch table to this file: OUT.csv or OUT.parquet."),
    station: str | None = typer.Option(None, "--station", help="RINEX clock product: the station to export (default: the first)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Receivers, message counts per type, time span, gaps, checksum failures, unknown talkers."""
    quiet_output(quiet)
    if out is not None and out.suffix.lower() not in (".csv", ".parquet"):
        fail(f"--out {out}: the name must end in .csv or .parquet")
    with user_errors():
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

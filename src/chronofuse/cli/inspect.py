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
    file: Path = typer.Argument(..., help="NMEA / UBX recording (mixed with RTCM or noise is fine, .gz ok), or RINEX obs/clock."),
    export: Path | None = typer.Option(None, "--export", help="Write the per-epoch table to OUT.csv or OUT.parquet."),
    receiver: str | None = typer.Option(None, "--receiver", help="A RINEX clock file's station to export (default: the first)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
) -> None:
    """Receivers, message counts per type, time span, gaps, checksum failures, unknown talkers."""
    if export is not None and export.suffix.lower() not in (".csv", ".parquet"):
        fail(f"--export {export}: the name must end in .csv or .parquet")
    with user_errors():
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

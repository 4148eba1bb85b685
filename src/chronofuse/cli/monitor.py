"""``chronofuse monitor SOURCE ...``: watch receivers live, log every epoch durably, report a session."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import typer
from rich.live import Live

from chronofuse.cli.common import err_console, fail, print_json, user_errors
from chronofuse.io.inspect import read_capture
from chronofuse.io.sources import FileSource, parse_source
from chronofuse.monitor.decisions import MonitorSettings
from chronofuse.monitor.engine import Monitor
from chronofuse.monitor.log import EpochLog
from chronofuse.monitor.table import receiver_table
from chronofuse.timescale import NS_PER_S


def register(app: typer.Typer) -> None:
    app.command("monitor")(monitor)


def _replay_source(path: Path, speed: float, index: int) -> FileSource:
    """A recording replayed at ``speed`` x its own pace (its bytes spread over its time span / speed)."""
    capture = read_capture(path)
    span_s = (capture.rows["gps_ns"][-1] - capture.rows["gps_ns"][0]) / NS_PER_S if capture.n_epochs > 1 else 0
    rate = path.stat().st_size / span_s * speed if span_s > 0 else None
    return FileSource(path, name=f"{path.name}#{index}", rate_bytes_s=rate, chunk=4096)


def _line(record: dict) -> str:
    doc = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in record.items()}
    return json.dumps(doc, separators=(",", ":"))


def monitor(
    sources: list[str] = typer.Argument(None, help="serial:/dev/ttyUSB0@9600, tcp:HOST:PORT, gpsd:HOST[:PORT] or a file."),
    db: Path | None = typer.Option(None, "--db", help="Append every epoch to this SQLite log (WAL)."),
    json_lines: bool = typer.Option(False, "--json-lines", help="Print each epoch as a JSON line once it is committed."),
    replay: list[Path] = typer.Option(None, "--replay", help="Replay a recording as a receiver (repeatable)."),
    speed: float = typer.Option(1.0, "--speed", help="Replay pace, x real time."),
    duration: float | None = typer.Option(None, "--duration", help="Stop after this many seconds."),
    report: Path | None = typer.Option(None, "--report", help="Summarize the log DB instead of monitoring."),
    out: Path | None = typer.Option(None, "--out", help="With --report: folder for the plots and summary."),
    gdop_max: float = typer.Option(5.0, "--gdop-max", help="A 1PPS is usable only with GDOP below this."),
    window: int = typer.Option(20, "--window", help="HOD detector window (differences)."),
    pfa: float = typer.Option(1e-3, "--pfa", help="HOD detector false-alarm probability per epoch."),
    training: int = typer.Option(120, "--training", help="Clock-bias epochs that fit each receiver's noise model."),
    h0: float | None = typer.Option(None, "--h0", help="White FM level h0 (s) of the receivers' clocks (with --hm2 and --sigma-rho: no training)."),
    hm2: float | None = typer.Option(None, "--hm2", help="Random-walk FM level h-2 (1/s)."),
    sigma_rho: float | None = typer.Option(None, "--sigma-rho", help="Mean pseudorange noise (m)."),
    train: float | None = typer.Option(None, "--train", help="Fit each receiver's noise model on its first SECONDS of clock bias instead (as detect --train)."),
    jump_ns: float = typer.Option(100.0, "--jump-ns", help="Offset jump between receivers flagged above this (ns)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON summary document on stdout at the end."),
) -> None:
    """Live table per receiver (fix, satellites, GDOP, usable, UTC, leap, clock bias/drift, qErr, alarms)."""
    if report is not None:
        _report(report, out, json_out)
        return
    if json_out and json_lines:
        fail("--json and --json-lines both want stdout: choose one")
    if speed <= 0:
        fail(f"--speed {speed}: must be > 0")
    with user_errors():
        chosen = [parse_source(s) for s in (sources or [])]
        chosen += [_replay_source(p, speed, i) for i, p in enumerate(replay or [])]
        if not chosen:
            fail("no source: give SOURCE arguments or --replay FILE")
        if train is not None and train <= 0:
            fail(f"--train {train:g}: must be > 0 seconds")
        settings = MonitorSettings(gdop_max=gdop_max, window=window, pfa=pfa, training_epochs=training,
                                   jump_s=jump_ns * 1e-9, train_s=train, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho)
        log = EpochLog(db) if db is not None else None

    def ack(records: list[dict]) -> None:
        if json_lines:
            sys.stdout.write("".join(_line(r) + "\n" for r in records))
            sys.stdout.flush()

    mon = Monitor(chosen, settings, log=log, on_ack=ack)
    show = err_console.is_terminal and not json_out
    try:
        if show:
            with Live(receiver_table(mon), console=err_console, refresh_per_second=4, transient=False) as live:
                mon.run(duration, on_tick=lambda m: live.update(receiver_table(m)))
        else:
            mon.run(duration)
    except KeyboardInterrupt:
        pass
    finally:
        if log is not None:
            log.close()
    if json_out:
        print_json({"receivers": [{"receiver": rx.name, "epochs": rx.epochs, "alarms": rx.alarms,
                                   "outages": rx.outages, "last": rx.last} for rx in mon.receivers.values()],
                    "acknowledged": mon.acknowledged, "db": str(db) if db else None})


def _report(db: Path, out: Path | None, json_out: bool) -> None:
    if out is None:
        fail("--report needs --out DIR")
    from chronofuse.monitor.summary import read_session
    from chronofuse.report.figures import plot_deviations, plot_time_error

    with user_errors():
        sessions = read_session(db)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    for s in sessions:
        ok = s.clock_bias_s == s.clock_bias_s
        if ok.any():
            t_s = (s.gps_ns - s.gps_ns[0]) / NS_PER_S
            files.append(str(plot_time_error(t_s[ok], {s.name: s.clock_bias_s[ok]}, out / f"{s.name}_clock_bias.png",
                                             title=f"{s.name}: clock bias, {int(s.alarm.sum())} alarm(s)")))
        if s.adev is not None:
            files.append(str(plot_deviations({"OADEV": s.adev}, out / f"{s.name}_adev.png",
                                             title=f"{s.name}: clock bias stability")))
    doc = {"db": str(db), "receivers": [s.to_dict() for s in sessions], "files": files}
    (out / "summary.json").write_text(json.dumps(doc, indent=2))
    if json_out:
        print_json(doc)
    else:
        for s in sessions:
            d = s.to_dict()
            err_console.print(f"{s.name}: {d['epochs']} epochs, {d['usable']} usable, {d['alarms']} alarm(s), "
                              f"{len(d['outages'])} outage(s)")
        err_console.print(f"wrote {len(files)} plot(s) and summary.json to {out}")

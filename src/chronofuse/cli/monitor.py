"""``chronofuse monitor SOURCE ...``: watch receivers live, log every epoch durably, serve a dashboard and
metrics, fire alert hooks, feed chronyd, report a session.

Output streams: the live table and the event lines go to stderr (the table only when stderr is a
terminal, drawn without capturing stdout); ``--json-lines`` writes each committed record to stdout,
``--json-lines-file`` to a file, with or without the table; ``--json`` one summary at the end.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import typer

from chronofuse.cli.common import err_console, fail, print_json, quiet_output, user_errors


def register(app: typer.Typer) -> None:
    app.command("monitor")(monitor)


def _check_recording(path: Path) -> None:
    """Refuse a file that is not a receiver recording (empty, garbage, a clock-bias text file): it would be
    read as no epochs at all, and the run would end at once, silently."""
    from chronofuse.io.formats import CAPTURE_FORMATS, capture_format

    if not path.is_file():
        fail(f"{path}: no such file")
    if path.stat().st_size == 0:
        fail(f"{path}: empty, not a receiver recording")
    if capture_format(path) is None:
        fail(f"{path}: not a receiver recording ({', '.join(CAPTURE_FORMATS)}); detect FILE or detect - read "
             "clock-bias text files")


def _replay_source(path: Path, speed: float, name: str, start_at):
    """A recording replayed burst by burst at ``speed`` x its own epochs' pace, its first epoch at ``start_at``."""
    from chronofuse.io.replay import ReplaySource

    _check_recording(path)
    return ReplaySource(path, name=name, speed=speed, start_at=start_at)


def _replay_names(paths: list[Path]) -> list[str]:
    """A replayed receiver is named by its file, whatever the order of the options (so one recording
    replayed into one log twice, in any order, keys the same rows); ``#N`` (its place among the replays)
    only tells apart two replays of files of one name in one run."""
    names = [p.name for p in paths]
    return [f"{n}#{i}" if names.count(n) > 1 else n for i, n in enumerate(names)]


def _timeout(value: float | None, name: str) -> float | None:
    if value is None or math.isinf(value):
        return None
    if value < 0:
        fail(f"{name} {value}: must be >= 0 s (or inf)")
    return value


def monitor(
    sources: list[str] = typer.Argument(None, help="serial:/dev/ttyUSB0@9600, tcp:HOST:PORT, gpsd:HOST[:PORT] or a file."),
    db: Path | None = typer.Option(None, "--db", help="Append every epoch to this SQLite log (WAL); one row per receiver and epoch."),
    json_lines: bool = typer.Option(False, "--json-lines", help="Print each epoch on stdout as a JSON line once it is committed."),
    json_lines_file: Path | None = typer.Option(None, "--json-lines-file", help="Append each committed epoch as a JSON line to this file."),
    replay: list[Path] = typer.Option(None, "--replay", help="Replay a recording as a receiver (repeatable)."),
    replay_speed: float = typer.Option(1.0, "--replay-speed", help="Replay pace, a factor of real time (2: twice as fast)."),
    duration: float | None = typer.Option(None, "--duration", help="Stop after this long (s)."),
    report: Path | None = typer.Option(None, "--report", help="Summarize the log DB instead of monitoring."),
    out: Path | None = typer.Option(None, "--out", help="With --report: folder for the plots and summary."),
    gdop_max: float = typer.Option(5.0, "--gdop-max", help="A 1PPS is usable only with GDOP below this."),
    window: int = typer.Option(20, "--window", help="HOD detector window (epochs)."),
    pfa: float = typer.Option(1e-3, "--pfa", help="HOD detector false-alarm probability per epoch."),
    h0: float | None = typer.Option(None, "--h0", help="White FM level h0 (s) of the receivers' clocks (with --hm2 and --sigma-rho: no training)."),
    hm2: float | None = typer.Option(None, "--hm2", help="Random-walk FM level h-2 (1/s)."),
    sigma_rho: float | None = typer.Option(None, "--sigma-rho", help="Mean pseudorange noise (m)."),
    train: float = typer.Option(120.0, "--train", help="Learn each receiver's missing noise parameters from its first clock biases "
                                "over this long (s), as detect --train does."),
    jump_ns: float = typer.Option(100.0, "--jump-ns", help="Offset jump between receivers flagged above this (ns)."),
    stale_s: float = typer.Option(5.0, "--stale-s", help="A receiver silent for longer than this (s) is stale: not usable, an event."),
    connect_timeout_s: float = typer.Option(0.0, "--connect-timeout-s", help="Retry a source that cannot be opened at the start for this long (s; inf: for ever); then exit 2 naming it. 0: the first failure."),
    reconnect_timeout_s: float = typer.Option(math.inf, "--reconnect-timeout-s", help="Give up (exit 2) on a source down for longer than this (s); default: retry for ever, backoff 0.1 s doubling to 5 s."),
    http: str | None = typer.Option(None, "--http", help="Serve the dashboard, /api/status and /metrics at HOST:PORT (HOST defaults to 127.0.0.1)."),
    on_alarm: str | None = typer.Option(None, "--on-alarm", help="Run this shell command once per alarm event (event JSON on stdin, CHRONOFUSE_* variables)."),
    webhook: str | None = typer.Option(None, "--webhook", help="POST each alarm event as JSON to this URL."),
    chrony_sock: Path | None = typer.Option(None, "--chrony-sock", help="Feed integrity-gated samples to chronyd's 'refclock SOCK' at this path."),
    no_table: bool = typer.Option(False, "--no-table", help="No live table on stderr, even on a terminal (event lines only)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON summary document on stdout at the end."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document or --json-lines)."),
) -> None:
    """Live table per receiver (fix, satellites, GDOP, usable and why not, UTC, leap, clock bias/drift, qErr,
    alarms, age), events on stderr, the log, a web dashboard, metrics, alert hooks and a chrony feed."""
    quiet_output(quiet)
    if report is not None:
        _report(report, out, json_out)
        return
    if json_out and json_lines:
        fail("--json and --json-lines both want stdout: choose one")
    if not replay_speed > 0:
        fail(f"--replay-speed == {replay_speed}, must be > 0")
    if not stale_s > 0:
        fail(f"--stale-s {stale_s}: must be > 0 s")
    if window < 1:
        fail(f"--window {window}: must be >= 1")
    if duration is not None and not duration > 0:
        fail(f"--duration {duration:g}: must be > 0 s")
    if not jump_ns > 0:
        fail(f"--jump-ns {jump_ns:g}: must be > 0 ns")
    if webhook is not None:
        from urllib.parse import urlsplit

        url = urlsplit(webhook)
        if url.scheme not in ("http", "https") or not url.hostname:
            fail(f"--webhook {webhook!r}: not an http:// or https:// URL with a host")
    if not 0.0 < pfa < 1.0:
        fail(f"--pfa {pfa:g}: must be in (0, 1)")
    connect = _timeout(connect_timeout_s, "--connect-timeout-s")
    reconnect = _timeout(reconnect_timeout_s, "--reconnect-timeout-s")
    with user_errors():
        from chronofuse.io.sources import parse_source

        chosen = [parse_source(s) for s in (sources or [])]
        for source in chosen:
            path = getattr(source, "path", None)
            if path is not None and not path.exists():
                fail(f"{path}: no such file (a source is serial:PORT, tcp:HOST:PORT, gpsd:HOST[:PORT] or a file)")
            if path is not None:
                _check_recording(path)
        from chronofuse.io.replay import SharedStart

        start_at = SharedStart()  # the replays' first epochs together (GPS-locked receivers are)
        chosen += [_replay_source(p, replay_speed, n, start_at) for p, n in zip(replay or [], _replay_names(replay or []))]
        if not chosen:
            fail("no source: give SOURCE arguments or --replay FILE")
        if not train > 0:
            fail(f"--train {train:g}: must be > 0 s")
        names = [s.name for s in chosen]
        if len(set(names)) != len(names):
            fail(f"two sources share the name {next(n for n in names if names.count(n) > 1)!r}")
        from chronofuse.monitor.decisions import MonitorSettings
        from chronofuse.monitor.log import EpochLog
        from chronofuse.monitor.web import parse_address

        address = parse_address(http, "--http") if http is not None else None
        settings = MonitorSettings(gdop_max=gdop_max, window=window, pfa=pfa, train_s=train,
                                   jump_s=jump_ns * 1e-9, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho)
        settings.check()  # every setting refused here, naming its option, before a source is opened
        log = EpochLog(db) if db is not None else None
    try:
        lines_file = open(json_lines_file, "a", encoding="utf-8") if json_lines_file is not None else None
    except OSError as err:
        fail(f"{json_lines_file}: {err.strerror}")
    from chronofuse.monitor.live_outputs import LiveOutputs

    outputs = LiveOutputs(json_lines=json_lines, lines_file=lines_file, http_address=address, on_alarm=on_alarm,
                          webhook=webhook, chrony_sock=chrony_sock, replayed=bool(replay),
                          table=err_console.is_terminal and not (json_out or no_table or quiet), console=err_console)
    with user_errors():
        outputs.listen()  # --http: a port in use or an address not on this host, refused before the run
    from chronofuse.monitor.engine import Monitor, SourceUnavailable
    from chronofuse.monitor.live_outputs import OutputClosed

    mon = Monitor(chosen, settings, log=log, on_ack=outputs.records, on_event=outputs.event, stale_s=stale_s,
                  connect_timeout_s=connect, reconnect_timeout_s=reconnect)
    outputs.attach(mon)
    gave_up = None
    try:
        with outputs.running(), user_errors():
            mon.run(duration, on_tick=outputs.tick)
    except SourceUnavailable as err:
        gave_up = str(err)
    except (KeyboardInterrupt, OutputClosed):  # Ctrl-C, or the reader of --json-lines went away: quietly
        pass
    finally:
        if log is not None:
            log.close()
        if lines_file is not None:
            lines_file.close()
    if gave_up is not None:
        fail(gave_up)
    if json_out:
        print_json({"receivers": [{"receiver": rx.name, "epochs": rx.epochs, "alarms": rx.alarms,
                                   "outages": rx.outages, "last": rx.last} for rx in mon.receivers.values()],
                    "acknowledged": mon.acknowledged, "db": str(db) if db else None,
                    "chrony": outputs.chrony.state() if outputs.chrony is not None else None,
                    "alerts": outputs.alert_counts()})


def _report(db: Path, out: Path | None, json_out: bool) -> None:
    if out is None:
        fail("--report needs --out DIR")
    from chronofuse.monitor.summary import read_session
    from chronofuse.report.figures import plot_deviations, plot_time_error
    from chronofuse.timescale import NS_PER_S

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
    from chronofuse.report.html import monitor_page

    monitor_page(doc, out, command=f"chronofuse monitor --report {db} --out {out}")
    if json_out:
        print_json(doc)
    else:
        for s in sessions:
            d = s.to_dict()
            err_console.print(f"{s.name}: {d['epochs']} epochs, {d['usable']} usable, {d['alarms']} alarm(s), "
                              f"{d['dissent_epochs']} dissenting, {d['jumps']} jump(s), {len(d['outages'])} outage(s)")
        err_console.print(f"wrote {len(files)} plot(s), summary.json and report.html to {out}")


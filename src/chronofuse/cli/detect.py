"""``chronofuse detect FILE``: clock-bias anomaly detection on a CSV, UBX or RINEX record.

The work is :func:`chronofuse.integrity.modes.detect_file` (its docstring says how the mode is chosen, how
the noise model is set, what the states mean and how missing data are counted); this command parses the
options, calls it and prints its document: ``--json`` as it is, else a summary, the clock events and a
table of alarms. Exit status: 0 integrity ok, 1 alarm, 3 integrity unavailable, 2 bad input.
"""

from __future__ import annotations

import math
from pathlib import Path

import typer

# The library (numpy, scipy, georinex), chronofuse.cli.common (numpy through report.jsonio) and rich's table
# are imported inside the command, so that `detect --help` pays only for typer (under 0.5 s).

_EXIT_CODES = {"ok": 0, "alarm": 1, "unavailable": 3}  # chronofuse.integrity.modes.EXIT_CODES (a test checks)

_MAX_TABLE_ROWS = 50
#: How often an idle ``detect -`` wakes to release the epochs its reorder buffer holds (s).
IDLE_TICK_S = 0.1

# chronofuse.integrity.receiver_status.DEFAULT_MAX_TIME_ACC_S in ns (a test checks; not imported for --help)
_DEFAULT_MAX_TACC_NS = 100.0


def register(app: typer.Typer) -> None:
    app.command("detect")(detect)


def detect(
    file: Path = typer.Argument(..., help="Clock-bias CSV (time + bias column), UBX (NAV-CLOCK), RINEX observation file, RINEX clock product (.clk), or a field log (ptp4l/phc2sys/ts2phc, chrony, RTKLIB .stat, gpsd JSON, Trimble TSIP); - : standard input (any of these but RINEX observations and field logs, read as it arrives)."),
    rate: float | None = typer.Option(None, "--rate", help="Sampling rate (Hz) of a file without a time column."),
    column: str | None = typer.Option(None, "--column", help="CSV clock-bias column (name)."),
    h0: float | None = typer.Option(None, "--h0", help="White FM level h0 (s)."),
    hm2: float | None = typer.Option(None, "--hm2", help="Random-walk FM level h-2 (1/s)."),
    sigma_rho: float | None = typer.Option(None, "--sigma-rho", help="Mean pseudorange noise (m)."),
    train: float | None = typer.Option(None, "--train", help="Learn the missing noise parameters from the first stretch of this length (s)."),
    window: int | None = typer.Option(None, "--window", help="Window length n (epochs; default 20) of a windowed detector."),
    pfa: float = typer.Option(1e-3, "--pfa", help="False-alarm probability per epoch."),
    position: str | None = typer.Option(None, "--position", help="Static antenna ECEF X,Y,Z (m): identification mode."),
    nav: list[Path] | None = typer.Option(None, "--nav", help="RINEX navigation file (identification mode); repeat for several (RINEX 3 observations: each day the file spans)."),
    station: str | None = typer.Option(None, "--station", help="RINEX clock product: the station to test (default: all, a table); a field log (ptp4l, chrony, ...): the clock to test (default: the first)."),
    max_tacc_ns: float = typer.Option(_DEFAULT_MAX_TACC_NS, "--max-tacc-ns", help="UBX: epochs whose receiver time accuracy (NAV-CLOCK tAcc) is over this many ns are not tested (unavailable); 0: not used."),
    noise: Path | None = typer.Option(None, "--noise", help="Noise model JSON (a previous --json output): h0, hm2, sigma_rho_m."),
    test: str = typer.Option("chi-square", "--test", help="RINEX 3 identification: the window test of each channel and of the receiver clock, chi-square or glr (a GLR for step, ramp and drag onsets)."),
    codes: str | None = typer.Option(None, "--codes", help="RINEX 3 identification: codes to test, comma-separated (e.g. 'G C1C,E C1X'); default every code most satellites of a system carry."),
    elevation_mask_deg: float = typer.Option(10.0, "--elevation-mask-deg", help="RINEX 3 identification: channels below this elevation (deg) are not used."),
    report: Path | None = typer.Option(None, "--report", help="Also write the verdict, its reason and every alarm as one HTML page."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
    follow: float | None = typer.Option(None, "--follow", help="With --json-lines: FILE is still being written; wait for new lines, stop after this long without any (s)."),
    json_lines: bool = typer.Option(False, "--json-lines", help="Stream: one JSON line per epoch as it is decided (FILE may be - for stdin, a pipe or a FIFO)."),
    raim: bool = typer.Option(False, "--raim", help="RINEX observations with --nav: position-domain integrity (protection levels against alert limits, fault detection and exclusion by solution separation); --position, if given, only checks the levels; no noise model or --train needed."),
    horizontal_alert_limit_m: float = typer.Option(40.0, "--horizontal-alert-limit-m", help="--raim: horizontal alert limit (m)."),
    vertical_alert_limit_m: float = typer.Option(50.0, "--vertical-alert-limit-m", help="--raim: vertical alert limit (m)."),
    integrity_risk: float = typer.Option(1e-4, "--integrity-risk", help="--raim: per-epoch budget of P(error beyond the protection level and no alarm)."),
    p_md: float = typer.Option(1e-3, "--p-md", help="--raim: missed-detection probability of the stated minimum detectable bias."),
    detector: str = typer.Option("chi-square", "--detector", help="Detector: chi-square (default), single-epoch, cusum, or one a plugin registers (group chronofuse.detectors)."),
) -> None:
    """Detect clock-bias anomalies with the high-order-difference chi-square test.

    Exit status: 0 integrity ok (tested, no alarm), 1 alarm, 3 integrity unavailable (too little could be
    tested, training failed, or the position is off), 2 bad input.
    """
    from chronofuse.cli.common import fail, print_json, quiet_output, user_errors

    quiet_output(quiet)

    if rate is not None and (rate <= 0 or not math.isfinite(rate)):
        fail(f"--rate {rate:g}: must be a positive number of Hz")
    if window is not None and window < 1:
        fail(f"--window {window}: must be >= 1")
    if not 0.0 < pfa < 1.0:
        fail(f"--pfa {pfa:g}: must be in (0, 1)")
    if train is not None and train <= 0:
        fail(f"--train {train:g}: must be > 0 seconds")
    if follow is not None and not (json_lines or str(file) == "-"):
        fail(f"--follow {follow:g}: a file still being written is read with --json-lines (or as -)")
    if not (max_tacc_ns >= 0 and math.isfinite(max_tacc_ns)):
        fail(f"--max-tacc-ns {max_tacc_ns:g}: must be >= 0 ns (0: not used)")
    from chronofuse.integrity.modes import detect_file, read_noise_file

    if raim:
        _raim(file, nav, position, pfa, horizontal_alert_limit_m, vertical_alert_limit_m, integrity_risk, p_md,
              elevation_mask_deg, json_out, report, json_lines=json_lines, train=train, detector=detector)
    from chronofuse.integrity.registry import DETECTORS

    if detector not in DETECTORS:
        fail(f"--detector {detector!r}: must be one of {', '.join(DETECTORS.names())}")
    if window is not None and "window" not in DETECTORS.entry(detector).config.model_fields:
        fail(f"--window {window}: detector {detector!r} has no window")
    window = 20 if window is None else window

    if noise is not None:
        with user_errors():
            model = read_noise_file(noise)
        h0 = model["h0"] if h0 is None else h0
        hm2 = model["hm2"] if hm2 is None else hm2
        sigma_rho = model["sigma_rho_m"] if sigma_rho is None else sigma_rho
    if train is None and None in (h0, hm2, sigma_rho):
        fail("give the noise model (--h0, --hm2 and --sigma-rho) or a training stretch (--train SECONDS)")
    max_tacc_s = max_tacc_ns / 1e9 if max_tacc_ns > 0 else None
    if json_lines or str(file) == "-":
        _stream(file, follow, json_lines, json_out, rate_hz=rate, column=column, station=station, detector=detector,
                settings=dict(window=window, pfa=pfa, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho, train_s=train,
                              max_time_acc_s=max_tacc_s))
    from chronofuse.cli.common import progress_reporter

    with user_errors(), progress_reporter("detect") as say:
        say(f"testing {file.name}")  # a RINEX 3 station's stages and epochs say their fraction (the long one)
        doc = detect_file(file, rate, progress=say, column=column, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho, train_s=train,
                          window=window, pfa=pfa, position_m=position, nav=nav or None, station=station,
                          max_time_acc_s=max_tacc_s, detector=detector, test=test,
                          codes=[c.strip() for c in codes.split(",") if c.strip()] if codes else None,
                          elevation_mask_deg=elevation_mask_deg)
        if report is not None:
            from chronofuse.report.html import detect_page

            detect_page(doc, report, str(file), command=f"chronofuse detect {file}")
    if json_out:
        print_json(doc)
    else:
        _print_human(file, doc)
    raise typer.Exit(_EXIT_CODES[doc["state"]])


def _stream(file: Path, follow: float | None, json_lines: bool, json_out: bool, *, rate_hz, column, station,
            detector: str, settings: dict) -> None:
    """``-`` or ``--json-lines``: the stream read as it arrives through the detection pipeline's live driver
    (:class:`chronofuse.integrity.live.StreamDetection`); with ``--json-lines`` one JSON line per epoch,
    flushed as it is decided; at the end the document ``detect FILE`` gives for the same data (printed unless
    ``--json-lines``), whose state is the exit status."""
    import json
    import sys

    from chronofuse.cli.common import print_json, user_errors
    from chronofuse.integrity.live import StreamDetection, follow_lines
    from chronofuse.integrity.modes import detection_settings
    from chronofuse.io.record_streams import read_chunks

    name = "<stdin>" if str(file) == "-" else str(file)
    with user_errors():
        source = sys.stdin.buffer if str(file) == "-" else open(file, "rb")  # noqa: SIM115
        try:
            if follow is None:
                chunks = read_chunks(source, idle_s=IDLE_TICK_S)
            else:
                import io

                text = io.TextIOWrapper(source, encoding="utf-8", errors="replace")
                chunks = (line.encode() for line in follow_lines(text, idle_s=follow))
            run = StreamDetection(chunks, detection_settings(detector, **settings), source=name, rate_hz=rate_hz, column=column,
                                  station=station, live=follow is None)
            for key, verdict in run:
                if json_lines:
                    line = verdict.as_json() if key is None or station is not None else {"station": key,
                                                                                          **verdict.as_json()}
                    sys.stdout.write(json.dumps(line) + "\n")
                    sys.stdout.flush()
            doc = run.document()
        finally:
            if source is not sys.stdin.buffer:
                source.close()
    if not json_lines:
        if json_out:
            print_json(doc)
        else:
            _print_human(Path(name), doc)
    raise typer.Exit(_EXIT_CODES[doc["state"]])


def _print_stations(file: Path, doc: dict) -> None:
    from rich.table import Table

    from chronofuse.cli.common import human_console

    con = human_console(False)
    con.print(f"[bold]{file}[/bold]: clock product, {doc['n_stations']} stations, window {doc['window']}, "
              f"P_fa {doc['pfa']:g}; overall {doc['state']}")
    table = Table("station", "state", "epochs", "tested", "alarms", "rate", "clock events", "noise ratio", "p",
                  "reason")
    for row in doc["stations"]:
        change = row.get("noise_change") or {}
        ratio, p_value = change.get("ratio", math.nan), change.get("p_value", math.nan)
        rate = row["n_alarms"] / row["n_tested"] if row["n_tested"] else math.nan
        table.add_row(row["station"], row["state"], str(row["n_epochs"]), str(row["n_tested"]), str(row["n_alarms"]),
                      _num(rate, ".1%"), str(len(row["clock_events"])), _num(ratio, ".3g"), _num(p_value, ".2g"),
                      "; ".join(row["unavailable_reasons"]))
    con.print(table)
    fa = doc.get("false_alarms")
    if fa:
        con.print(f"false alarms over the {len(fa['no_event'])} stations with no clock event and no noise change "
                  f"(F test p >= {fa['alpha']:g}): {fa['n_alarms']} in {fa['n_tested']} tested epochs = "
                  f"{_num(fa['rate'], '.2%')} (nominal {fa['nominal']:.2%})")
        con.print(f"  over every station without a clock event: {fa['all_n_alarms']} in {fa['all_n_tested']} = "
                  f"{_num(fa['all_rate'], '.2%')}")
        for key, label in (("clock_event", "clock events"), ("noise_changed", "noise changed after training"),
                           ("untested", "not tested"), ("no_event", "no event")):
            con.print(f"  {label} ({len(fa[key])}): {', '.join(fa[key]) or '-'}", soft_wrap=False)


def _raim(file: Path, nav, position, pfa, hal_m, val_m, integrity_risk, p_md, elevation_mask_deg, json_out, report,
          *, json_lines, train, detector) -> None:
    """``detect OBS --nav NAV --raim``: :func:`chronofuse.integrity.raim_station.raim_document`, printed."""
    from chronofuse.cli.common import fail, print_json, progress_reporter, user_errors
    from chronofuse.integrity.modes import detect_file
    from chronofuse.integrity.raim import RaimSettings

    if json_lines or str(file) == "-":
        fail("--raim reads a whole RINEX observation file: not with --json-lines or -")
    if train is not None or detector != "chi-square":
        fail("--raim needs no noise model: --train and --detector are for clock-bias detection")
    for flag, value in (("--integrity-risk", integrity_risk), ("--p-md", p_md)):
        if not 0.0 < value <= 0.5:
            fail(f"{flag} {value:g}: must be in (0, 0.5]")
    if not 0.0 < pfa <= 0.5:
        fail(f"--pfa {pfa:g}: must be in (0, 0.5] with --raim")
    for flag, value in (("--horizontal-alert-limit-m", hal_m), ("--vertical-alert-limit-m", val_m)):
        if not (value > 0 and math.isfinite(value)):
            fail(f"{flag} {value:g}: must be a positive number of metres")
    settings = RaimSettings(pfa=pfa, integrity_risk=integrity_risk, p_md=p_md, horizontal_alert_limit_m=hal_m,
                            vertical_alert_limit_m=val_m)
    with user_errors(), progress_reporter("detect") as say:
        say(f"RAIM on {file.name}")
        doc = detect_file(file, nav=nav or None, position_m=position, raim=True, raim_settings=settings,
                          elevation_mask_deg=elevation_mask_deg)
        if report is not None:
            from chronofuse.report.html import detect_page

            detect_page(doc, report, str(file), command=f"chronofuse detect {file} --raim")
    if json_out:
        print_json(doc)
    else:
        _print_raim(file, doc)
    raise typer.Exit(_EXIT_CODES[doc["state"]])


def _print_raim(file: Path, doc: dict) -> None:
    from chronofuse.cli.common import human_console

    con = human_console(False)
    states = doc["epoch_states"]
    con.print(f"[bold]{file}[/bold]: RAIM ({'+'.join(doc['systems'])}), {doc['n_epochs']:,} epochs: "
              + ", ".join(f"{states[s]:,} {s}" for s in states) + f"; availability {doc['availability']:.1%}")
    con.print(f"alert limits H {doc['horizontal_alert_limit_m']:g} m, V {doc['vertical_alert_limit_m']:g} m; "
              f"P_fa {doc['pfa']:g}, integrity risk {doc['integrity_risk']:g}")
    hpl, vpl, mdb = doc["hpl_m"], doc["vpl_m"], doc["mdb_m"]
    con.print(f"HPL median {_num(hpl['median'], '.1f')} m (95 % {_num(hpl['p95'], '.1f')} m), VPL median "
              f"{_num(vpl['median'], '.1f')} m (95 % {_num(vpl['p95'], '.1f')} m), minimum detectable bias median "
              f"{_num(mdb['median'], '.1f')} m (at P_md {doc['p_md']:g})")
    check = doc.get("position_check")
    if check is not None:
        lo, hi = check["rate_ci95"]
        con.print(f"against the position given: horizontal error median {_num(check['horizontal_error_m']['median'], '.2f')} m, "
                  f"max {_num(check['horizontal_error_m']['max'], '.2f')} m; {check['n_beyond_level']} of "
                  f"{check['n_epochs']:,} available epochs beyond a level (95 % CI {_num(lo, '.2g')}..{_num(hi, '.2g')})")
    if doc["excluded"]:
        con.print("excluded: " + ", ".join(doc["excluded"]))
    if doc["state"] == "unavailable":
        con.print("[red]integrity unavailable[/red]: " + "; ".join(doc["unavailable_reasons"]))
    elif doc["state"] == "alarm":
        con.print(f"[red]integrity alarm[/red]: {doc['n_alarms']} epoch(s) detected a fault")
    else:
        con.print("[green]integrity ok: no alarm[/green]")


def _num(value: float | None, spec: str) -> str:
    return "-" if value is None or not math.isfinite(value) else format(value, spec)


def _print_human(file: Path, doc: dict) -> None:
    if doc["mode"] == "clock-product":
        _print_stations(file, doc)
        return
    from rich.table import Table

    from chronofuse.cli.common import human_console

    con = human_console(False)
    con.print(f"[bold]{file}[/bold]: {doc['mode']} mode, {doc['n_epochs']:,} epochs ({doc['n_skipped']} skipped, "
              f"{doc['n_tested']:,} tested), interval {doc['interval_s']:g} s, window {doc['window']}, "
              f"P_fa {doc['pfa']:g}, threshold {doc['threshold']:.3f}")
    if doc.get("noise"):
        noise = doc["noise"]
        con.print(f"noise model: h0 {noise['h0']:.3e} s, h-2 {noise['hm2']:.3e} /s, sigma_rho {noise['sigma_rho_m']:.3g} m")
    for warning in doc.get("warnings", []):
        con.print(f"[yellow]warning[/yellow]: {warning}")
    if doc.get("untested"):
        con.print(f"not tested: {', '.join(doc['untested'])}")
    for event in doc.get("clock_events", []):
        con.print(f"clock event: receiver clock reset of {event['size_s'] * 1e3:+g} ms at t = {_t(event['t_ns'])} s")
    if doc.get("faulty"):
        con.print("faulty: " + ", ".join(f"{f['channel']} (from t = {_t(f['t_ns'])} s)" for f in doc["faulty"]))
    for event in doc.get("channel_events", []):
        con.print(f"{event['kind']} {event['channel']} at t = {_t(event['t_ns'])} s: {event['reason']}")
    if doc["state"] == "unavailable":
        con.print("[red]integrity unavailable[/red]: " + "; ".join(doc["unavailable_reasons"]))
    elif not doc["alarms"]:
        con.print("[green]integrity ok: no alarm[/green]")
    if not doc["alarms"]:
        return
    table = Table("t (s)", "statistic", "channel", title=f"{doc['n_alarms']} alarm(s)")
    for alarm in doc["alarms"][:_MAX_TABLE_ROWS]:
        table.add_row(_t(alarm["t_ns"]), f"{alarm['statistic']:.2f}", alarm["channel"] or "clock")
    con.print(table)
    if doc["n_alarms"] > _MAX_TABLE_ROWS:
        con.print(f"... {doc['n_alarms'] - _MAX_TABLE_ROWS} more (use --json for all)")


def _t(t_ns: int) -> str:
    """An epoch of integer nanoseconds as exact seconds (``1800``, ``0.5``, ``-1.000000001``)."""
    sign = "-" if t_ns < 0 else ""
    whole, frac = divmod(abs(int(t_ns)), 1_000_000_000)
    return f"{sign}{whole}" + (f".{frac:09d}".rstrip("0") if frac else "")

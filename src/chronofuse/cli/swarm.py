"""``chronofuse swarm ...``: two-way clock synchronization over radio links (the swarm paper)."""

from __future__ import annotations

import functools
import inspect
import math
import time
import warnings
from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from chronofuse.cli.common import collected_warnings, fail, human_console, print_json, progress_reporter, quiet_output, user_errors
from chronofuse.cli.swarm_options import (
    SCENARIO_KEYS,
    algorithm_names,
    build_scenario,
    load_models,
    model_files,
    quiet_dask,
    scenario_options,
    trial_progress,
)

swarm_app = typer.Typer(help="Swarm clock synchronization over two-way radio links.", no_args_is_help=True)


def register(app: typer.Typer) -> None:
    app.add_typer(swarm_app, name="swarm")


def with_scenario(func):
    """Add the link-scenario options to a command; the command receives them as ``scenario`` (built)."""
    options = scenario_options()
    params = [p for name, p in inspect.signature(func).parameters.items() if name != "scenario"]
    kinds = {"exchanges": int, "toa_model": str, "oscillator": str, "manoeuvre": str, "clock_truth": str,
             "latitude": Optional[float]}
    extra = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=options[name],
                               annotation=kinds.get(name, float)) for name in SCENARIO_KEYS]

    @functools.wraps(func)
    def command(**kwargs):
        values = {name: kwargs.pop(name) for name in SCENARIO_KEYS}
        with user_errors():
            scenario = build_scenario(**values)
        return func(scenario=scenario, **kwargs)

    command.__signature__ = inspect.Signature(
        [p.replace(kind=inspect.Parameter.KEYWORD_ONLY) for p in params] + extra)
    return command


def _write_summary(out: Path, doc: dict) -> list[str]:
    """``out``/summary.json holding ``doc`` (the --json document); returns the file written."""
    from chronofuse.report.jsonio import dumps

    with user_errors():
        out.mkdir(parents=True, exist_ok=True)
        (out / "summary.json").write_text(dumps(doc) + "\n")
    return [str(out / "summary.json")]


def _urt_mode(urt_mode: str) -> None:
    if urt_mode not in ("paper", "calibrated"):
        fail(f"--urt-mode == {urt_mode!r}, must be 'paper' or 'calibrated'")


def _num(x: float, spec: str) -> str:
    """A figure for the human table; "-" where it is not available (NaN)."""
    return "-" if x is None or x != x else format(x, spec)


def _span(lo: float, hi: float) -> str:
    """An interval for the human table; "not available" where it has none (too few trials scored)."""
    if lo is None or hi is None or lo != lo or hi != hi:
        return "not available"
    return f"{lo:.3g}-{hi:.3g}"


@swarm_app.command("run")
@with_scenario
def run(
    scenario=None,
    algorithm: str = typer.Option("all", "--algorithm", help="Comma-separated algorithm names, or 'all'."),
    urt_mode: str = typer.Option("calibrated", "--urt-mode",
                                 help="paper (the paper's batch URT estimate) or calibrated (per link, under GNSS)."),
    trials: int = typer.Option(20, "--trials", help="Monte Carlo trials (links, each its own prior draw); intervals need at least 10."),
    seed: int = typer.Option(0, "--seed", help="Root seed (trial i uses its own child stream)."),
    threshold: float = typer.Option(1e-9, "--threshold", help="Convergence threshold tau of K* (s)."),
    model: Path = typer.Option(None, "--model", help="BP model file for rtt-rvc-kf-bp (chronofuse swarm train)."),
    lstm_model: Path = typer.Option(None, "--lstm-model", help="LSTM model file for rtt-rvc-kf-lstm."),
    outage: str = typer.Option(None, "--outage", help="K0:K1: also lose exchanges K0..K1-1 (robustness)."),
    true_offset: float = typer.Option(None, "--true-offset",
                                      help="Every trial's true initial offset (s) instead of a draw from the prior, "
                                           "which the nodes still assume (a test of the prior's tails)."),
    out: Path | None = typer.Option(None, "--out", help="Report folder: summary.json, the JSON document (created)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Simulate two-node links and run the algorithms: RMSE and its ratio to the Bayesian bound (95 %
    intervals over trials), K*, overhead."""
    quiet_output(quiet)
    from chronofuse.experiments.swarm import run_link
    from chronofuse.experiments.swarm_documents import link_report

    with user_errors(), collected_warnings() as notes:
        _urt_mode(urt_mode)
        files = model_files(model, lstm_model)
        names = algorithm_names(algorithm, files)
        networks = load_models(files, urt_mode)
        window = None
        if outage is not None:
            try:
                window = tuple(int(k) for k in outage.split(":"))
            except ValueError:
                window = ()
            if len(window) != 2:
                fail(f"--outage == {outage!r}, must be K0:K1 (two exchange numbers)")
        if trials < 1:
            fail(f"--trials == {trials}, must be >= 1")
        if true_offset is not None and not math.isfinite(true_offset):
            fail(f"--true-offset == {true_offset!r}, must be a finite number of seconds")
        with progress_reporter("swarm run") as say:
            say(f"simulating {trials} links", 0.0)
            res = run_link(scenario, names, trials=trials, seed=seed, urt_mode=urt_mode, threshold_s=threshold,
                           networks=networks, outage=window, true_offset_s=true_offset, progress=say)
    doc = link_report(res) | {"warnings": notes}
    if out is not None:
        from chronofuse.report.html import swarm_page

        doc["files"] = _write_summary(out, doc) + [str(out / "report.html")]
        swarm_page(doc, out)
    if json_out:
        print_json(doc)
        return
    con = human_console(False)
    for note in notes:
        con.print(f"warning: {note}", markup=False, emoji=False)
    table = Table("algorithm", "trials scored", "RMSE (ns)", "95 % interval", "RMSE / bound", "95 % interval", "K*",
                  title=f"{trials} links, URT {urt_mode}")
    for name, value in doc["rmse_ns"].items():
        k = doc["convergence_epochs"][name]
        scored = trials - len(doc["unscored_trials"][name])
        table.add_row(name, f"{scored}/{trials}", _num(value, ".4g"), _span(*doc["rmse_ci_ns"][name]),
                      _num(doc["ratio_to_bound"][name], ".3g"), _span(*doc["ratio_ci"][name]),
                      "-" if k is None else str(k))
    con.print(table)
    con.print(f"Bayesian bound (same model, the stated prior, the calibration's uncertainty): "
              f"{doc['bound_ns']['rms']:.4g} ns RMS over the run, {doc['bound_ns']['final']:.4g} ns at the end; "
              f"each ratio's bound is over the exchanges that algorithm is scored on (those it gave an estimate at; "
              f"--json: bound_scored_ns)")


@swarm_app.command("sweep")
@with_scenario
def sweep(
    scenario=None,
    param: str = typer.Option(..., "--param", help="velocity | distance | reply-delay | urt | snr."),
    values: str = typer.Option(..., "--values", help="Comma-separated values, SI units (m/s, m, s, s, dB)."),
    algorithm: str = typer.Option("ptp-mls,rtt-rvc,rtt-rvc-kf,doppler-kf", "--algorithm",
                                  help="Comma-separated algorithm names."),
    urt_mode: str = typer.Option("calibrated", "--urt-mode", help="paper or calibrated."),
    trials: int = typer.Option(100, "--trials", help="Monte Carlo trials per value; intervals need at least 10."),
    chunk_trials: int = typer.Option(25, "--chunk-trials", help="Trials per task (fixes the random streams)."),
    seed: int = typer.Option(0, "--seed", help="Root seed."),
    scheduler: str = typer.Option("local", "--scheduler",
                                  help="Where the trials run: 'local' (a Dask LocalCluster of processes), 'serial' "
                                       "(this process) or tcp://HOST:PORT of a Dask scheduler."),
    out: Path = typer.Option(Path("swarm-sweep"), "--out", help="Folder for the table, summary and figure."),
    model: Path = typer.Option(None, "--model", help="BP model file for rtt-rvc-kf-bp."),
    lstm_model: Path = typer.Option(None, "--lstm-model", help="LSTM model file for rtt-rvc-kf-lstm."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Sweep one parameter over values: a tidy table (CSV and Parquet), a summary with intervals and a figure."""
    quiet_output(quiet)
    from chronofuse.experiments.sweep import SWEEP_PARAMS, run_sweep, scenario_at, summarize
    from chronofuse.report.swarm import plot_sweep, write_sweep
    from chronofuse.sync.metrics import MIN_INTERVAL_TRIALS
    from chronofuse.validation import InputWarning

    with user_errors(), collected_warnings() as notes:
        from chronofuse.extras import require

        require("distributed", "swarm sweep")
        if param not in SWEEP_PARAMS:
            fail(f"--param == {param!r}, must be one of {list(SWEEP_PARAMS)}")
        try:
            value_list = [float(v) for v in values.split(",") if v.strip()]
        except ValueError:
            fail(f"--values == {values!r}, must be comma-separated numbers")
        if not value_list:
            fail("--values is empty, must give at least one number")
        _urt_mode(urt_mode)
        files = model_files(model, lstm_model)
        names = algorithm_names(algorithm, files)
        load_models(files, urt_mode)
        if trials < 1 or chunk_trials < 1:
            fail(f"--trials == {trials} and --chunk-trials == {chunk_trials}, must both be >= 1")
        if trials < MIN_INTERVAL_TRIALS:
            warnings.warn(InputWarning(f"{{trials}} == {trials} is below {MIN_INTERVAL_TRIALS}: no 95 % intervals "
                                       f"(a bootstrap over so few trials is too narrow)", fields=("trials",)))
        for v in value_list:
            scenario_at(scenario, param, v)
        start = time.perf_counter()
        quiet_dask()
        with trial_progress(f"swarm sweep {param}") as advance:
            table = run_sweep(scenario, param, value_list, names, trials=trials, seed=seed,
                              chunk_trials=chunk_trials, urt_mode=urt_mode,
                              scheduler=None if scheduler == "local" else scheduler, progress=advance,
                              model_files={k: str(v) for k, v in files.items()})
        summary = summarize(table)
        written = write_sweep(table, summary, out)
        written.append(plot_sweep(summary, param, SWEEP_PARAMS[param], Path(out) / "sweep.png",
                                  title=f"{trials} links x {scenario.exchanges} exchanges, URT {urt_mode}"))
        elapsed = time.perf_counter() - start
    doc = {"param": param, "unit": SWEEP_PARAMS[param], "elapsed_s": elapsed, "files": [str(f) for f in written],
           "summary": summary.to_dict(orient="records"), "warnings": notes}
    if json_out:
        print_json(doc)
        return
    con = human_console(False)
    table_out = Table("value", "algorithm", "RMSE (ns)", "95 % interval", "bound (ns)", "RMSE / bound",
                      title=f"sweep over {param}")
    for row in doc["summary"]:
        table_out.add_row(f"{row['value']:g}", row["algorithm"], _num(row["rmse_ns"], ".4g"),
                          _span(row["rmse_lo_ns"], row["rmse_hi_ns"]), f"{row['bound_rms_ns']:.4g}",
                          f"{_num(row['ratio'], '.3g')} ({_span(row['ratio_lo'], row['ratio_hi'])})")
    for note in notes:
        con.print(f"warning: {note}", markup=False, emoji=False)
    con.print(table_out)
    con.print(f"{len(written)} files -> {out}/ in {elapsed:.1f} s")


@swarm_app.command("train")
def train(
    out: Path = typer.Option(Path("swarm-models"), "--out", help="Folder for bp.pt, lstm.pt and training.json."),
    quick: bool = typer.Option(False, "--quick", help="A small data set (6000 samples) and few epochs."),
    seed: int = typer.Option(0, "--seed", help="Root seed of the data set and the training."),
    device: str = typer.Option("cpu", "--device", help="cpu, cuda, or auto (the GPU when present)."),
    urt_mode: str = typer.Option("calibrated", "--urt-mode", help="The chain the networks serve: paper or calibrated."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Train the BP 9-32-1 residual network and the LSTM baseline on links drawn from the prior (1e5
    samples, v ~ U[0, 2000] m/s, SNR ~ U[4, 20] dB, split 6:2:2 by held-out SNR group) and measure what
    each is worth on held-out links, with intervals."""
    quiet_output(quiet)
    from chronofuse.experiments.swarm_training import train_networks

    with user_errors():
        from chronofuse.extras import require

        require("torch", "swarm train")  # before the data set is built, not after
        if device not in ("cpu", "cuda", "auto"):
            fail(f"--device == {device!r}, must be cpu, cuda or auto")
        _urt_mode(urt_mode)
        with progress_reporter("swarm train") as say:
            summary = train_networks(out, quick=quick, seed=seed, device=device, urt_mode=urt_mode, progress=say,
                                     command=training_command(seed, quick, urt_mode))
        from chronofuse.report.jsonio import dumps

        (Path(out) / "training.json").write_text(dumps(summary))  # strict JSON: a missing interval is null
    if json_out:
        print_json(summary)
        return
    con = human_console(False)
    table = Table("network", "parameters", "train (s)", "device", "test residual left (ns)",
                  "held-out RMSE with / without", "at 1 us offset")
    for kind, r in summary["networks"].items():
        a, b = r["ablation"], r["ablation_offset_1us"]
        table.add_row(kind, str(r["parameters"]), f"{r['train_seconds']:.1f}", r["device"],
                      f"{r['test_left_rms_ns']:.3g} of {r['test_target_rms_ns']:.3g}",
                      f"{a['ratio']:.3g} ({_span(*a['ratio_ci'])})", f"{b['ratio']:.3g} ({_span(*b['ratio_ci'])})")
    con.print(table)
    con.print(f"models -> {out}/")


@swarm_app.command("network")
def network(
    nodes: int = typer.Option(8, "--nodes", help="Aircraft in the swarm (node 0 has the best oscillator)."),
    topology: str = typer.Option("tree", "--topology", help="tree (paths from the leader) or consensus."),
    duration: float = typer.Option(600.0, "--duration", help="Run length (s)."),
    interval: float = typer.Option(1.0, "--interval", help="Exchange interval (s)."),
    area: float = typer.Option(60e3, "--area", help="Side of the square the nodes start in (m)."),
    radio_range: float = typer.Option(150e3, "--radio-range", help="Largest range of a link (m)."),
    neighbours: int = typer.Option(6, "--neighbours", help="Links to the nearest nodes, at most this many each."),
    leader_loss_at: float = typer.Option(-1.0, "--leader-loss-at", help="When the leader leaves (s; < 0: never)."),
    cut_off: str = typer.Option(None, "--cut-off", help="NODE:FROM:TO: all of a node's links down (s)."),
    mean_up: float = typer.Option(float("inf"), "--mean-up", help="Mean time a link stays up (s; inf: always up)."),
    mean_down: float = typer.Option(30.0, "--mean-down", help="Mean time a link stays down (s)."),
    snr: float = typer.Option(10.0, "--snr", help="SNR of every link (dB)."),
    oscillator: str = typer.Option("ocxo", "--oscillator", help="Oscillator preset of the followers."),
    leader_oscillator: str = typer.Option("rb", "--leader-oscillator", help="Oscillator preset of node 0."),
    scheduler: str = typer.Option("serial", "--scheduler",
                                  help="'serial', 'local' (a Dask LocalCluster) or tcp://HOST:PORT for the links."),
    seed: int = typer.Option(0, "--seed", help="Root seed."),
    out: Path | None = typer.Option(None, "--out", help="Report folder: summary.json, the JSON document (created)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """A swarm over two-way links: the leader elected on clock quality, each node's time, state and
    uncertainty, and its time error to the leader (RMS, percentiles, MTIE/TDEV against PRTC-B)."""
    quiet_output(quiet)
    from chronofuse.experiments.swarm_documents import network_document
    from chronofuse.experiments.swarm_network import SwarmScenario

    with user_errors():
        cuts = ()
        if cut_off is not None:
            try:
                node, t0, t1 = cut_off.split(":")
                cuts = ((int(node), float(t0), float(t1)),)
            except ValueError:
                fail(f"--cut-off == {cut_off!r}, must be NODE:FROM:TO")
        sc = SwarmScenario(nodes=nodes, duration_s=duration, interval_s=interval, area_m=area,
                           radio_range_m=radio_range, neighbours=neighbours,
                           leader_loss_at_s=None if leader_loss_at < 0 else leader_loss_at, cut_off=cuts,
                           mean_up_s=mean_up, mean_down_s=mean_down, snr_db=snr, oscillator=oscillator,
                           leader_oscillator=leader_oscillator, topology=topology)
        quiet_dask()
        with progress_reporter("swarm network"):
            doc = network_document(sc, seed=seed, scheduler=None if scheduler == "local" else scheduler)
    if out is not None:
        doc["files"] = _write_summary(out, doc)
    if json_out:
        print_json(doc)
        return
    con = human_console(False)
    table = Table("node", "state at the end", "parent", "sigma (ns)", "to leader RMS (ns)", "p95 (ns)", "max (ns)",
                  "PRTC-B MTIE/TDEV", title=f"{topology}: {doc['nodes']} nodes, {doc['links']} links, "
                                             f"{doc['steps']} exchanges every {interval:g} s")
    for row in doc["per_node"]:
        te = row.get("to_leader", {})
        mask = row.get("mask") or {}
        verdict = "-" if not mask else ("pass" if mask["mtie_passed"] and mask["tdev_passed"] else "fail")
        table.add_row(str(row["node"]), row["state_end"], str(row["parent_end"]),
                      "-" if row["sigma_end_ns"] is None else f"{row['sigma_end_ns']:.3g}",
                      f"{te.get('rms_ns', float('nan')):.3g}", f"{te.get('p95_abs_ns', float('nan')):.3g}",
                      f"{te.get('max_abs_ns', float('nan')):.3g}", verdict)
    con.print(table)
    for change in doc["leader_changes"]:
        who = "none" if change["leader"] < 0 else f"node {change['leader']}"
        con.print(f"exchange {change['exchange']}: leader {who}")


def reproduce_swarm_command(
    figure: str = typer.Option("all", "--figure", help="6, 7, 8, 9, 10 or all."),
    quick: bool = typer.Option(False, "--quick", help="10 trials x 1000 exchanges per point."),
    out: Path = typer.Option(Path("out/reproduce/swarm"), "--out",
                             help="Report folder (created; docs/sync holds the published run)."),
    model: Path = typer.Option(None, "--model", help="BP model file (rtt-rvc-kf-bp curves)."),
    lstm_model: Path = typer.Option(None, "--lstm-model", help="LSTM model file (figure 10)."),
    scheduler: str = typer.Option("serial", "--scheduler",
                                  help="'serial', 'local' (a LocalCluster) or tcp://HOST:PORT."),
    seed: int = typer.Option(0, "--seed", help="Root seed."),
    replot: bool = typer.Option(False, "--replot", help="Redraw figures and report from --out's swarm.json only."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """The swarm paper's figures 6-10 with the Bayesian bound, intervals and the paper's numbers beside ours,
    the URT-change and network checks, written to --out."""
    quiet_output(quiet)
    from chronofuse.experiments.swarm_reproduce import FIGURES, replot_swarm, reproduce_swarm

    if replot:
        with user_errors():
            if not (Path(out) / "swarm.json").is_file():
                fail(f"--replot: {out}/swarm.json does not exist (a full run writes it)")
            doc = replot_swarm(out)
        if json_out:
            print_json({"out": str(out), **doc})
        else:
            human_console(False).print(f"report -> {out}/README.md ({len(doc['figures'])} figure(s), redrawn)")
        return
    with user_errors():
        figures = tuple(FIGURES) if figure == "all" else (figure,)
        if any(f not in FIGURES for f in figures):
            fail(f"--figure == {figure!r}, must be one of {list(FIGURES)} or all")
        files = model_files(model, lstm_model)
        load_models(files, "calibrated")
        quiet_dask()
        with progress_reporter("reproduce swarm") as say:
            doc = reproduce_swarm(out, figures=figures, quick=quick, seed=seed,
                                  model_files={k: str(v) for k, v in files.items()},
                                  scheduler=None if scheduler == "local" else scheduler, progress=say)
    if json_out:
        print_json({"out": str(out), **doc})
        return
    human_console(False).print(f"report -> {out}/README.md ({len(doc['figures'])} figure(s))")


def training_command(seed=0, quick: bool = False, urt_mode: str = "calibrated") -> str:
    """The command line that trains networks of these settings, kept in each model file; ``--out`` and
    ``--device`` change where they go and how fast, not what they are."""
    return " ".join(["chronofuse swarm train", *(["--quick"] if quick else []), f"--seed {seed}",
                     *([] if urt_mode == "calibrated" else [f"--urt-mode {urt_mode}"])])

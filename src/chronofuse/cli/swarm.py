"""``chronofuse swarm ...``: two-way clock synchronization over radio links (the swarm paper)."""

from __future__ import annotations

import time
from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import fail, human_console, print_json, progress_reporter, quiet_output, user_errors
from chronofuse.cli.swarm_options import (
    algorithm_names,
    build_scenario,
    load_models,
    model_files,
    quiet_dask,
    scenario_options,
    trial_progress,
)

swarm_app = typer.Typer(help="Swarm clock synchronization over two-way radio links (the swarm paper).", no_args_is_help=True)


def register(app: typer.Typer) -> None:
    app.add_typer(swarm_app, name="swarm")


_S = scenario_options()


def _write_summary(out: Path, doc: dict) -> list[str]:
    """``out``/summary.json holding ``doc`` (the --json document); returns the file written."""
    from chronofuse.report.jsonio import dumps

    with user_errors():
        out.mkdir(parents=True, exist_ok=True)
        (out / "summary.json").write_text(dumps(doc) + "\n")
    return [str(out / "summary.json")]


@swarm_app.command("run")
def run(
    algorithm: str = typer.Option("all", "--algorithm",
                                  help="Comma-separated algorithm names, or 'all' (see chronofuse.sync.registry)."),
    urt_mode: str = typer.Option("calibrated", "--urt-mode", help="paper (the source paper as written) or calibrated."),
    velocity: float = _S["velocity"], distance: float = _S["distance"], acceleration: float = _S["acceleration"],
    reply_delay: float = _S["reply_delay"], urt: float = _S["urt"], urt_jitter: float = _S["urt_jitter"],
    snr: float = _S["snr"], toa_model: str = _S["toa_model"], exchanges: int = _S["exchanges"],
    true_offset: float = _S["true_offset"], true_skew: float = _S["true_skew"], oscillator: str = _S["oscillator"],
    interval: float = _S["interval"],
    trials: int = typer.Option(20, "--trials", help="Monte Carlo trials."),
    seed: int = typer.Option(0, "--seed", help="Root seed (trial i uses its own child stream)."),
    threshold: float = typer.Option(1e-9, "--threshold", help="Convergence threshold tau of K* (s)."),
    model: Path = typer.Option(None, "--model", help="BP model file for 'proposed' (chronofuse swarm train)."),
    lstm_model: Path = typer.Option(None, "--lstm-model", help="LSTM model file for 'lstm'."),
    outage: str = typer.Option(None, "--outage", help="K0:K1: also lose exchanges K0..K1-1 (robustness)."),
    out: Path | None = typer.Option(None, "--out", help="Report folder: summary.json, the JSON document (created)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Simulate a two-node link and run the algorithms: RMSE, K*, overhead and the PCRB beside them."""
    quiet_output(quiet)
    from chronofuse.experiments.swarm import run_link
    from chronofuse.experiments.swarm_documents import link_report

    with user_errors():
        scenario = build_scenario(velocity=velocity, distance=distance, acceleration=acceleration,
                                  reply_delay=reply_delay, urt=urt, urt_jitter=urt_jitter, snr=snr,
                                  toa_model=toa_model, exchanges=exchanges, true_offset=true_offset,
                                  true_skew=true_skew, oscillator=oscillator, interval=interval)
        if urt_mode not in ("paper", "calibrated"):
            fail(f"--urt-mode == {urt_mode!r}, must be 'paper' or 'calibrated'")
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
        with progress_reporter("swarm run"):
            res = run_link(scenario, names, trials=trials, seed=seed, urt_mode=urt_mode, threshold_s=threshold,
                           networks=networks, outage=window)
    doc = link_report(res)
    if out is not None:
        doc["files"] = _write_summary(out, doc)
    if json_out:
        print_json(doc)
        return
    con = human_console(False)
    table = Table("algorithm", "RMSE (ns)", "RMSE / PCRB", "K*", title=f"{trials} trials, URT mode {urt_mode}")
    for name, value in doc["rmse_ns"].items():
        k = doc["convergence_epochs"][name]
        table.add_row(name, f"{value:.4g}", f"{value / doc['pcrb_ns']['rms']:.3g}", "-" if k is None else str(k))
    con.print(table)
    con.print(f"PCRB (same link model): {doc['pcrb_ns']['rms']:.4g} ns RMS over the run, "
              f"{doc['pcrb_ns']['final']:.4g} ns at the last exchange")


@swarm_app.command("sweep")
def sweep(
    param: str = typer.Option(..., "--param", help="velocity | distance | reply-delay | urt | snr."),
    values: str = typer.Option(..., "--values", help="Comma-separated values, SI units (m/s, m, s, s, dB)."),
    algorithm: str = typer.Option("ptp-mls,rtt-rvc,proposed-no-nn,ours-doppler", "--algorithm",
                                  help="Comma-separated algorithm names."),
    urt_mode: str = typer.Option("calibrated", "--urt-mode", help="paper or calibrated."),
    velocity: float = _S["velocity"], distance: float = _S["distance"], acceleration: float = _S["acceleration"],
    reply_delay: float = _S["reply_delay"], urt: float = _S["urt"], urt_jitter: float = _S["urt_jitter"],
    snr: float = _S["snr"], toa_model: str = _S["toa_model"], exchanges: int = _S["exchanges"],
    true_offset: float = _S["true_offset"], true_skew: float = _S["true_skew"], oscillator: str = _S["oscillator"],
    interval: float = _S["interval"],
    trials: int = typer.Option(100, "--trials", help="Monte Carlo trials per value."),
    chunk_trials: int = typer.Option(25, "--chunk-trials", help="Trials per task (fixes the random streams)."),
    seed: int = typer.Option(0, "--seed", help="Root seed."),
    scheduler: str = typer.Option("local", "--scheduler",
                                  help="Where the trials run: 'local' (a Dask LocalCluster of processes), 'serial' "
                                       "(this process) or tcp://HOST:PORT of a Dask scheduler."),
    out: Path = typer.Option(Path("swarm-sweep"), "--out", help="Folder for the table, summary and figure."),
    model: Path = typer.Option(None, "--model", help="BP model file for 'proposed'."),
    lstm_model: Path = typer.Option(None, "--lstm-model", help="LSTM model file for 'lstm'."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Sweep one parameter over values: a tidy table (CSV and Parquet), a summary and a figure."""
    quiet_output(quiet)
    from chronofuse.experiments.sweep import SWEEP_PARAMS, run_sweep, summarize
    from chronofuse.report.swarm import plot_sweep, write_sweep

    with user_errors():
        if param not in SWEEP_PARAMS:
            fail(f"--param == {param!r}, must be one of {list(SWEEP_PARAMS)}")
        try:
            value_list = [float(v) for v in values.split(",") if v.strip()]
        except ValueError:
            fail(f"--values == {values!r}, must be comma-separated numbers")
        if not value_list:
            fail("--values is empty, must give at least one number")
        if urt_mode not in ("paper", "calibrated"):
            fail(f"--urt-mode == {urt_mode!r}, must be 'paper' or 'calibrated'")
        files = model_files(model, lstm_model)
        names = algorithm_names(algorithm, files)
        load_models(files, urt_mode)
        if trials < 1 or chunk_trials < 1:
            fail(f"--trials == {trials} and --chunk-trials == {chunk_trials}, must both be >= 1")
        scenario = build_scenario(velocity=velocity, distance=distance, acceleration=acceleration,
                                  reply_delay=reply_delay, urt=urt, urt_jitter=urt_jitter, snr=snr,
                                  toa_model=toa_model, exchanges=exchanges, true_offset=true_offset,
                                  true_skew=true_skew, oscillator=oscillator, interval=interval)
        from chronofuse.experiments.sweep import scenario_at

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
        files = write_sweep(table, summary, out)
        files.append(plot_sweep(summary, param, SWEEP_PARAMS[param], Path(out) / "sweep.png",
                                title=f"{trials} trials x {exchanges} exchanges, URT {urt_mode}"))
        elapsed = time.perf_counter() - start
    doc = {"param": param, "unit": SWEEP_PARAMS[param], "elapsed_s": elapsed, "files": [str(f) for f in files],
           "summary": summary.to_dict(orient="records")}
    if json_out:
        print_json(doc)
        return
    con = human_console(False)
    table_out = Table("value", "algorithm", "RMSE (ns)", "PCRB (ns)", title=f"sweep over {param}")
    for row in doc["summary"]:
        table_out.add_row(f"{row['value']:g}", row["algorithm"], f"{row['rmse_ns']:.4g}", f"{row['pcrb_rms_ns']:.4g}")
    con.print(table_out)
    con.print(f"{len(files)} files -> {out}/ in {elapsed:.1f} s")


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
    """Train the BP 9-32-1 residual network and the LSTM baseline (seed data set: 1e5 samples,
    v ~ U[0, 2000] m/s, SNR ~ U[4, 20] dB, split 6:2:2 by held-out SNR group) and measure the ablation."""
    quiet_output(quiet)
    import json

    from chronofuse.experiments.swarm import train_networks

    with user_errors():
        if device not in ("cpu", "cuda", "auto"):
            fail(f"--device == {device!r}, must be cpu, cuda or auto")
        if urt_mode not in ("paper", "calibrated"):
            fail(f"--urt-mode == {urt_mode!r}, must be 'paper' or 'calibrated'")
        with progress_reporter("swarm train") as say:
            summary = train_networks(out, quick=quick, seed=seed, device=device, urt_mode=urt_mode, progress=say)
        (Path(out) / "training.json").write_text(json.dumps(summary, indent=2))
    if json_out:
        print_json(summary)
        return
    con = human_console(False)
    table = Table("network", "parameters", "train (s)", "device", "test residual left (ns)", "ablation with / without (ns)")
    for kind, r in summary["networks"].items():
        table.add_row(kind, str(r["parameters"]), f"{r['train_seconds']:.1f}", r["device"],
                      f"{r['test_left_rms_ns']:.3g} of {r['test_target_rms_ns']:.3g}",
                      f"{r['ablation']['rmse_with_s'] * 1e9:.3g} / {r['ablation']['rmse_without_s'] * 1e9:.3g}")
    con.print(table)
    con.print(f"models -> {out}/")


@swarm_app.command("network")
def network(
    followers: int = typer.Option(3, "--followers", help="Followers of the leader."),
    topology: str = typer.Option("tree", "--topology", help="tree (star: all follow the leader), chain, or consensus."),
    duration: float = typer.Option(7200.0, "--duration", help="Run length (s)."),
    interval: float = typer.Option(1.0, "--interval", help="Exchange interval (s)."),
    gnss_loss_at: float = typer.Option(1800.0, "--gnss-loss-at", help="When the leader loses GNSS (s; < 0: never)."),
    gnss_loss_for: float = typer.Option(3600.0, "--gnss-loss-for", help="How long the leader stays in holdover (s)."),
    mean_up: float = typer.Option(float("inf"), "--mean-up", help="Mean time a link stays up (s; inf: always up)."),
    mean_down: float = typer.Option(30.0, "--mean-down", help="Mean time a link stays down (s)."),
    snr: float = _S["snr"], oscillator: str = _S["oscillator"],
    seed: int = typer.Option(0, "--seed", help="Root seed."),
    out: Path | None = typer.Option(None, "--out", help="Report folder: summary.json, the JSON document (created)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """A leader and followers: each follower's time error to the leader and to true time (RMS, ns),
    through the leader's GNSS loss and links that come and go."""
    quiet_output(quiet)
    from chronofuse.experiments.swarm_documents import network_document

    with user_errors():
        if followers < 1:
            fail(f"--followers == {followers}, must be >= 1")
        if topology not in ("tree", "chain", "consensus"):
            fail(f"--topology == {topology!r}, must be tree, chain or consensus")
        if duration <= 2 * interval or interval <= 0:
            fail(f"--duration == {duration} and --interval == {interval}: need interval > 0 and at least 3 exchanges")
        with progress_reporter("swarm network"):
            doc = network_document(followers=followers, topology=topology, duration_s=duration, interval_s=interval,
                                   gnss_loss_at_s=gnss_loss_at, gnss_loss_for_s=gnss_loss_for, mean_up_s=mean_up,
                                   mean_down_s=mean_down, snr_db=snr, oscillator=oscillator, seed=seed)
    steps = doc["steps"]
    if out is not None:
        doc["files"] = _write_summary(out, doc)
    if json_out:
        print_json(doc)
        return
    con = human_console(False)
    table = Table("follower", "parent", "to leader RMS (ns)", "to leader max (ns)", "to true RMS (ns)", "link up",
                  title=f"{topology}: {steps} exchanges every {interval:g} s")
    for i in range(followers):
        table.add_row(str(i + 1), str(doc["parents"][i]), f"{doc['to_leader_rms_ns'][i]:.3g}",
                      f"{doc['to_leader_max_ns'][i]:.3g}", f"{doc['to_true_rms_ns'][i]:.3g}",
                      f"{doc['link_up_fraction'][i]:.0%}")
    con.print(table)
    con.print(f"leader to true time: {doc['leader_to_true_rms_ns'][0]:.3g} ns RMS, "
              f"{doc['leader_to_true_max_ns']:.3g} ns max")


def reproduce_swarm_command(
    figure: str = typer.Option("all", "--figure", help="6, 7, 8, 9, 10 or all."),
    quick: bool = typer.Option(False, "--quick", help="8 trials x 1000 exchanges per point."),
    out: Path = typer.Option(Path("out/reproduce/swarm"), "--out",
                             help="Report folder (created; docs/sync holds the published run)."),
    model: Path = typer.Option(None, "--model", help="BP model file ('proposed' curves)."),
    lstm_model: Path = typer.Option(None, "--lstm-model", help="LSTM model file (figure 10)."),
    scheduler: str = typer.Option("serial", "--scheduler",
                                  help="'serial', 'local' (a LocalCluster) or tcp://HOST:PORT."),
    seed: int = typer.Option(0, "--seed", help="Root seed."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """The swarm paper: figures 6-10 with the PCRB line and the source paper's numbers beside ours, written to --out."""
    quiet_output(quiet)
    from chronofuse.experiments.swarm_reproduce import FIGURES, reproduce_swarm

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

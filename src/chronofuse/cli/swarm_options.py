"""The options the ``chronofuse swarm`` commands share, and their checks: the link scenario the options
describe, the algorithms and network model files asked for, and the progress bar over trials (the swarm paper). Light to import: the library
modules are imported inside the functions, so ``chronofuse swarm --help`` stays fast.
"""

from __future__ import annotations

from contextlib import contextmanager

import typer

from chronofuse.cli.common import fail

__all__ = ["algorithm_names", "build_scenario", "load_models", "model_files", "quiet_dask",
           "scenario_options", "trial_progress"]

def quiet_dask() -> None:
    """Dask's shutdown chatter (worker-kill warnings) would break the one-line/stdout contract."""
    import logging

    for name in ("distributed", "distributed.nanny", "distributed.worker", "distributed.scheduler"):
        logging.getLogger(name).setLevel(logging.ERROR)


def build_scenario(*, velocity, distance, acceleration, reply_delay, urt, urt_jitter, snr, toa_model, exchanges,
                   true_offset, true_skew, oscillator, interval):
    """The :class:`LinkScenario` the options describe (validated; its errors name the config fields, which
    the command line writes as these options, :mod:`chronofuse.cli.flags`)."""
    from chronofuse.experiments.swarm import LinkScenario
    from chronofuse.models.link import LinkModel

    link = LinkModel(interval_s=interval, reply_delay_s=reply_delay, urt_fixed_s=urt, urt_jitter_s=urt_jitter,
                     snr_db=snr, toa_model=toa_model)
    return LinkScenario(distance_m=distance, velocity_m_s=velocity, acceleration_m_s2=acceleration,
                        exchanges=exchanges, true_offset_s=true_offset, true_skew=true_skew,
                        oscillator=oscillator, link=link)


def scenario_options():
    return dict(
        velocity=typer.Option(800.0, "--velocity", help="Radial velocity (m/s; opening > 0)."),
        distance=typer.Option(80e3, "--distance", help="Initial distance (m)."),
        acceleration=typer.Option(0.0, "--acceleration", help="Radial acceleration (m/s^2)."),
        reply_delay=typer.Option(4e-3, "--reply-delay", help="Reply slot T_B (s)."),
        urt=typer.Option(20e-9, "--urt", help="Fixed unequal reply time (s)."),
        urt_jitter=typer.Option(2e-9, "--urt-jitter", help="URT jitter sigma (s)."),
        snr=typer.Option(10.0, "--snr", help="Link SNR (dB; 4..20 with the source paper's TOA table)."),
        toa_model=typer.Option("table", "--toa-model", help="TOA noise: table (seed) or crb (Cramér-Rao form)."),
        exchanges=typer.Option(2000, "--exchanges", help="Exchanges per run."),
        true_offset=typer.Option(0.0, "--true-offset", help="True clock offset B - A at the start (s)."),
        true_skew=typer.Option(0.0, "--true-skew", help="True fractional frequency offset B - A."),
        oscillator=typer.Option("ocxo", "--oscillator", help="Oscillator preset of both nodes."),
        interval=typer.Option(0.01, "--interval", help="Exchange interval (s)."),
    )


def model_files(model, lstm_model) -> dict:
    return {kind: path for kind, path in (("bp", model), ("lstm", lstm_model)) if path is not None}


def algorithm_names(text: str, files: dict) -> tuple:
    """The algorithms asked for; 'all' takes those whose models were given."""
    from chronofuse.sync.registry import ALGORITHM_NAMES, NEEDS_NETWORK

    if text == "all":
        return tuple(n for n in ALGORITHM_NAMES if NEEDS_NETWORK.get(n, "bp") in files or n not in NEEDS_NETWORK)
    names = tuple(a.strip() for a in text.split(","))
    for name in names:
        if name not in ALGORITHM_NAMES:
            fail(f"--algorithm == {name!r}, must be among {list(ALGORITHM_NAMES)}")
        kind = NEEDS_NETWORK.get(name)
        if kind is not None and kind not in files:
            flag = "--model" if kind == "bp" else "--lstm-model"
            fail(f"--algorithm == {name!r} needs a trained {kind} network: give {flag} FILE (chronofuse swarm train)")
    return names


def load_models(files: dict, urt_mode: str) -> dict:
    """Load the model files; a file that does not match its configuration is one line naming the option."""
    from chronofuse.sync.network import load_residual_network
    from chronofuse.validation import ChronofuseError

    chain = {"filter": "seed", "light_time": "seed", "urt_mode": urt_mode}
    out = {}
    for kind, path in files.items():
        flag = "--model" if kind == "bp" else "--lstm-model"
        try:
            out[kind] = load_residual_network(path, chain=chain)
        except (ChronofuseError, FileNotFoundError, IsADirectoryError) as exc:
            fail(f"{flag} {exc}")
        if out[kind].config.kind != kind:
            fail(f"{flag} {path}: holds a {out[kind].config.kind} network, expected {kind}")
    return out


@contextmanager
def trial_progress(label: str):
    """A progress bar over trials on stderr (off when stderr is not a terminal); yields ``advance(done, total)``."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from chronofuse.cli.common import err_console

    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=err_console, transient=True, disable=not err_console.is_terminal) as bar:
        task = bar.add_task(label, total=None)

        def advance(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield advance

"""The options the ``chronofuse swarm`` commands share, and their checks: the link scenario the options
describe (geometry, link, prior, calibration), the algorithms and network model files asked for, and the
progress bar over trials. Errors name the library's config fields, which the command line writes as these
options (:mod:`chronofuse.cli.flags`). Light to import:
the library modules are imported inside the functions, so ``chronofuse swarm --help`` stays fast.
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
                   oscillator, interval, offset_mean=0.0, offset_sigma=1e-6, skew_mean=0.0, skew_sigma=1e-8,
                   urt_sigma=5e-9, range_spread=0.0, calibration_duration=600.0, reference_sigma=5e-9,
                   common_velocity=0.0, cross_velocity=0.0, latitude=None, bearing=90.0, manoeuvre="none",
                   load_factor=5.0, reply_jitter=0.0, nlos=0.0, loss=0.0, loss_burst=1.0, clock_truth="power-law"):
    """The :class:`LinkScenario` the options describe (validated; errors name the config fields, the
    calibration's as ``calibration_<field>``)."""
    from pydantic import ValidationError

    from chronofuse.experiments.swarm import LinkScenario
    from chronofuse.models.link import LinkModel
    from chronofuse.sync.calibration import CalibrationConfig
    from chronofuse.sync.prior import LinkPrior

    from chronofuse.validation import InputError

    link = LinkModel(interval_s=interval, reply_delay_s=reply_delay, urt_fixed_s=urt, urt_jitter_s=urt_jitter,
                     snr_db=snr, toa_model=toa_model, reply_jitter_s=reply_jitter, nlos_probability=nlos,
                     loss_fraction=loss, loss_burst_mean=loss_burst)
    prior = LinkPrior(offset_mean_s=offset_mean, offset_sigma_s=offset_sigma, skew_mean=skew_mean,
                      skew_sigma=skew_sigma, urt_sigma_s=urt_sigma, range_spread_m=range_spread)
    try:
        calibration = CalibrationConfig(duration_s=calibration_duration, reference_sigma_s=reference_sigma)
    except ValidationError as exc:  # its fields' names (duration_s) mean other things elsewhere
        from chronofuse.cli.common import pydantic_message

        err = exc.errors()[0]
        field = f"calibration_{err['loc'][0] if err['loc'] else 'duration_s'}"  # the window is the one model rule
        raise InputError(pydantic_message(err, f"{{{field}}}"), fields=(field,)) from None
    return LinkScenario(distance_m=distance, velocity_m_s=velocity, acceleration_m_s2=acceleration,
                        exchanges=exchanges, oscillator=oscillator, link=link, prior=prior, calibration=calibration,
                        common_velocity_m_s=common_velocity, cross_velocity_m_s=cross_velocity,
                        latitude_deg=latitude, bearing_deg=bearing, manoeuvre=manoeuvre, load_factor_g=load_factor,
                        clock_truth=clock_truth)


#: The scenario options' names, as :func:`build_scenario` takes them.
SCENARIO_KEYS = ("velocity", "distance", "acceleration", "reply_delay", "urt", "urt_jitter", "snr", "toa_model",
                 "exchanges", "oscillator", "interval", "offset_mean", "offset_sigma", "skew_mean", "skew_sigma",
                 "urt_sigma", "range_spread", "calibration_duration", "reference_sigma", "common_velocity",
                 "cross_velocity", "latitude", "bearing", "manoeuvre", "load_factor", "reply_jitter", "nlos", "loss",
                 "loss_burst", "clock_truth")


def scenario_options():
    return dict(
        velocity=typer.Option(800.0, "--velocity", help="Radial velocity of B from A (m/s, opening > 0)."),
        distance=typer.Option(80e3, "--distance", help="Initial range (m)."),
        acceleration=typer.Option(0.0, "--acceleration", help="Radial acceleration (m/s^2)."),
        reply_delay=typer.Option(4e-3, "--reply-delay", help="Reply slot T_B (s)."),
        urt=typer.Option(20e-9, "--urt", help="Mean fixed unequal reply time of a link (s)."),
        urt_jitter=typer.Option(2e-9, "--urt-jitter", help="URT jitter sigma (s)."),
        snr=typer.Option(10.0, "--snr", help="SNR (dB; 4..20 with the paper's table)."),
        toa_model=typer.Option("table", "--toa-model", help="TOA noise: table (the paper's) or crb (Cramér-Rao)."),
        exchanges=typer.Option(2000, "--exchanges", help="Exchanges per run."),
        oscillator=typer.Option("ocxo", "--oscillator", help="Oscillator preset of both nodes."),
        interval=typer.Option(0.01, "--interval", help="Exchange interval (s)."),
        offset_mean=typer.Option(0.0, "--offset-mean", help="Prior mean of the clock offset B - A at the start (s)."),
        offset_sigma=typer.Option(1e-6, "--offset-sigma", help="Prior sigma of that offset, drawn per trial (s)."),
        skew_mean=typer.Option(0.0, "--skew-mean", help="Prior mean of the fractional frequency offset B - A."),
        skew_sigma=typer.Option(1e-8, "--skew-sigma", help="Prior sigma of that frequency offset, drawn per trial."),
        urt_sigma=typer.Option(5e-9, "--urt-sigma", help="Spread of the fixed URT across links, drawn per trial (s)."),
        range_spread=typer.Option(0.0, "--range-spread", help="Half-width of the initial range drawn per trial (m)."),
        calibration_duration=typer.Option(600.0, "--calibration-duration",
                                          help="URT calibration window, one GNSS comparison a second (s)."),
        reference_sigma=typer.Option(5e-9, "--reference-sigma", help="Each node's GNSS time error in calibration (s)."),
        common_velocity=typer.Option(0.0, "--common-velocity", help="Both nodes' velocity along the line of sight (m/s)."),
        cross_velocity=typer.Option(0.0, "--cross-velocity", help="B's velocity across the line of sight (m/s)."),
        latitude=typer.Option(None, "--latitude", help="Put the nodes on the rotating Earth at this latitude (deg)."),
        bearing=typer.Option(90.0, "--bearing", help="Bearing of the line of sight from north (deg)."),
        manoeuvre=typer.Option("none", "--manoeuvre", help="B's manoeuvre: none, turn or climb."),
        load_factor=typer.Option(5.0, "--load-factor", help="The manoeuvre's load factor (g)."),
        reply_jitter=typer.Option(0.0, "--reply-jitter", help="Sigma of B's reply slot, reported in T_B (s)."),
        nlos=typer.Option(0.0, "--nlos", help="Probability that an arrival is a reflected (NLOS) path."),
        loss=typer.Option(0.0, "--loss", help="Fraction of exchanges lost (Gilbert-Elliott bursts)."),
        loss_burst=typer.Option(1.0, "--loss-burst", help="Mean length of a loss burst (exchanges)."),
        clock_truth=typer.Option("power-law", "--clock-truth",
                                 help="Clock truth: power-law (the preset) or markov (the filter's own model)."),
    )


def model_files(model, lstm_model) -> dict:
    return {kind: path for kind, path in (("bp", model), ("lstm", lstm_model)) if path is not None}


def algorithm_names(text: str, files: dict) -> tuple:
    """The algorithms asked for; 'all' takes those whose models were given."""
    from chronofuse.sync.registry import ALGORITHM_NAMES, NEEDS_NETWORK, check_name

    if text == "all":
        return tuple(n for n in ALGORITHM_NAMES if NEEDS_NETWORK.get(n, "bp") in files or n not in NEEDS_NETWORK)
    names = tuple(a.strip() for a in text.split(","))
    for name in names:
        check_name(name)  # an unknown or renamed name: an input error naming the field (--algorithm)
        kind = NEEDS_NETWORK.get(name)
        if kind is not None and kind not in files:
            flag = "--model" if kind == "bp" else "--lstm-model"
            fail(f"--algorithm == {name!r} needs a trained {kind} network: give {flag} FILE (chronofuse swarm train)")
    return names


def load_models(files: dict, urt_mode: str) -> dict:
    """Load the model files; a file that does not match its configuration is one line naming the option."""
    from chronofuse.sync.residual import load_residual_network
    from chronofuse.validation import ChronofuseError

    chain = {"light_time": "paper", "urt_mode": urt_mode}
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
    """Progress over trials (:func:`chronofuse.cli.common.progress_reporter`); yields ``advance(done, total)``."""
    from chronofuse.cli.common import progress_reporter

    with progress_reporter(label) as say:

        def advance(done: int, total: int) -> None:
            say(f"trial {done} of {total}", done / total if total else None)

        yield advance

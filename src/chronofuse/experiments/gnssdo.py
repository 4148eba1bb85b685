"""``chronofuse gnssdo``: one GNSSDO run on a simulated scenario (or a real reference record), evaluated.

Orchestration only: the truth models simulate, :mod:`chronofuse.discipline` disciplines, the stability
engine measures. Everything is drawn from one ``SeedSequence`` (child 0: the oscillator, child 1: the
receivers, child 2: each trial's initial phase and frequency offsets), so a trial's numbers do not depend
on the trial count.

Metrics (all over the trials; SI inside, ns only in the summary's ``*_ns`` keys):

* time error (TE) of the disciplined 1PPS against true time, over the seconds from ``SETTLE_S`` (30 min,
  the source paper's convergence bound) on that have a usable reference (holdover is reported apart):
  ``time_error_rms_ns`` (rms over trials and seconds), ``time_error_pp_ns`` (mean over trials of the
  peak-to-peak);
* ``convergence_s``: the first second after which ``|TE| < CONVERGENCE_THRESHOLD_S`` (100 ns) holds at
  every later second with a usable reference (median over trials; null if never);
* ``time_error_rms_ci_ns``: its 95 % Monte Carlo interval over trials (:mod:`chronofuse.analysis.montecarlo`;
  null with one trial);
* ``clairvoyant_rms_ns`` (and ``_ci_ns``): the TE rms of the clairvoyant Kalman servo
  (:func:`chronofuse.discipline.bound.clairvoyant_servo`: the true oscillator model, flicker FM included,
  the true receiver noise model, unconstrained steering) on the same data;
* ``optimal_rms_ns`` and ``optimal_kind``: in a Gaussian scenario (no outliers, steps or spoofing:
  :func:`is_gaussian`) the causal lower bound, the clairvoyant filter's own phase-error covariance over
  the same window (:func:`chronofuse.discipline.bound.time_error_bound`), ``optimal_kind == "bound"``;
  otherwise the clairvoyant servo's TE, ``optimal_kind == "clairvoyant"``, which is not a bound.
  ``ratio_to_optimal`` (and ``_ci``) is the controller's TE rms over the clairvoyant servo's on the same
  trials (paired: the receivers' slow wander, which makes whole trials better or worse, cancels); the
  clairvoyant servo attains the bound within its interval in open sky (tested), so in a Gaussian
  scenario this is the tight estimate of the ratio to the bound. ``ratio_to_bound_direct`` (and
  ``_ci``) is the TE rms over the bound itself, unpaired (its interval is as wide as the TE's);
* ``holdover_error_ns`` / ``holdover_s`` (outage scenario): rms over trials of the TE accumulated over
  the outage;
* ``state_seconds``: seconds per state (mean over trials); ``locked_over_threshold_seconds``: seconds LOCKED
  while the true |TE| is at or above the lock threshold (mean over trials; a LOCKED that lies);
  ``holdover_ready_seconds`` and ``predicted_holdover_sigma_ns`` (median over the LOCKED seconds of the
  predicted holdover error's standard deviation after the state machine's horizon, 1 h);
* ``adev``: overlapping ADEV (mean Allan variance over trials) of the free-running oscillator, of the
  GNSS reference (the fused, qErr-corrected 1PPS error) and of the disciplined output.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.progress import Progress, silent, within
from chronofuse.analysis.metrics import pooled_oadev
from chronofuse.analysis.stability.taus import averaging_factors
from chronofuse.analysis.montecarlo import mean_square_per_trial, ratio_ci, rms_ci
from chronofuse.discipline.bound import ClairvoyantServo, time_error_bound
from chronofuse.discipline.chain import ChainConfig, GnssdoRun, discipline_run
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.design import clairvoyant_controller, design_measurement_sigma_s, equivalent_white_sigma_s
from chronofuse.discipline.plausibility import DragMonitor, ReferenceNoise
from chronofuse.discipline.qualification import Qualification
from chronofuse.discipline.registry import SERVOS
from chronofuse.discipline.servo import Servo
from chronofuse.discipline.stages import LoopStage, StateStage
from chronofuse.discipline.states import HoldoverModel, State, StateConfig, StateRun
from chronofuse.estimation.pipeline import Pipeline
from chronofuse.io.pps_reference import read_pps_reference
from chronofuse.models.environment import ENVIRONMENTS, ReceiverEnvironment, receiver_environment
from chronofuse.models.oscillator import OscillatorModel, simulate_oscillator
from chronofuse.models.oscillator_presets import PRESETS, preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.seeding import child_rng, child_seed, root_seed
from chronofuse.validation import InputError, check_choice, check_scalar, invalid
from chronofuse.experiments.gnssdo_controllers import (  # noqa: F401 (part of this module's API)
    DESIGN_STEER_S,
    INITIAL_FREQUENCY_FRACTION,
    INITIAL_FREQUENCY_MAX,
    INITIAL_PHASE_MAX_S,
    _check_controller,
    _free_phase,
    initial_frequency_max,
    make_controller,
)

__all__ = ["SCENARIOS", "CONTROLLERS", "DEFAULT_CONTROLLER", "GnssdoSetup", "make_controller",
           "scenario_environment", "simulate_gnssdo", "evaluate", "run_gnssdo", "run_reference", "is_gaussian",
           "DESIGN_STEER_S"]

#: The scenarios this module builds from the open sky, then every other receiver environment of the registry
#: (:data:`chronofuse.models.environment.ENVIRONMENTS`) under its own name.
SCENARIOS = ("open-sky", "urban-canyon", "outage", "outliers", "spoofing",
             *(name for name in ENVIRONMENTS if name not in ("open-sky", "urban-canyon", "spoofing")))
#: The built-in controllers the reproductions compare: the PI servo and four Kalman servos (plain; weighted
#: adaptive, the GNSSDO paper's; with chi-square innovation gating; with a Huber robust update). Any name of
#: the servo registry, :data:`chronofuse.discipline.registry.SERVOS`, plugins included, can be chosen.
CONTROLLERS = ("pi", "kalman", "adaptive-kalman", "gated-kalman", "huber-kalman")
#: Picked by measurement: the lowest mean ratio to the clairvoyant time-error rms over open sky, urban
#: canyon and jump outliers in ``chronofuse reproduce gnssdo`` (docs/gnssdo/README.md shows the table).
DEFAULT_CONTROLLER = "gated-kalman"
SETTLE_S = 1800.0
CONVERGENCE_THRESHOLD_S = 100e-9


@dataclass(frozen=True)
class GnssdoSetup:
    """One ``chronofuse gnssdo`` configuration (the command line's options)."""

    scenario: str = "open-sky"
    controller: str = DEFAULT_CONTROLLER
    receivers: int = 3
    duration_s: int = 86_400
    trials: int = 1
    seed: int = 0
    oscillator: str = "ocxo"
    gdop_max: float = 5.0
    dac_bits: int | None = None
    #: The free-running oscillator, when it is not the preset ``oscillator`` itself (a scenario file's
    #: h-coefficient and drift overrides); its ``name`` is reported.
    oscillator_model: OscillatorModel | None = None
    loop_bandwidth_hz: float | None = None
    fusion: str = "fusion"
    integrity_pfa: float | None = None
    #: The oscillator's plausibility test of each receiver and of the fused reference (spoofing through the oscillator).
    plausibility: bool = True
    #: ``"fit"``: the Kalman controllers learn the noise from a calibration record
    #: (:mod:`chronofuse.experiments.gnssdo_design`); ``"datasheet"``: designed from the presets' figures.
    design: str = "fit"
    #: A GNSS outage added to any scenario: every receiver jammed from ``outage_start_s`` for ``outage_s``.
    outage_start_s: float | None = None
    outage_s: float = 0.0

    def __post_init__(self):
        check_choice(self.scenario, "scenario", SCENARIOS)
        _check_controller(self.controller)
        check_scalar(self.receivers, "receivers", min_val=1, integer=True)
        check_scalar(self.duration_s, "duration_s", min_val=2 * SETTLE_S, integer=True)
        check_scalar(self.trials, "trials", min_val=1, integer=True)
        check_scalar(self.seed, "seed", min_val=0, integer=True)
        check_scalar(self.gdop_max, "gdop_max", min_val=1.0)
        if self.oscillator_model is None:
            check_choice(self.oscillator, "oscillator", tuple(PRESETS))
        if self.dac_bits is not None:
            check_scalar(self.dac_bits, "dac_bits", min_val=1, max_val=32, integer=True)
        if self.loop_bandwidth_hz is not None:
            check_scalar(self.loop_bandwidth_hz, "loop_bandwidth_hz", min_val=0.0, max_val=0.5, include_min=False)
            if "natural_hz" not in SERVOS.entry(self.controller).config.model_fields:
                raise InputError(f"{{loop_bandwidth_hz}} == {self.loop_bandwidth_hz}: {{controller}} "
                                 f"{self.controller!r} has no loop-bandwidth setting (pi has)",
                                 fields=("loop_bandwidth_hz", "controller"))
        check_choice(self.fusion, "fusion", ("fusion", "selection"))
        check_choice(self.design, "design", ("fit", "datasheet"))
        if self.integrity_pfa is not None:
            check_scalar(self.integrity_pfa, "integrity_pfa", min_val=0.0, max_val=1.0, include_min=False,
                         include_max=False)
        if self.outage_start_s is not None:
            check_scalar(self.outage_start_s, "outage_start_s", min_val=0.0, max_val=self.duration_s)
            check_scalar(self.outage_s, "outage_s", min_val=0.0, max_val=self.duration_s - self.outage_start_s)


def scenario_environment(name: str, duration_s: float) -> ReceiverEnvironment:
    """The receiver environment of a gnssdo scenario (events placed relative to the run's length).

    ``outage``: open sky, every receiver jammed for the third quarter of the run (holdover);
    ``outliers``: open sky plus 2 % single-pulse outliers of rms 300 ns, the source paper's "GPS jump outliers"
    (跳变野值; persistent steps of the receivers' time are left out: they move the reference itself, and
    no controller can tell them from the truth); ``spoofing``: the preset drag-off (2 ns/s) from mid-run.
    """
    check_choice(name, "scenario", SCENARIOS)
    if name not in ("outage", "outliers", "spoofing"):
        return receiver_environment(name)
    sky = receiver_environment("open-sky")
    if name == "outage":
        return dataclasses.replace(sky, name="outage", description="open sky, all receivers jammed for the third quarter",
                                   jamming_start_s=0.5 * duration_s, jamming_duration_s=0.25 * duration_s)
    if name == "outliers":
        model = dataclasses.replace(sky.model, outlier_prob=0.02, outlier_sigma_s=300e-9)
        return dataclasses.replace(sky, name="outliers", model=model, description="open sky with 1PPS outliers")
    return dataclasses.replace(receiver_environment("spoofing"), spoof_start_s=0.5 * duration_s)


def state_config(osc: OscillatorModel) -> StateConfig:
    """The lock criteria of a GNSSDO on ``osc``: the defaults of :class:`~chronofuse.discipline.states.StateConfig`
    (|TE| 100 ns claimed, the filtered time error within half of it for 60 s), a frequency-correction
    excursion of ``max(1e-9, 10 sigma_y(1 s))`` (the loop's correction scatters by 1.7e-10 about its 600 s
    average with the OCXO or CSAC, 2e-11 with the Rb and 4e-9 with the TCXO in open sky and urban canyon),
    and the holdover prediction from the oscillator's own noise and aging."""
    adev_1s = math.sqrt(osc.h.h0 / 2.0 + 2.0 * math.log(2.0) * osc.h.hm1)
    return StateConfig(freq_threshold=max(1e-9, 10.0 * adev_1s), holdover=HoldoverModel.of(osc))


def reference_noise(env: ReceiverEnvironment) -> ReferenceNoise:
    """One receiver's 1PPS noise as the designer models it (its environment's receiver model): white noise
    inflated by the mean log-normal GDOP gain, with the outliers' variance folded in, plus multipath and
    wander as Gauss-Markov terms."""
    m = env.model
    white = m.white_sigma_s * math.exp(m.gdop_log_sigma**2)
    white = math.sqrt(white**2 + m.outlier_prob * m.outlier_sigma_s**2)
    return ReferenceNoise(white, ((m.multipath_sigma_s, m.multipath_tau_s), (m.wander_sigma_s, m.wander_tau_s)))


def plausibility_monitors(osc: OscillatorModel, env: ReceiverEnvironment, receivers: int) -> tuple[DragMonitor, None]:
    """The drag monitors of each receiver and of the fused reference: each receiver's, and none on the fused
    reference. A coherent drag refuses every receiver, which puts the GNSSDO in holdover by itself; a monitor
    of the fused series would add the receivers coming and going (its value jumps by their differences: in
    the default urban-canyon day such a monitor, given one receiver's noise, refused the fused reference for
    51,920 s and never re-admitted it) and no sensitivity (at the long horizons that set the slowest rate
    caught, the oscillator's noise dominates). The stage exists (``ChainConfig.reference_monitor``)."""
    return DragMonitor.for_oscillator(osc, reference_noise(env)), None


def is_gaussian(env: ReceiverEnvironment) -> bool:
    """Whether the scenario's reference errors are Gaussian (given which seconds have a sample), so that
    the clairvoyant filter's covariance is a causal lower bound: no outliers, no steps, no spoofing."""
    m = env.model
    spoofed = env.spoof_start_s is not None and env.spoof_rate_s_per_s != 0.0
    return m.outlier_prob == 0.0 and m.jump_prob == 0.0 and not spoofed


def simulate_gnssdo(setup: GnssdoSetup, progress: Progress = silent) -> dict:
    """Simulate the scenario and run the chosen controller and the clairvoyant one on the same data."""
    root = root_seed(setup.seed)
    osc = preset(setup.oscillator) if setup.oscillator_model is None else setup.oscillator_model
    if setup.dac_bits is not None:
        osc = dataclasses.replace(osc, dac_bits=setup.dac_bits)
    dac = Dac.for_oscillator(osc)
    env = scenario_environment(setup.scenario, setup.duration_s)
    if setup.outage_start_s is not None:
        env = dataclasses.replace(env, jamming_start_s=setup.outage_start_s, jamming_duration_s=setup.outage_s)
    progress("simulating the oscillator", 0.0)
    free, noise_only = _free_phase(osc, setup.duration_s, setup.trials, root)
    progress("simulating the receivers", 0.05)
    rx = simulate_receivers(env, setup.duration_s, setup.receivers, child_seed(root, 1), trials=setup.trials)
    monitors = plausibility_monitors(osc, env, setup.receivers) if setup.plausibility else (None, None)
    config = ChainConfig(qualification=Qualification(gdop_max=setup.gdop_max), fusion=setup.fusion,
                         integrity_pfa=setup.integrity_pfa, states=state_config(osc), receiver_monitor=monitors[0],
                         reference_monitor=monitors[1])
    if setup.design == "fit":
        from chronofuse.experiments.gnssdo_design import fitted_controller

        progress(f"fitting {setup.controller} on a calibration record", 0.1)
        servo, design = fitted_controller(setup.controller, osc, env, setup.receivers, dac, root, config=config,
                                          loop_bandwidth_hz=setup.loop_bandwidth_hz)
    else:
        servo = make_controller(setup.controller, osc, env, setup.receivers, dac, setup.loop_bandwidth_hz)
        design = "datasheet"
    progress(f"disciplining ({setup.controller})", 0.9)
    run = discipline_run(servo, free, rx.pps_error_s, rx.epochs, config)
    progress("disciplining (clairvoyant)", 0.95)
    yardstick = clairvoyant_controller(osc, env, setup.receivers, dac)
    best = discipline_run(yardstick, free, rx.pps_error_s, rx.epochs, config)
    return {"setup": setup, "oscillator": osc, "environment": env, "free_phase_s": free, "noise_phase_s": noise_only,
            "receivers": rx, "run": run, "clairvoyant": best, "clairvoyant_servo": yardstick, "design": design}


def adev_series(free_phase_s: np.ndarray, reference_error_s: np.ndarray, phase_s: np.ndarray,
                start: int = int(SETTLE_S)) -> dict:
    """``{"free_run": {"tau", "dev"}, "gnss": ..., "disciplined": ...}`` on one octave grid up to a quarter
    of the record from ``start`` (the seconds before it hold the acquisition's phase step)."""
    free_phase_s, reference_error_s, phase_s = free_phase_s[:, start:], reference_error_s[:, start:], phase_s[:, start:]
    taus = averaging_factors(phase_s.shape[1] // 4, "octave").astype(float)
    gnss = -reference_error_s  # the reference 1PPS's own time error
    if np.isnan(gnss).mean() > 0.5:
        gnss_dev = np.full(taus.shape, np.nan)
    else:
        gnss_dev = pooled_oadev(gnss, 1.0, taus).dev
    return {"free_run": {"tau": taus, "dev": pooled_oadev(free_phase_s, 1.0, taus).dev},
            "gnss": {"tau": taus, "dev": gnss_dev},
            "disciplined": {"tau": taus, "dev": pooled_oadev(phase_s, 1.0, taus).dev}}


def te_window(has_reference: np.ndarray) -> np.ndarray:
    """The seconds the time error is measured over: from ``SETTLE_S`` on, with a usable reference."""
    t = np.arange(has_reference.shape[-1], dtype=float)
    return has_reference & (t >= SETTLE_S)[None, :]


def _ci_ns(interval) -> list | None:
    lo, hi = interval[1], interval[2]
    return None if not (math.isfinite(lo) and math.isfinite(hi)) else [lo * 1e9, hi * 1e9]


def time_error_metrics(phase_s: np.ndarray, has_reference: np.ndarray) -> dict:
    """TE rms (with its 95 % Monte Carlo interval over trials) and peak-to-peak after ``SETTLE_S`` with a
    usable reference, and the convergence time (s)."""
    window = te_window(has_reference)
    x = np.where(window, phase_s, np.nan)
    rms = float(np.sqrt(np.nanmean(x**2))) if window.any() else math.nan
    pp = float(np.nanmean(np.nanmax(x, axis=1) - np.nanmin(x, axis=1))) if window.any() else math.nan
    bad = has_reference & (np.abs(phase_s) >= CONVERGENCE_THRESHOLD_S)
    conv = []
    for row, seen in zip(bad, has_reference):
        idx = np.flatnonzero(row)
        if not seen.any():  # never disciplined: it never converged
            conv.append(math.nan)
            continue
        conv.append(0.0 if idx.size == 0 else (math.nan if idx[-1] == row.size - 1 else float(idx[-1] + 1)))
    converged = [c for c in conv if math.isfinite(c)]
    ci = _ci_ns(rms_ci(mean_square_per_trial(phase_s, window)))
    return {"time_error_rms_ns": rms * 1e9, "time_error_rms_ci_ns": ci, "time_error_pp_ns": pp * 1e9,
            "convergence_s": float(np.median(converged)) if len(converged) == len(conv) else None}


def _holdover(run: GnssdoRun, env: ReceiverEnvironment) -> dict:
    if env.jamming_start_s is None or env.jamming_duration_s <= 0:
        return {}
    start = int(env.jamming_start_s)
    end = min(int(env.jamming_start_s + env.jamming_duration_s), run.phase_s.shape[1] - 1)
    err = run.phase_s[:, end] - run.phase_s[:, start]
    return {"holdover_error_ns": float(np.sqrt(np.mean(err**2))) * 1e9, "holdover_s": float(end - start)}


def run_config_threshold_s(sim: dict) -> float:
    """The |TE| a run's LOCKED claims (its state machine's lock threshold)."""
    return float(state_config(sim["oscillator"]).lock_threshold_s)


def optimal_metrics(phase_s: np.ndarray, clairvoyant_phase_s: np.ndarray, has_reference: np.ndarray,
                    env: ReceiverEnvironment, clairvoyant: ClairvoyantServo) -> dict:
    """``clairvoyant_rms_ns`` (+ CI), ``optimal_rms_ns``, ``optimal_kind`` and ``ratio_to_optimal`` (+ CI):
    the bound in a Gaussian scenario, the clairvoyant servo's TE otherwise (module docstring)."""
    window = te_window(has_reference)
    ms = mean_square_per_trial(phase_s, window)
    ms_best = mean_square_per_trial(clairvoyant_phase_s, window)
    best = rms_ci(ms_best)
    out = {"clairvoyant_rms_ns": best[0] * 1e9, "clairvoyant_rms_ci_ns": _ci_ns(best)}
    if is_gaussian(env):
        bound = time_error_bound(clairvoyant, has_reference)
        rms_bound = bound.rms_s(window)
        plain = rms_ci(ms)
        out.update(optimal_kind="bound", optimal_rms_ns=rms_bound * 1e9,
                   optimal_note="causal lower bound: the clairvoyant filter's phase-error covariance",
                   ratio_to_bound_direct=plain[0] / rms_bound,
                   ratio_to_bound_direct_ci=None if not math.isfinite(plain[1]) else [plain[1] / rms_bound,
                                                                                    plain[2] / rms_bound])
    else:
        out.update(optimal_kind="clairvoyant", optimal_rms_ns=best[0] * 1e9,
                   optimal_note="not a bound (the scenario is not Gaussian): the clairvoyant servo's time error")
    # Paired with the clairvoyant servo on the same trials: the trial-to-trial spread (the receivers' slow
    # wander) cancels, so this is the tight estimate of the ratio to the bound where the clairvoyant servo
    # attains it (tested), and the ratio to the clairvoyant otherwise.
    ratio = ratio_ci(ms, ms_best)
    out["ratio_to_optimal"] = ratio[0]
    out["ratio_to_optimal_ci"] = None if not math.isfinite(ratio[1]) else [ratio[1], ratio[2]]
    return out


def evaluate(sim: dict) -> dict:
    """The summary (JSON keys of the command line) of :func:`simulate_gnssdo`'s result."""
    run, best, setup = sim["run"], sim["clairvoyant"], sim["setup"]
    has_ref = np.isfinite(run.reference_error_s)
    summary = {"scenario": setup.scenario, "controller": setup.controller, "receivers": setup.receivers,
               "duration_s": setup.duration_s, "trials": setup.trials, "seed": setup.seed,
               "oscillator": sim["oscillator"].name, **time_error_metrics(run.phase_s, has_ref)}
    summary["design"] = sim.get("design", "datasheet")
    summary.update(optimal_metrics(run.phase_s, best.phase_s, has_ref, sim["environment"],
                                   sim["clairvoyant_servo"]))
    summary.update(_holdover(run, sim["environment"]))
    summary["state_seconds"] = run.states.seconds_in()
    locked = run.states.state == State.LOCKED
    threshold = run_config_threshold_s(sim)
    summary["locked_over_threshold_seconds"] = float(np.sum(locked & (np.abs(run.phase_s) >= threshold)) / setup.trials)
    summary["holdover_ready_seconds"] = float(run.states.holdover_ready.sum() / setup.trials)
    sigma = run.states.holdover_sigma_s
    summary["predicted_holdover_sigma_ns"] = (float(np.nanmedian(sigma)) * 1e9 if np.isfinite(sigma).any() else None)
    summary["state_changes_trial0"] = run.states.changes(0)[:50]
    summary["dac_rail_alarm_seconds"] = float(run.states.rail_alarm.sum() / setup.trials)
    summary["no_usable_receiver"] = bool(not has_ref.any())
    summary["adev"] = adev_series(sim["noise_phase_s"], run.reference_error_s, run.phase_s)
    return summary


def run_gnssdo(setup: GnssdoSetup, out_dir: Path | None = None, progress: Progress = silent) -> dict:
    """Simulate, evaluate and (with ``out_dir``) write ``summary.json`` and the PNG report; returns the summary."""
    from chronofuse.report.gnssdo import write_report
    from chronofuse.report.jsonio import dumps

    sim = simulate_gnssdo(setup, within(progress, 0.0, 0.4))  # measuring takes the rest (timed on a 1-day run)
    progress("measuring", 0.4)
    summary = evaluate(sim)
    if out_dir is not None:
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        from chronofuse.analysis.masks import MASKS
        from chronofuse.report.html import gnssdo_page

        output = np.asarray(sim["run"].phase_s[0, int(SETTLE_S):], dtype=float)
        summary["masks"] = {m: MASKS[m].check(output, 1.0).to_dict() for m in ("prtc-a", "prtc-b", "g811")}
        summary["masks_record"] = (f"the disciplined 1PPS of trial 0 from {SETTLE_S:g} s (after settling) to the end, "
                                   f"{output.size} s, any outage in holdover included")
        summary["files"] = write_report(sim, summary, out_dir) + ["summary.json", "report.html"]
        (out_dir / "summary.json").write_text(dumps(summary) + "\n")
        gnssdo_page(summary, out_dir)
    return summary


def run_reference(path: Path, controller: str = DEFAULT_CONTROLLER, seed: int = 0, trials: int = 1,
                  progress: Progress = lambda s: None, oscillator: str = "ocxo",
                  oscillator_model: OscillatorModel | None = None) -> dict:
    """Discipline a simulated oscillator against a real 1PPS record (truth: the record's reference clock).

    The record is the receiver's 1PPS error ``e`` (its mean, the antenna-cable offset, removed); the
    oscillator is simulated (seed child 0); the servo's measurement noise is calibrated on the record's
    first four hours by :func:`~chronofuse.discipline.design.equivalent_white_sigma_s` (what a user with a reference would do once).
    """
    _check_controller(controller)
    e = read_pps_reference(path, min_samples=int(2 * SETTLE_S))
    e = e - np.mean(e)
    steps = e.size
    osc = preset(oscillator) if oscillator_model is None else oscillator_model
    dac = Dac.for_oscillator(osc)
    root = root_seed(seed)
    progress("simulating the oscillator", 0.0)
    free, noise_only = _free_phase(osc, steps, trials, root)
    sigma = equivalent_white_sigma_s(e[:4 * 3600])
    env = dataclasses.replace(receiver_environment("open-sky"), name="reference")
    # One receiver against a maser: 300 s steering keeps the output's ADEV within twice the lower envelope
    # at every tau (200 s: 2.12x at 256 s; TE rms 10.9 ns either way).
    servo = make_controller(controller, osc, env, 1, dac, measurement_sigma_s=sigma, steer_s=300.0)
    progress(f"disciplining ({controller}) against {path.name}")
    # the chain's loop and state stages on the recorded reference (one receiver, always usable, no integrity,
    # no plausibility test: the record is the truth's reference)
    frame = {"free_phase_s": free, "reference_error_s": np.broadcast_to(e, free.shape),
             "loop_reference_s": np.broadcast_to(e, free.shape), "implausible": np.zeros(free.shape, dtype=bool),
             "usable": np.ones((trials, 1, steps), dtype=bool), "excluded": np.zeros((trials, 1, steps), dtype=bool)}
    run = Pipeline([("loop", LoopStage(servo)), ("states", StateStage(state_config(osc)))]).fit().run(frame)
    best = Pipeline([("loop", LoopStage(clairvoyant_controller(osc, env, 1, dac)))]).fit().run(frame)
    has_ref = np.ones(free.shape, dtype=bool)
    states = StateRun(run["gnssdo_state"], run["gnssdo_reason"], run["rail_alarm"], run["filtered_offset_s"],
                      run["holdover_ready"], run["holdover_sigma_s"])
    summary = {"reference": str(path), "controller": controller, "duration_s": steps, "trials": trials, "seed": seed,
               **time_error_metrics(run["phase_s"], has_ref),
               "optimal_rms_ns": time_error_metrics(best["phase_s"], has_ref)["time_error_rms_ns"],
               "state_seconds": states.seconds_in(),
               "adev": adev_series(noise_only, np.broadcast_to(e, free.shape), run["phase_s"])}
    return summary

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
  ``unresolved_offset_alarm_seconds``: seconds in ALARM entered for an unresolved offset (mean over trials:
  receivers let back in after a refusal that may carry what the oscillator could not resolve);
  ``holdover_ready_seconds`` and ``predicted_holdover_sigma_ns`` (median over the LOCKED seconds of the
  predicted holdover error's standard deviation after the state machine's horizon, 1 h);
* ``adev``: overlapping ADEV (mean Allan variance over trials) of the free-running oscillator, of the
  GNSS reference (the fused, qErr-corrected 1PPS error) and of the disciplined output.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.analysis.metrics import pooled_dev, trial_avar
from chronofuse.progress import Progress, silent, within
from chronofuse.analysis.stability.taus import averaging_factors
from chronofuse.analysis.montecarlo import mean_square_per_trial, ratio_ci, rms_ci
from chronofuse.discipline.bound import ClairvoyantServo, time_error_bound
from chronofuse.discipline.chain import ChainConfig, discipline_runs
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.design import clairvoyant_controller, design_measurement_sigma_s, equivalent_white_sigma_s
from chronofuse.discipline.plausibility import DragMonitor, ReferenceNoise
from chronofuse.discipline.qualification import Qualification
from chronofuse.discipline.pi import max_natural_hz
from chronofuse.discipline.registry import SERVOS
from chronofuse.discipline.servo import Servo
from chronofuse.discipline.stages import LoopStage, StateStage
from chronofuse.discipline.states import HoldoverModel, Reason, State, StateConfig, StateRun
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
           "DESIGN_STEER_S", "CALIBRATION_S", "reference_offset_s", "reference_sigma_s", "reference_spread_s",
           "reference_servo", "reference_frame", "reference_pipeline"]

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
            if self.loop_bandwidth_hz >= max_natural_hz(1.0):
                raise InputError(f"{{loop_bandwidth_hz}} == {self.loop_bandwidth_hz}: a PI loop of damping 1 "
                                 f"sampled each second is unstable from {max_natural_hz(1.0):.4g} Hz on",
                                 fields=("loop_bandwidth_hz",))
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


def design_gnssdo(setup: GnssdoSetup, progress: Progress = silent) -> dict:
    """What every trial of ``setup`` shares: the oscillator, the environment, the chain's settings, the
    controller (fitted once on its calibration record) and the clairvoyant yardstick."""
    root = root_seed(setup.seed)
    osc = preset(setup.oscillator) if setup.oscillator_model is None else setup.oscillator_model
    if setup.dac_bits is not None:
        osc = dataclasses.replace(osc, dac_bits=setup.dac_bits)
    dac = Dac.for_oscillator(osc)
    env = scenario_environment(setup.scenario, setup.duration_s)
    if setup.outage_start_s is not None:
        env = dataclasses.replace(env, jamming_start_s=setup.outage_start_s, jamming_duration_s=setup.outage_s)
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
    return {"setup": setup, "oscillator": osc, "environment": env, "config": config, "servo": servo,
            "design": design, "clairvoyant_servo": clairvoyant_controller(osc, env, setup.receivers, dac)}


def simulate_trials(plan: dict, first_trial: int, trials: int, progress: Progress = silent) -> dict:
    """Trials ``first_trial .. first_trial + trials - 1`` of :func:`design_gnssdo`'s ``plan``: each trial's numbers
    are those it has in a run of all of them (the seeding of :mod:`chronofuse.models`)."""
    setup = plan["setup"]
    root = root_seed(setup.seed)
    osc, env = plan["oscillator"], plan["environment"]
    progress("simulating the oscillator", 0.0)
    free, noise_only = _free_phase(osc, setup.duration_s, trials, root, first_trial)
    progress("simulating the receivers", 0.05)
    rx = simulate_receivers(env, setup.duration_s, setup.receivers, child_seed(root, 1), trials=trials,
                            first_trial=first_trial)
    servo, yardstick = copy.deepcopy(plan["servo"]), plan["clairvoyant_servo"]
    progress(f"disciplining ({setup.controller} and the clairvoyant servo)", 0.5)
    run, best = discipline_runs((servo, yardstick), free, rx.pps_error_s, rx.epochs, plan["config"])
    return {"setup": setup, "oscillator": osc, "environment": env, "free_phase_s": free, "noise_phase_s": noise_only,
            "receivers": rx, "run": run, "clairvoyant": best, "clairvoyant_servo": yardstick, "design": plan["design"],
            "config": plan["config"], "first_trial": first_trial}


def simulate_gnssdo(setup: GnssdoSetup, progress: Progress = silent) -> dict:
    """Simulate the scenario and run the chosen controller and the clairvoyant one on the same data."""
    return simulate_trials(design_gnssdo(setup, progress), 0, setup.trials, progress)


def _adev_taus(steps: int, start: int = int(SETTLE_S)) -> np.ndarray:
    return averaging_factors((steps - start) // 4, "octave").astype(float)


def adev_avar(free_phase_s: np.ndarray, reference_error_s: np.ndarray, phase_s: np.ndarray,
              start: int = int(SETTLE_S)) -> dict:
    """Each trial's Allan variance (trials, k) of the free-running oscillator, the GNSS reference and the
    disciplined output from ``start`` (the seconds before it hold the acquisition's phase step), on the octave
    grid up to a quarter of the record (``"tau"``), with the reference's missing seconds counted
    (``"gnss_missing"``, ``"gnss_seconds"``)."""
    taus = _adev_taus(phase_s.shape[1], start)
    gnss = -reference_error_s[:, start:]  # the reference 1PPS's own time error
    empty = np.isnan(gnss).all(axis=1)
    gnss_avar = np.full((gnss.shape[0], taus.size), np.nan)
    if not empty.all():
        gnss_avar[~empty] = trial_avar(gnss[~empty], 1.0, taus)
    return {"tau": taus, "free_run": trial_avar(free_phase_s[:, start:], 1.0, taus), "gnss": gnss_avar,
            "disciplined": trial_avar(phase_s[:, start:], 1.0, taus),
            "gnss_missing": int(np.isnan(gnss).sum()), "gnss_seconds": int(gnss.size)}


def pooled_adev(avar: dict) -> dict:
    """``{"free_run": {"tau", "dev"}, "gnss": ..., "disciplined": ...}``: the trials of :func:`adev_avar` pooled
    (:func:`~chronofuse.analysis.metrics.pooled_dev`); the reference's NaN where it misses over half its seconds."""
    taus = avar["tau"]
    gnss = (np.full(taus.shape, np.nan) if avar["gnss_missing"] > 0.5 * avar["gnss_seconds"]
            else pooled_dev(avar["gnss"]))
    return {"free_run": {"tau": taus, "dev": pooled_dev(avar["free_run"])}, "gnss": {"tau": taus, "dev": gnss},
            "disciplined": {"tau": taus, "dev": pooled_dev(avar["disciplined"])}}


def adev_series(free_phase_s: np.ndarray, reference_error_s: np.ndarray, phase_s: np.ndarray,
                start: int = int(SETTLE_S)) -> dict:
    """``{"free_run": {"tau", "dev"}, "gnss": ..., "disciplined": ...}``: overlapping ADEV pooled over the trials
    (:func:`adev_avar`, :func:`pooled_adev`)."""
    return pooled_adev(adev_avar(free_phase_s, reference_error_s, phase_s, start))


def te_window(has_reference: np.ndarray) -> np.ndarray:
    """The seconds the time error is measured over: from ``SETTLE_S`` on, with a usable reference."""
    t = np.arange(has_reference.shape[-1], dtype=float)
    return has_reference & (t >= SETTLE_S)[None, :]


def _ci_ns(interval) -> list | None:
    lo, hi = interval[1], interval[2]
    return None if not (math.isfinite(lo) and math.isfinite(hi)) else [lo * 1e9, hi * 1e9]


def _convergence_s(phase_s: np.ndarray, has_reference: np.ndarray) -> np.ndarray:
    """Per trial: the first second after which ``|TE| < CONVERGENCE_THRESHOLD_S`` at every later second with a
    usable reference (NaN: never, or never disciplined)."""
    bad = has_reference & (np.abs(phase_s) >= CONVERGENCE_THRESHOLD_S)
    conv = np.empty(phase_s.shape[0])
    for i, (row, seen) in enumerate(zip(bad, has_reference)):
        idx = np.flatnonzero(row)
        if not seen.any():  # never disciplined: it never converged
            conv[i] = math.nan
        else:
            conv[i] = 0.0 if idx.size == 0 else (math.nan if idx[-1] == row.size - 1 else float(idx[-1] + 1))
    return conv


def _time_error_trials(phase_s: np.ndarray, has_reference: np.ndarray) -> dict:
    """Per trial: the window's size, the mean square and peak-to-peak of TE over it, the convergence time."""
    window = te_window(has_reference)
    pp = np.full(phase_s.shape[0], np.nan)
    rows = window.any(axis=1)
    x = np.where(window, phase_s, np.nan)[rows]
    pp[rows] = np.nanmax(x, axis=1) - np.nanmin(x, axis=1)
    return {"count": window.sum(axis=1), "ms": mean_square_per_trial(phase_s, window), "pp": pp,
            "convergence": _convergence_s(phase_s, has_reference)}


def _time_error_summary(t: dict) -> dict:
    count = t["count"]
    ms = np.where(count > 0, t["ms"], 0.0)
    rms = math.sqrt(float(np.sum(ms * count)) / float(np.sum(count))) if count.sum() > 0 else math.nan
    pp = float(np.mean(t["pp"][np.isfinite(t["pp"])])) if np.isfinite(t["pp"]).any() else math.nan
    conv = t["convergence"]
    return {"time_error_rms_ns": rms * 1e9, "time_error_rms_ci_ns": _ci_ns(rms_ci(t["ms"])), "time_error_pp_ns": pp * 1e9,
            "convergence_s": float(np.median(conv)) if np.isfinite(conv).all() else None}


def time_error_metrics(phase_s: np.ndarray, has_reference: np.ndarray) -> dict:
    """TE rms (with its 95 % Monte Carlo interval over trials) and peak-to-peak after ``SETTLE_S`` with a
    usable reference, and the convergence time (s)."""
    return _time_error_summary(_time_error_trials(phase_s, has_reference))


def run_config_threshold_s(sim: dict) -> float:
    """The |TE| a run's LOCKED claims (its state machine's lock threshold)."""
    return float(state_config(sim["oscillator"]).lock_threshold_s)


def unresolved_alarm_seconds(states: StateRun) -> np.ndarray:
    """Seconds per trial in ALARM entered for an unresolved offset (a reference let back in after a refusal
    that may carry what the oscillator could not resolve: :mod:`chronofuse.discipline.states`)."""
    reason = np.asarray(states.reason)
    steps = np.arange(reason.shape[1])
    last = np.maximum.accumulate(np.where(reason != 0, steps, 0), axis=1)
    entered = np.take_along_axis(reason, last, axis=1)
    return np.sum((states.state == State.ALARM) & (entered == Reason.UNRESOLVED_OFFSET), axis=1)


def trial_stats(sim: dict) -> dict:
    """Everything :func:`summarize` needs from :func:`simulate_trials`' result, per trial (arrays (trials, ...)) or
    summed, so that blocks of trials merge (:func:`merge_stats`) without keeping their seconds."""
    run, best = sim["run"], sim["clairvoyant"]
    has_ref = np.isfinite(run.reference_error_s)
    window = te_window(has_ref)
    env = sim["environment"]
    out = {"te": _time_error_trials(run.phase_s, has_ref), "ms_best": mean_square_per_trial(best.phase_s, window)}
    if is_gaussian(env):
        out["bound_ms"] = time_error_bound(sim["clairvoyant_servo"], has_ref).per_trial_mean_square_s2(window)
    if env.jamming_start_s is not None and env.jamming_duration_s > 0:
        start = int(env.jamming_start_s)
        end = min(int(env.jamming_start_s + env.jamming_duration_s), run.phase_s.shape[1] - 1)
        out["holdover_err"] = run.phase_s[:, end] - run.phase_s[:, start]
        out["holdover_s"] = float(end - start)
    states = run.states
    locked = states.state == State.LOCKED
    sigma = states.holdover_sigma_s
    out.update(state_seconds=np.stack([(states.state == st).sum(axis=1) for st in State], axis=1),
               locked_over=np.sum(locked & (np.abs(run.phase_s) >= run_config_threshold_s(sim)), axis=1),
               ready=states.holdover_ready.sum(axis=1), rail=states.rail_alarm.sum(axis=1),
               unresolved=unresolved_alarm_seconds(states),
               sigma=np.asarray(sigma[np.isfinite(sigma)]), any_reference=has_ref.any(axis=1),
               changes_first=states.changes(0)[:50] if sim.get("first_trial", 0) == 0 else None,
               adev=adev_avar(sim["noise_phase_s"], run.reference_error_s, run.phase_s))
    return out


def merge_stats(blocks: list[dict]) -> dict:
    """:func:`trial_stats` of consecutive blocks of trials as one (the trials in order)."""
    if len(blocks) == 1:
        return blocks[0]

    def cat(get):
        return np.concatenate([get(b) for b in blocks])

    first = blocks[0]
    out = {"te": {k: cat(lambda b, k=k: b["te"][k]) for k in first["te"]}, "ms_best": cat(lambda b: b["ms_best"])}
    for key in ("bound_ms", "holdover_err", "state_seconds", "locked_over", "ready", "rail", "unresolved", "sigma",
                "any_reference"):
        if key in first:
            out[key] = cat(lambda b, key=key: b[key])
    if "holdover_s" in first:
        out["holdover_s"] = first["holdover_s"]
    out["changes_first"] = next((b["changes_first"] for b in blocks if b["changes_first"] is not None), None)
    adev = {"tau": first["adev"]["tau"]}
    for key in ("free_run", "gnss", "disciplined"):
        adev[key] = cat(lambda b, key=key: b["adev"][key])
    for key in ("gnss_missing", "gnss_seconds"):
        adev[key] = sum(b["adev"][key] for b in blocks)
    out["adev"] = adev
    return out


def optimal_summary(stats: dict, env: ReceiverEnvironment) -> dict:
    """``clairvoyant_rms_ns`` (+ CI), ``optimal_rms_ns``, ``optimal_kind`` and ``ratio_to_optimal`` (+ CI):
    the bound in a Gaussian scenario, the clairvoyant servo's TE otherwise (module docstring)."""
    ms, ms_best = stats["te"]["ms"], stats["ms_best"]
    best = rms_ci(ms_best)
    out = {"clairvoyant_rms_ns": best[0] * 1e9, "clairvoyant_rms_ci_ns": _ci_ns(best)}
    if is_gaussian(env):
        count = stats["te"]["count"]
        bound_ms = np.where(count > 0, stats["bound_ms"], 0.0)
        rms_bound = math.sqrt(float(np.sum(bound_ms * count)) / float(np.sum(count))) if count.sum() > 0 else math.nan
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


def summarize(plan: dict, stats: dict) -> dict:
    """The summary (JSON keys of the command line) from a plan (:func:`design_gnssdo`, or a simulation's result)
    and the trials' :func:`trial_stats`."""
    setup, env = plan["setup"], plan["environment"]
    trials = int(stats["te"]["count"].shape[0])
    summary = {"scenario": setup.scenario, "controller": setup.controller, "receivers": setup.receivers,
               "duration_s": setup.duration_s, "trials": trials, "seed": setup.seed,
               "oscillator": plan["oscillator"].name, **_time_error_summary(stats["te"])}
    summary["design"] = plan.get("design", "datasheet")
    summary.update(optimal_summary(stats, env))
    if "holdover_err" in stats:
        summary.update(holdover_error_ns=float(np.sqrt(np.mean(stats["holdover_err"] ** 2))) * 1e9,
                       holdover_s=stats["holdover_s"])
    summary["state_seconds"] = {st.name.lower(): float(stats["state_seconds"][:, i].sum() / trials)
                                for i, st in enumerate(State)}
    summary["locked_over_threshold_seconds"] = float(stats["locked_over"].sum() / trials)
    summary["holdover_ready_seconds"] = float(stats["ready"].sum() / trials)
    sigma = stats["sigma"]
    summary["predicted_holdover_sigma_ns"] = float(np.median(sigma)) * 1e9 if sigma.size else None
    summary["state_changes_trial0"] = stats["changes_first"]
    summary["dac_rail_alarm_seconds"] = float(stats["rail"].sum() / trials)
    summary["unresolved_offset_alarm_seconds"] = float(stats["unresolved"].sum() / trials)
    summary["no_usable_receiver"] = bool(not stats["any_reference"].any())
    summary["adev"] = pooled_adev(stats["adev"])
    summary["drag_check"] = drag_check(plan["config"].receiver_monitor)
    return summary


def drag_check(monitor: DragMonitor | None, budget_s: float = 100e-9) -> dict | None:
    """What the oscillator's plausibility test can catch with these receivers (None: the test is off): the
    slowest coherent drag refused before the time error reaches ``budget_s`` (its rate and horizon; None where
    no horizon's threshold is under the budget, as in an urban canyon) and ``refused_from_te_ns``, the smallest
    threshold over the horizons: no drag is refused before the output is that far off."""
    if monitor is None:
        return None
    rate, horizon = monitor.slowest_rate(budget_s)
    caught = math.isfinite(rate)
    return {"budget_ns": budget_s * 1e9, "slowest_rate_ns_per_s": rate * 1e9 if caught else None,
            "horizon_s": horizon if caught else None, "refused_from_te_ns": min(monitor.thresholds_s) * 1e9}


def evaluate(sim: dict) -> dict:
    """The summary (JSON keys of the command line) of :func:`simulate_gnssdo`'s result."""
    return summarize(sim, trial_stats(sim))


#: Trials simulated together: a block's seconds (the receivers' epochs, every stage's columns) are dropped once
#: its :func:`trial_stats` are taken, so memory does not grow with the trial count (about 120 MB a trial-day
#: with three receivers).
BLOCK_TRIALS = 4


def _block_stats(plan: dict, first: int, count: int) -> dict:
    return trial_stats(simulate_trials(plan, first, count))


def _workers(requested: int | None, blocks: int) -> int:
    if requested is not None:
        check_scalar(requested, "workers", min_val=1, integer=True)
        return min(int(requested), blocks)
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, min(cores, blocks))


def gnssdo_stats(plan: dict, workers: int | None = None, progress: Progress = silent) -> dict:
    """:func:`trial_stats` of every trial of ``plan`` (:func:`design_gnssdo`), simulated in blocks of
    :data:`BLOCK_TRIALS` trials on ``workers`` processes (None: one per usable core); the same numbers
    whatever the blocks or the workers (each trial's seeds are its own)."""
    trials = plan["setup"].trials
    blocks = [(first, min(BLOCK_TRIALS, trials - first)) for first in range(0, trials, BLOCK_TRIALS)]
    n = _workers(workers, len(blocks))
    if n == 1:
        stats = []
        for i, (first, count) in enumerate(blocks):
            progress(f"trials {first + 1}-{first + count} of {trials}", first / trials)
            stats.append(_block_stats(plan, first, count))
        return merge_stats(stats)
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    # fork: the workers start with this process's imports and compiled kernels (spawn re-imports both, seconds)
    method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
    progress(f"{trials} trials in {len(blocks)} blocks on {n} processes")
    with ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context(method)) as pool:
        stats = list(pool.map(_block_stats, [plan] * len(blocks), *zip(*blocks)))
    return merge_stats(stats)


def run_gnssdo(setup: GnssdoSetup, out_dir: Path | None = None, progress: Progress = silent,
               workers: int | None = None) -> dict:
    """Simulate, evaluate and (with ``out_dir``) write ``summary.json`` and the PNG report; returns the summary.

    Trials run in blocks on ``workers`` processes (:func:`gnssdo_stats`); the report's plots show trial 0."""
    from chronofuse.report.gnssdo import write_report
    from chronofuse.report.jsonio import dumps

    plan = design_gnssdo(setup, within(progress, 0.0, 0.05))
    if setup.trials <= BLOCK_TRIALS:
        sim = simulate_trials(plan, 0, setup.trials, within(progress, 0.05, 0.4))
        progress("measuring", 0.4)
        summary = summarize(plan, trial_stats(sim))
    else:
        summary = summarize(plan, gnssdo_stats(plan, workers, within(progress, 0.05, 0.9)))
        sim = simulate_trials(plan, 0, 1) if out_dir is not None else None
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


#: The receiver environment a recorded reference is designed for (its noise is calibrated on the record).
REFERENCE_ENVIRONMENT = dataclasses.replace(receiver_environment("open-sky"), name="reference")


#: The seconds of a recorded reference its calibration uses (offset, noise, spread): its first four hours, what a
#: user with a reference does once at installation; the run from then on uses nothing from later seconds.
CALIBRATION_S = 4 * 3600


def reference_offset_s(reference_error_s) -> float:
    """The recorded 1PPS error's constant offset (the antenna and cable delay): its mean over the first
    :data:`CALIBRATION_S` seconds."""
    return float(np.nanmean(np.asarray(reference_error_s, dtype=np.float64)[:CALIBRATION_S]))


def reference_sigma_s(reference_error_s) -> float:
    """The recorded 1PPS error's equivalent white standard deviation, calibrated on its first four hours
    (:func:`~chronofuse.discipline.design.equivalent_white_sigma_s`): the servo's measurement noise."""
    return float(equivalent_white_sigma_s(np.asarray(reference_error_s, dtype=np.float64)[:CALIBRATION_S]))


def reference_spread_s(reference_error_s) -> float:
    """The recorded 1PPS error's standard deviation over its first four hours: the reference's own error, the
    state machine's noise margin (:class:`~chronofuse.discipline.states.StateConfig`'s ``noise_sigmas``)."""
    return float(np.nanstd(np.asarray(reference_error_s, dtype=np.float64)[:CALIBRATION_S]))


def reference_servo(reference_error_s, controller: str, osc: OscillatorModel) -> Servo:
    """The servo ``gnssdo --reference`` disciplines ``osc`` with: ``controller`` on ``osc``'s DAC, its measurement
    noise calibrated on the record's first four hours (:func:`~chronofuse.discipline.design.equivalent_white_sigma_s`;
    what a user with a reference would do once)."""
    sigma = reference_sigma_s(reference_error_s)
    # One receiver against a maser: 300 s steering keeps the output's ADEV within twice the lower envelope
    # at every tau (200 s: 2.12x at 256 s; TE rms 10.9 ns either way).
    return make_controller(controller, osc, REFERENCE_ENVIRONMENT, 1, Dac.for_oscillator(osc), measurement_sigma_s=sigma,
                           steer_s=300.0)


def reference_frame(reference_error_s, free_phase_s, reference_sigma_s: float = math.nan) -> dict:
    """The input columns of :func:`reference_pipeline`: a recorded 1PPS error ``reference_error_s`` (steps,)
    (NaN: no pulse that second) as the one receiver, always usable and never excluded (no integrity, no
    plausibility test: the record is the truth's reference), its standard deviation ``reference_sigma_s``
    (NaN: unknown) and the free oscillator ``free_phase_s`` (trials, steps)."""
    free = np.asarray(free_phase_s, dtype=np.float64)
    e = np.broadcast_to(np.asarray(reference_error_s, dtype=np.float64), free.shape)
    trials, steps = free.shape
    return {"free_phase_s": free, "reference_error_s": e, "loop_reference_s": e,
            "implausible": np.zeros(free.shape, dtype=bool), "usable": np.ones((trials, 1, steps), dtype=bool),
            "excluded": np.zeros((trials, 1, steps), dtype=bool),
            "reference_variance_s2": np.full(free.shape, float(reference_sigma_s) ** 2),
            "unresolved_s": np.zeros(free.shape)}


def reference_pipeline(servo: Servo, osc: OscillatorModel) -> Pipeline:
    """The chain's loop and state stages, what ``gnssdo --reference`` runs on :func:`reference_frame`'s
    columns (in batch; streamed second by second it gives the same, tested)."""
    return Pipeline([("loop", LoopStage(servo)), ("states", StateStage(state_config(osc)))])


def run_reference(path: Path, controller: str = DEFAULT_CONTROLLER, seed: int = 0, trials: int = 1,
                  progress: Progress = silent, oscillator: str = "ocxo",
                  oscillator_model: OscillatorModel | None = None) -> dict:
    """Discipline a simulated oscillator against a real 1PPS record (truth: the record's reference clock).

    The record is the receiver's 1PPS error ``e``, its antenna-cable offset removed; the oscillator is
    simulated (seed child 0). The offset (:func:`reference_offset_s`), the servo's measurement noise
    (:func:`reference_sigma_s`) and the state machine's noise margin (:func:`reference_spread_s`) are
    calibrated on the record's first :data:`CALIBRATION_S` seconds, what a user with a reference does once:
    no second of the run depends on a later one (a prefix of the record runs as the start of the whole).
    """
    _check_controller(controller)
    e = read_pps_reference(path, min_samples=int(2 * SETTLE_S))
    offset = reference_offset_s(e)
    e = e - offset
    steps = e.size
    osc = preset(oscillator) if oscillator_model is None else oscillator_model
    dac = Dac.for_oscillator(osc)
    root = root_seed(seed)
    progress("simulating the oscillator", 0.0)
    free, noise_only = _free_phase(osc, steps, trials, root)
    env = REFERENCE_ENVIRONMENT
    servo = reference_servo(e, controller, osc)
    progress(f"disciplining ({controller}) against {path.name}")
    frame = reference_frame(e, free, reference_spread_s(e))
    run = reference_pipeline(servo, osc).fit().run(frame)
    best = Pipeline([("loop", LoopStage(clairvoyant_controller(osc, env, 1, dac)))]).fit().run(frame)
    has_ref = np.ones(free.shape, dtype=bool)
    states = StateRun(run["gnssdo_state"], run["gnssdo_reason"], run["rail_alarm"], run["filtered_offset_s"],
                      run["holdover_ready"], run["holdover_sigma_s"])
    summary = {"reference": str(path), "controller": controller, "duration_s": steps, "trials": trials, "seed": seed,
               "calibration_s": min(CALIBRATION_S, steps), "cable_offset_ns": offset * 1e9,
               **time_error_metrics(run["phase_s"], has_ref),
               "optimal_rms_ns": time_error_metrics(best["phase_s"], has_ref)["time_error_rms_ns"],
               "state_seconds": states.seconds_in(),
               "adev": adev_series(noise_only, np.broadcast_to(e, free.shape), run["phase_s"])}
    return summary

"""Two-node link experiments (orchestration only): scenario -> prior draw -> calibration -> truth -> algorithms
-> metrics with intervals, beside the Bayesian bound of the same model.

:func:`run_link` is the one library call behind ``chronofuse swarm run``: each trial is one link with its
own draw from the scenario's prior (offset, skew, reply delay, initial range), its own URT calibration
(a separate run while both nodes know true time), then ``exchanges`` exchanges; every named algorithm runs
on the same exchanges, and each one's RMSE, its ratio to the bound (with percentile-bootstrap intervals
over trials, so the calibration-to-calibration spread is in them) and its convergence epochs come back.

Random streams (``chronofuse.seeding``), children of the root: 0 clock A, 1 clock B, 2 link noise, 3 the
prior draw, 4 the calibration; inside each, trial ``i`` has its own child, so a trial's numbers do not
depend on how many trials run or where.
"""

from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, replace

import numpy as np

from chronofuse.models.clock_markov import ClockMarkovModel
from chronofuse.models.earth_frame import EarthRotating
from chronofuse.models.kinematics import climb, constant_velocity, manoeuvre, turn
from chronofuse.models.link import Exchanges, LinkModel, node_clock_error_s, simulate_exchanges
from chronofuse.models.oscillator_presets import preset
from chronofuse.progress import Progress, silent
from chronofuse.seeding import child_rng, child_seed, root_seed
from chronofuse.sync.base import measurement_array
from chronofuse.sync.calibration import CalibrationConfig, UrtCalibration, calibrate_urt
from chronofuse.sync.metrics import (MIN_INTERVAL_TRIALS, convergence_epochs, per_trial_bound_var, per_trial_mse,
                                     ratio_interval,
                                     rmse_interval, robustness, scored_trials)
from chronofuse.sync.pcrb import exchange_bound
from chronofuse.sync.prior import LinkPrior, PriorDraw
from chronofuse.sync.registry import ALGORITHM_NAMES, LinkKnowledge, make_algorithm
from chronofuse.validation import InputError, InputWarning, check_choice, check_scalar

__all__ = ["LinkScenario", "link_paths", "simulate_scenario", "calibrate_scenario", "knowledge_of", "run_link",
           "hold_last", "MANOEUVRES"]

MANOEUVRES = ("none", "turn", "climb")
CLOCK_TRUTHS = ("power-law", "markov")


@dataclass(frozen=True)
class LinkScenario:
    """One two-node link (defaults: the paper's section 4 conditions, SNR 10 dB assumed; it does not say).

    Geometry: B starts ``distance_m`` from A (the prior may spread it) along the line of sight and moves
    along it at ``velocity_m_s`` (opening > 0) with ``acceleration_m_s2``; both nodes also fly at
    ``common_velocity_m_s`` along the line (A's own motion, which the paper's "A at rest" cannot see), and
    B at ``cross_velocity_m_s`` across it. ``latitude_deg`` None puts the nodes in the inertial frame
    (no Earth rotation, the paper's setting); a latitude puts them on the rotating Earth with the line of
    sight on ``bearing_deg`` (degrees from north), so the Sagnac effect is in the truth. ``manoeuvre``
    ("none", "turn", "climb") makes B turn or pull up at ``load_factor_g`` from ``manoeuvre_start_s`` for
    ``manoeuvre_s``. ``clock_truth``: "power-law" (the oscillator preset's noise, flicker by Kasdin-Walter)
    or "markov" (the finite model the filter and bound use, so the bound is exact for the truth).
    ``prior`` and ``calibration`` are stated (:mod:`chronofuse.sync.prior`, :mod:`chronofuse.sync.calibration`).
    """

    distance_m: float = 80e3
    velocity_m_s: float = 800.0
    acceleration_m_s2: float = 0.0
    exchanges: int = 2000
    oscillator: str = "ocxo"
    link: LinkModel = LinkModel()
    prior: LinkPrior = LinkPrior()
    calibration: CalibrationConfig = CalibrationConfig()
    common_velocity_m_s: float = 0.0
    cross_velocity_m_s: float = 0.0
    latitude_deg: float | None = None
    bearing_deg: float = 90.0
    manoeuvre: str = "none"
    load_factor_g: float = 5.0
    manoeuvre_start_s: float = 5.0
    manoeuvre_s: float = 5.0
    clock_truth: str = "power-law"

    def __post_init__(self):
        check_scalar(self.distance_m, "distance_m", min_val=0.0)
        for name in ("velocity_m_s", "common_velocity_m_s", "cross_velocity_m_s"):
            check_scalar(getattr(self, name), name, min_val=-1e4, max_val=1e4)
        check_scalar(self.acceleration_m_s2, "acceleration_m_s2", min_val=-1e3, max_val=1e3)
        check_scalar(self.exchanges, "exchanges", min_val=2, integer=True)
        if self.latitude_deg is not None:
            check_scalar(self.latitude_deg, "latitude_deg", min_val=-89.0, max_val=89.0)
        check_scalar(self.bearing_deg, "bearing_deg", min_val=-360.0, max_val=360.0)
        check_choice(self.manoeuvre, "manoeuvre", MANOEUVRES)
        check_scalar(self.load_factor_g, "load_factor_g", min_val=1.0, max_val=12.0)
        check_choice(self.clock_truth, "clock_truth", CLOCK_TRUTHS)
        preset(self.oscillator)
        if not isinstance(self.link, LinkModel):
            raise TypeError(f"link == {self.link!r}, must be a LinkModel")

    @property
    def duration_s(self) -> float:
        return self.exchanges * self.link.interval_s


def _unit(bearing_deg: float) -> np.ndarray:
    b = np.radians(bearing_deg)
    return np.array([np.sin(b), np.cos(b), 0.0])


def link_paths(sc: LinkScenario, ranges_m: np.ndarray, *, static: bool = False):
    """A's and B's paths (trial axis of ``ranges_m``) for scenario ``sc``; ``static``: both at rest in the
    scenario's frame (the calibration's formation)."""
    ranges = np.atleast_1d(np.asarray(ranges_m, dtype=np.float64))
    u = _unit(sc.bearing_deg)
    across = np.array([u[1], -u[0], 0.0])
    altitude = np.array([0.0, 0.0, 3000.0])
    v_a = np.zeros(3) if static else sc.common_velocity_m_s * u
    v_b = v_a if static else v_a + sc.velocity_m_s * u + sc.cross_velocity_m_s * across
    acc_b = np.zeros(3) if static else sc.acceleration_m_s2 * u
    r_b = altitude + ranges[:, None] * u
    a = constant_velocity(altitude, v_a)
    if static or sc.manoeuvre == "none":
        b = manoeuvre(r_b, np.broadcast_to(v_b, r_b.shape), np.zeros(1), acc_b[None, :])
    else:
        if sc.manoeuvre == "turn":
            profile = turn(np.zeros(3), v_b, load_factor_g=sc.load_factor_g, start_s=sc.manoeuvre_start_s,
                           duration_s=sc.manoeuvre_s)
        else:
            profile = climb(np.zeros(3), v_b, load_factor_g=sc.load_factor_g, start_s=sc.manoeuvre_start_s,
                            pull_s=sc.manoeuvre_s / 2.0, hold_s=sc.manoeuvre_s / 2.0)
        acc = profile.acceleration_m_s2[0] + acc_b
        b = manoeuvre(r_b, np.broadcast_to(v_b, r_b.shape), profile.segment_start_s, acc)
    if sc.latitude_deg is not None:
        return EarthRotating(a, sc.latitude_deg, 0.0, 0.0), EarthRotating(b, sc.latitude_deg, 0.0, 0.0)
    return a, b


def _clocks(sc: LinkScenario, steps: int, interval_s: float, base, draw: PriorDraw, trials: int, keys=(0, 1)):
    """Clock errors of A and B (trials, steps + 2): the oscillators' noise, B offset and skewed per draw."""
    osc = preset(sc.oscillator)
    t = np.arange(steps + 2) * interval_s
    if sc.clock_truth == "markov":
        single = ClockMarkovModel.for_link(osc, _silent(osc), interval_s, steps * interval_s)
        xa = np.vstack([single.simulate_phase_s(steps + 2, interval_s, child_rng(base, keys[0], i)) for i in range(trials)])
        xb = np.vstack([single.simulate_phase_s(steps + 2, interval_s, child_rng(base, keys[1], i)) for i in range(trials)])
    else:
        xa = node_clock_error_s(osc, steps, interval_s, child_seed(base, keys[0]), trials)
        xb = node_clock_error_s(osc, steps, interval_s, child_seed(base, keys[1]), trials)
    return xa, xb + draw.offset_s[:, None] + draw.skew[:, None] * t


def _silent(osc):
    """An oscillator with no noise (so that ``for_link(osc, silent)`` is one clock's model)."""
    from dataclasses import replace as _replace

    from chronofuse.models.oscillator import PowerLaw

    return _replace(osc, h=PowerLaw())


def simulate_scenario(sc: LinkScenario, trials: int, seed, *, urt_change_s=None,
                      true_offset_s=None) -> tuple[Exchanges, PriorDraw]:
    """Truth and measurements of ``trials`` links of ``sc`` (each its own prior draw), and the draws.
    ``urt_change_s`` (steps,) or (trials, steps) is added to each link's URT (a change after calibration).
    ``true_offset_s`` (a number or (trials,)) replaces the drawn initial offsets, everything else drawn as
    before: a stress test of offsets the nodes' prior makes unlikely (its tails)."""
    check_scalar(trials, "trials", min_val=1, integer=True)
    base = root_seed(seed)
    draw = sc.prior.draw(sc.distance_m, int(trials), child_seed(base, 3))
    if true_offset_s is not None:
        forced = np.broadcast_to(np.asarray(true_offset_s, dtype=np.float64), (int(trials),)).copy()
        if not np.all(np.isfinite(forced)):
            raise InputError(f"{{true_offset_s}} == {true_offset_s!r}, must be finite", fields=("true_offset_s",))
        draw = draw.model_copy(update={"offset_s": forced})
    steps, dt = int(sc.exchanges), sc.link.interval_s
    xa, xb = _clocks(sc, steps, dt, base, draw, int(trials))
    a, b = link_paths(sc, draw.range_m)
    change = np.broadcast_to(draw.urt_deviation_s[:, None], (int(trials), steps))
    if urt_change_s is not None:
        change = change + np.asarray(urt_change_s, dtype=np.float64)
    ex = simulate_exchanges(a, b, xa, xb, sc.link, steps, child_seed(base, 2), urt_change_s=change)
    return ex, draw


def calibrate_scenario(sc: LinkScenario, draw: PriorDraw, seed) -> UrtCalibration:
    """Each link's URT calibration (:mod:`chronofuse.sync.calibration`): a separate run with both nodes at
    rest at the link's initial range, one exchange per GNSS time comparison, each node's GNSS time off by
    white noise of ``reference_sigma_s``. Uses the truth on purpose (the reference stands for GNSS)."""
    base = root_seed(seed)
    cal = sc.calibration
    trials = draw.offset_s.size
    link = replace(sc.link, interval_s=cal.reference_interval_s, loss_fraction=0.0, nlos_probability=0.0)
    steps = cal.comparisons
    xa, xb = _clocks(sc, steps, link.interval_s, base, draw, trials, keys=(0, 1))
    a, b = link_paths(sc, draw.range_m, static=True)
    ex = simulate_exchanges(a, b, xa, xb, link, steps, child_seed(base, 2),
                            urt_change_s=np.broadcast_to(draw.urt_deviation_s[:, None], (trials, steps)))
    ref = ex.offset_s + cal.reference_sigma_s * np.sqrt(2.0) * np.vstack(
        [child_rng(base, 3, i).standard_normal(steps) for i in range(trials)])
    return calibrate_urt(ex.t_i_s, ex.t_b_s, ex.t_r_s, ex.velocity_m_s, ex.a_los_velocity_m_s,
                         link.toa_sigma_at(ex.snr_db), ref, t_s=ex.t_s, urt_jitter_s=link.urt_jitter_s,
                         reference_sigma_s=cal.reference_sigma_s, velocity_sigma_m_s=link.velocity_sigma_at(ex.snr_db))


def knowledge_of(sc: LinkScenario, calibration: UrtCalibration | None, urt_mode: str = "calibrated") -> LinkKnowledge:
    """What the nodes of ``sc`` know after ``calibration`` (None: the nominal URT, no uncertainty)."""
    urt = sc.link.urt_fixed_s if calibration is None else calibration.urt_s
    sigma = 0.0 if calibration is None else calibration.sigma_s
    return LinkKnowledge(link=sc.link, oscillator=preset(sc.oscillator), prior=sc.prior, steps=sc.exchanges,
                         urt_s=urt, calibration_sigma_s=sigma, urt_mode=urt_mode)


def hold_last(est: np.ndarray) -> np.ndarray:
    """Each row with NaN replaced by the last finite value before it (a receiver holds its output)."""
    idx = np.where(np.isfinite(est), np.arange(est.shape[1]), 0)
    np.maximum.accumulate(idx, axis=1, out=idx)
    return np.take_along_axis(est, idx, axis=1)


def bound_of(sc: LinkScenario, ex: Exchanges, calibration: UrtCalibration | None):
    """The Bayesian bound of these exchanges under ``sc``'s prior and ``calibration``'s uncertainty."""
    know = knowledge_of(sc, calibration)
    return exchange_bound(sc.link, know.clock_model(), sc.prior, t_i_s=np.where(ex.lost, np.nan, ex.tau_up_s + ex.offset_s),
                          t_b_s=np.where(ex.lost, np.nan, ex.t_b_s), offset_s=ex.offset_s,
                          velocity_m_s=ex.radial_velocity_m_s, snr_db=np.where(ex.lost, np.nan, ex.snr_db),
                          calibration_sigma_s=know.calibration_sigma_s)


def run_link(sc: LinkScenario, algorithms=ALGORITHM_NAMES, *, trials: int = 20, seed=0, urt_mode: str = "calibrated",
             threshold_s: float = 1e-9, networks: dict | None = None, outage: tuple[int, int] | None = None,
             overrides: dict | None = None, variants: dict | None = None, true_offset_s=None,
             progress: Progress = silent) -> dict:
    """Run ``algorithms`` on ``trials`` links of ``sc`` (module docstring); ``progress(message, fraction)``
    hears of each algorithm as it starts (:mod:`chronofuse.progress`).

    Returns a dict: per algorithm ``rmse_s`` and its interval ``rmse_ci_s``, ``ratio`` to the bound and
    ``ratio_ci``, ``convergence_epochs`` (K*: first exchange whose running RMSE over trials is below
    ``threshold_s``; None if never), ``mse_per_trial_s2`` (NaN: the trial had no estimate), ``bound_rms_s``
    (the bound's RMS over the exchanges the algorithm is scored on, the ratio's denominator:
    :func:`chronofuse.sync.metrics.per_trial_bound_var`),
    ``unscored_trials`` (the indices of those trials, left out of the RMSE and ratio with a warning); ``bound_s`` (``rms``, ``final``, per trial);
    ``calibration`` (the URT estimates' error and stated sigma); the scenario. ``networks`` maps "bp" /
    "lstm" to trained residual networks. ``outage = (k0, k1)`` also loses exchanges ``k0 .. k1 - 1`` and adds
    ``robustness`` (the paper's eqs. 49-50). ``overrides`` maps an algorithm name to configuration fields;
    ``variants`` maps more labels to ``(name, fields)``: the same algorithm with other settings, on the same
    exchanges, reported under the label. ``true_offset_s`` (a number or one per trial) fixes the trials' true
    initial offsets instead of drawing them (:func:`simulate_scenario`; the nodes still know only the prior).
    """
    if outage is not None:
        k0, k1 = (int(k) for k in outage)
        if not 1 <= k0 < k1 <= sc.exchanges:
            raise InputError(f"{{outage}} == {k0}:{k1}, must be K0:K1 with 1 <= K0 < K1 <= {{exchanges}} ({sc.exchanges})",
                             fields=("outage", "exchanges"))
    check_choice(urt_mode, "urt_mode", ("paper", "calibrated"))
    base = root_seed(seed)
    ex, draw = simulate_scenario(sc, trials, child_seed(base, 0), true_offset_s=true_offset_s)
    calib = calibrate_scenario(sc, draw, child_seed(base, 4))
    know = knowledge_of(sc, calib, urt_mode)
    Z = measurement_array(ex)
    bound = bound_of(sc, ex, calib)
    out = {name: {} for name in ("rmse_s", "rmse_ci_s", "ratio", "ratio_ci", "convergence_epochs",
                                 "mse_per_trial_s2", "bound_rms_s", "robustness", "unscored_trials")}
    if trials < MIN_INTERVAL_TRIALS:
        warnings.warn(InputWarning(f"{{trials}} == {trials} is below {MIN_INTERVAL_TRIALS}: no 95 % intervals (a "
                                   f"bootstrap over so few trials is too narrow)", fields=("trials",)), stacklevel=2)
    runs = [(name, name, (overrides or {}).get(name, {})) for name in algorithms]
    runs += [(label, name, fields) for label, (name, fields) in (variants or {}).items()]
    for i, (name, algorithm, fields) in enumerate(runs):
        progress(name, 0.1 + 0.9 * i / len(runs))
        alg = make_algorithm(algorithm, know, networks=networks, **fields).fit()
        err = alg.run(Z).offset_s - ex.offset_s
        mse = per_trial_mse(err)
        bound_var = per_trial_bound_var(bound.offset_var_s2, err)  # over the exchanges it is scored on
        r, lo, hi, q, qlo, qhi, unscored = score_trials(name, mse, bound_var)
        scored = np.isfinite(bound_var)
        out["bound_rms_s"][name] = float(np.sqrt(bound_var[scored].mean())) if scored.any() else float("nan")
        out["unscored_trials"][name] = unscored
        out["rmse_s"][name], out["rmse_ci_s"][name] = r, [lo, hi]
        out["ratio"][name], out["ratio_ci"][name] = q, [qlo, qhi]
        out["convergence_epochs"][name] = convergence_epochs(err, threshold_s)
        out["mse_per_trial_s2"][name] = mse.tolist()
        if outage is not None:
            stressed = Z.copy()
            stressed[:, k0:k1, :] = np.nan
            err_stress = hold_last(alg.run(stressed).offset_s) - ex.offset_s
            out["robustness"][name] = robustness(hold_last(err + ex.offset_s) - ex.offset_s, err_stress, threshold_s, k1)
    cal_err = calib.urt_s - (sc.link.urt_fixed_s + draw.urt_deviation_s)
    return {
        **out,
        "bound_s": {"rms": bound.mean_rms_s, "final": float(np.sqrt(np.mean(bound.final_s**2))),
                    "per_trial_rms": bound.rms_s.tolist()},
        "calibration": {"urt_error_rms_s": float(np.sqrt(np.mean(cal_err**2))),
                        "stated_sigma_rms_s": float(np.sqrt(np.mean(calib.sigma_s**2)))},
        "urt_mode": urt_mode,
        "true_offset_s": None if true_offset_s is None else np.broadcast_to(
            np.asarray(true_offset_s, dtype=np.float64), (int(trials),)).tolist(),
        "threshold_s": float(threshold_s),
        "trials": int(trials),
        "scenario": _scenario_dict(sc),
    }


def score_trials(name: str, mse, bound_var, confidence: float = 0.95) -> tuple:
    """``(rmse, lo, hi, ratio, ratio_lo, ratio_hi, unscored)`` of one algorithm over the trials where it gave
    an estimate; ``unscored`` lists the others (left out, with an :class:`InputWarning` naming how many). All
    NaN when no trial has an estimate; ``lo``/``hi`` NaN below :data:`MIN_INTERVAL_TRIALS` scored trials."""
    mse, bound_var = np.asarray(mse, dtype=float), np.asarray(bound_var, dtype=float)
    ok = scored_trials(mse)
    unscored = np.flatnonzero(~ok).tolist()
    if unscored:
        warnings.warn(InputWarning(
            f"{name}: {len(unscored)} of {mse.size} trials had no estimate (no exchange got through to it): "
            f"left out of its RMSE and ratio" + (f" (which cover the other {ok.sum()})" if ok.any()
                                                 else ", which are not available")), stacklevel=3)
    if not ok.any():
        return (float("nan"),) * 6 + (unscored,)
    return (*rmse_interval(mse[ok], confidence), *ratio_interval(mse[ok], bound_var[ok], confidence), unscored)


def _scenario_dict(sc: LinkScenario) -> dict:
    d = {k: v for k, v in asdict(sc).items() if k not in ("link", "prior", "calibration")}
    return d | {"link": asdict(sc.link), "prior": sc.prior.model_dump(), "calibration": sc.calibration.model_dump()}

"""What physics requires of the disciplined oscillator, measured on simulated truth (slow: a few seconds each).

Independent yardsticks: the free-running oscillator and the GNSS reference of the same run (their lower
ADEV envelope is what no controller can beat), and the clairvoyant Kalman servo given the true models.
"""

import numpy as np
import pytest

from chronofuse.discipline.dac import Dac
from chronofuse.discipline.holdover import clairvoyant_holdover_error, holdover_error
from chronofuse.discipline.loop import close_loop
from chronofuse.experiments.gnssdo import (
    DEFAULT_CONTROLLER,
    GnssdoSetup,
    _free_phase,
    evaluate,
    make_controller,
    scenario_environment,
    simulate_gnssdo,
)
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.seeding import child_seed, root_seed

pytestmark = pytest.mark.slow


def _summary(**kw):
    return evaluate(simulate_gnssdo(GnssdoSetup(**{"duration_s": 43_200, "trials": 3, "seed": 5, **kw})))


def test_the_disciplined_adev_keeps_the_oscillator_inside_the_loop_and_stays_near_the_envelope():
    a = _summary(scenario="open-sky")["adev"]
    tau = np.array(a["free_run"]["tau"])
    free, gnss, ours = (np.array(a[k]["dev"]) for k in ("free_run", "gnss", "disciplined"))
    inside = tau <= 4  # the loop's steering time constant is 200 s (DESIGN_STEER_S): these taus are well inside it
    assert np.all(ours[inside] <= 1.1 * free[inside])
    assert np.all(ours <= 2.0 * np.fmin(free, gnss))


@pytest.mark.parametrize("scenario", ["open-sky", "urban-canyon"])
def test_the_default_controller_is_within_125_percent_of_the_clairvoyant_kalman_servo(scenario):
    s = _summary(scenario=scenario, controller=DEFAULT_CONTROLLER)
    assert s["time_error_rms_ns"] <= 1.25 * s["optimal_rms_ns"]


def test_the_seeds_pi_preset_is_far_from_optimal_in_an_urban_canyon():
    s = _summary(scenario="urban-canyon", controller="pi")
    assert s["time_error_rms_ns"] > 1.25 * s["optimal_rms_ns"]


def test_gating_beats_the_plain_kalman_filter_under_jump_outliers_though_not_by_the_seeds_30_percent():
    # The servos' own handling of the outliers, without the plausibility test in front of them: with it, the
    # lone receiver's outliers (2 % of the seconds, rms 300 ns) get it refused (7,720 s of holdover in 12 h,
    # seed 5, 3 trials) and the run measures the holdover, not the servo (gated 10.9 against 5.4 ns without;
    # the fitted plain Kalman servo 35 ns).
    kf = _summary(scenario="outliers", controller="kalman", receivers=1, plausibility=False)["time_error_rms_ns"]
    gated = _summary(scenario="outliers", controller="gated-kalman", receivers=1,
                     plausibility=False)["time_error_rms_ns"]
    assert gated < 0.98 * kf
    assert gated > 0.7 * kf  # measured: 5-10 % better (docs/gnssdo), not the source paper's 30 %


def test_fused_receivers_beat_best_source_selection_in_an_urban_canyon():
    fused = _summary(scenario="urban-canyon", receivers=4, fusion="fusion")
    selected = _summary(scenario="urban-canyon", receivers=4, fusion="selection")
    assert fused["time_error_rms_ns"] < selected["time_error_rms_ns"]


def test_holdover_error_is_bounded_below_by_the_clairvoyant_predictor_and_shrinks_with_a_longer_lock():
    osc = preset("ocxo")
    env = scenario_environment("open-sky", 1.0)
    horizons = np.array([3600.0, 4 * 3600.0])
    result = {}
    for locked in (1800, 4 * 3600):
        steps = locked + 4 * 3600 + 1
        root = root_seed(7)
        free, _ = _free_phase(osc, steps, 6, root)
        rx = simulate_receivers(env, locked, 2, child_seed(root, 1), trials=6)
        ref = np.full((6, steps), np.nan)
        ref[:, :locked] = np.nanmean(rx.pps_error_s + rx.epochs.qerr_s, axis=1)
        run = close_loop(make_controller(DEFAULT_CONTROLLER, osc, env, 2, Dac.for_oscillator(osc)), free, ref)
        ours = np.sqrt(np.mean(holdover_error(run.phase_s, locked, horizons) ** 2, axis=0))
        limit, _ = clairvoyant_holdover_error(free, locked, horizons, osc.drift_per_s)
        result[locked] = (ours, np.sqrt(np.mean(limit**2, axis=0)))
    for ours, limit in result.values():
        assert np.all(ours >= 0.8 * limit)  # no controller beats the clairvoyant predictor (scatter of 6 trials)
    assert result[4 * 3600][0][-1] < result[1800][0][-1]  # a longer lock learns frequency and drift better

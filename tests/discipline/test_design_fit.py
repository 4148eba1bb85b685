"""The loop designed from data: the noise fit against known truth, and the fitted default against the bound
when the data sheets are wrong."""

import numpy as np
import pytest

from chronofuse.analysis.montecarlo import mean_square_per_trial, ratio_ci
from chronofuse.discipline.bound import clairvoyant_servo
from chronofuse.discipline.chain import ChainConfig, discipline_run
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.noise_fit import fit_loop_noise
from chronofuse.experiments.gnssdo import DEFAULT_CONTROLLER, _free_phase, make_controller, scenario_environment, te_window
from chronofuse.experiments.gnssdo_design import fitted_controller, mismatched
from chronofuse.models.noise import gauss_markov
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.seeding import child_seed, root_seed


def test_the_noise_fit_recovers_white_noise_and_two_gauss_markov_errors_drawn_with_known_values():
    rng = np.random.default_rng(4)
    n = 86_400
    white, mp, wd = 2e-9, (3e-9, 15.0), (3e-9, 1500.0)
    hm2 = 4e-27
    y = np.cumsum(np.sqrt(2 * np.pi**2 * hm2) * rng.standard_normal(n))  # random-walk FM
    x = np.cumsum(y)
    e = (white * rng.standard_normal(n) + gauss_markov(rng.standard_normal(n + 1), mp[0], mp[1], 1.0)
         + gauss_markov(rng.standard_normal(n + 1), wd[0], wd[1], 1.0))
    f = fit_loop_noise(x - e)
    assert abs(f.sigma_s / white - 1) < 0.1
    sigma, tau = max(f.gauss_markov, key=lambda p: p[0])  # the multipath
    assert abs(sigma / mp[0] - 1) < 0.15 and abs(tau / mp[1] - 1) < 0.3
    # The slow wander is not told apart from random-walk FM in a day: it comes out as h-2 (measured 6x),
    # which is what the loop needs to know, both being what it cannot average away.
    assert 1.0 < f.hm2 / hm2 < 20


def test_outliers_and_short_gaps_do_not_turn_the_white_noise_into_random_walk_fm():
    rng = np.random.default_rng(5)
    n = 40_000
    z = 2e-9 * rng.standard_normal(n) + gauss_markov(rng.standard_normal(n + 1), 3e-9, 15.0, 1.0)
    clean = fit_loop_noise(z)
    dirty = z.copy()
    hit = rng.random(n) < 0.02
    dirty[hit] += 300e-9 * rng.standard_normal(hit.sum())
    dirty[rng.random(n) < 0.01] = np.nan
    f = fit_loop_noise(dirty)
    assert f.hm2 < 10 * clean.hm2 + 1e-28
    assert abs(clean.sigma_s / 2e-9 - 1) < 0.1
    assert abs(f.sigma_s / 2e-9 - 1) < 0.3  # measured 27 % high; the rest shows as a spurious 3 s term


@pytest.fixture(scope="module")
def open_sky():
    osc = preset("ocxo")
    steps, trials = 43_200, 6  # 3 left the paired interval too wide once the yardstick knew the aging
    env = scenario_environment("open-sky", steps)
    root = root_seed(3)
    free, _ = _free_phase(osc, steps, trials, root)
    rx = simulate_receivers(env, steps, 3, child_seed(root, 1), trials=trials)
    dac = Dac.for_oscillator(osc)

    def ms(servo):
        run = discipline_run(servo, free, rx.pps_error_s, rx.epochs, ChainConfig())
        return mean_square_per_trial(run.phase_s, te_window(np.isfinite(run.reference_error_s)))

    return osc, env, dac, root, ms, ms(clairvoyant_servo(osc, env, 3, dac))


@pytest.mark.slow
def test_the_fitted_default_is_within_115_percent_of_the_bound_in_open_sky(open_sky):
    osc, env, dac, root, ms, best = open_sky
    servo, how = fitted_controller(DEFAULT_CONTROLLER, osc, env, 3, dac, root)
    assert how.startswith("fit")
    assert ratio_ci(ms(servo), best)[2] <= 1.15


@pytest.mark.slow
def test_with_data_sheets_off_10x_in_h_minus_2_and_3x_in_receiver_noise_the_fitted_default_stays_within_125_percent(
        open_sky):
    osc, env, dac, root, ms, best = open_sky
    wrong_osc, wrong_env = mismatched(osc, env, 10.0, 3.0)
    servo, _ = fitted_controller(DEFAULT_CONTROLLER, osc, env, 3, dac, root, design_osc=wrong_osc,
                                 design_env=wrong_env)
    assert ratio_ci(ms(servo), best)[2] <= 1.25
    # the negative: the GNSSDO paper's PI preset is not within 1.25x
    assert ratio_ci(ms(make_controller("pi", osc, env, 3, dac)), best)[1] > 1.25


def test_a_fitted_design_kept_for_its_setup_is_the_one_fitted_anew_and_a_new_seed_fits_anew():
    import dataclasses

    import chronofuse.experiments.gnssdo_design as design

    osc, env = preset("ocxo"), scenario_environment("open-sky", 7200)
    dac = Dac.for_oscillator(osc)

    def fit(env=env, seed=3):
        servo, how = fitted_controller("kalman", osc, env, 3, dac, root_seed(seed), calibration_s=7200)
        assert how.startswith("fit")
        return servo

    design._FITTED.clear()
    first = fit()
    # The same record whatever the run's events (the calibration is taken in ordinary conditions): kept.
    again = fit(env=dataclasses.replace(env, jamming_start_s=600.0, jamming_duration_s=600.0))
    assert len(design._FITTED) == 1 and again is not first and again.design() == first.design()
    again.reset()  # a caller's copy: using it leaves the kept one alone
    design._FITTED.clear()
    assert fit().design() == first.design()
    # Another seed is another calibration record: fitted anew, and it differs.
    assert fit(seed=4).design() != first.design()
    assert len(design._FITTED) == 2

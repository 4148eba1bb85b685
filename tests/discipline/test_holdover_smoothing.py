"""Holdover error and its physical limit; RTS smoothing of a recorded run."""

import numpy as np
import pytest

from chronofuse.discipline.holdover import clairvoyant_holdover_error, holdover_error
from chronofuse.discipline.kalman import KalmanServo
from chronofuse.discipline.loop import close_loop
from chronofuse.discipline.smoothing import control_phase_s, smooth_run
from chronofuse.models.clock import two_state_clock_phase_s
from chronofuse.models.oscillator import PowerLaw


def test_holdover_error_is_the_phase_walked_since_entry():
    x = np.array([[0.0, 1.0, 3.0, 6.0, 10.0]])
    assert holdover_error(x, 1, np.array([1.0, 3.0])).tolist() == [[2.0, 9.0]]
    with pytest.raises(ValueError, match="horizons_s"):
        holdover_error(x, 1, np.array([10.0]))


def test_the_clairvoyant_predictor_is_exact_for_a_noise_free_drifting_clock():
    t = np.arange(2000.0)
    d = 3e-14
    x = (1e-7 + 2e-10 * t + 0.5 * d * t**2)[None, :]
    err, _ = clairvoyant_holdover_error(x, 1000, np.array([100.0, 900.0]), d)
    assert np.abs(err).max() < 1e-18


def test_the_clairvoyant_error_of_white_fm_is_the_phase_random_walk_plus_the_window_frequency_error():
    # White FM only (q1 = h0 / 2): the phase after entry random-walks, variance q1 h, and the frequency
    # estimated over an m-second window errs by variance q1 / m, adding q1 h^2 / m: the rms is
    # sqrt(q1 h (1 + h / m)).
    h0, trials, steps = 1e-22, 400, 3000
    rng = np.random.default_rng(0)
    x = two_state_clock_phase_s(rng.standard_normal((trials, steps)), np.zeros((trials, steps)),
                                np.zeros((trials, steps)), h0=h0, hm2=0.0, dt_s=1.0)
    err, chosen = clairvoyant_holdover_error(x, 2000, np.array([900.0]), 0.0)
    assert chosen[0] >= 512  # a long window: white FM averages out
    theory = np.sqrt(h0 / 2 * 900 * (1 + 900 / chosen[0]))
    assert np.sqrt(np.mean(err**2)) == pytest.approx(theory, rel=0.1)


def test_rts_smoothing_removes_the_filters_lag_on_a_recorded_run():
    rng = np.random.default_rng(3)
    trials, steps = 4, 3000
    h = PowerLaw(h0=2e-22, hm2=1e-30)
    x_free = two_state_clock_phase_s(rng.standard_normal((trials, steps)), rng.standard_normal((trials, steps)),
                                     rng.standard_normal((trials, steps)), h0=h.h0, hm2=h.hm2, dt_s=1.0)
    x_free = x_free + 5e-10 * np.arange(steps)
    sigma = 10e-9
    servo = KalmanServo(h, sigma, steer_s=200.0, tau_match_s=100.0)
    loop = close_loop(servo, x_free, sigma * rng.standard_normal((trials, steps)))
    sm = smooth_run(loop, servo)
    truth = loop.phase_s[:, 200:]
    rms_f = np.sqrt(np.mean((sm.filtered_s[:, 200:] - truth) ** 2))
    rms_s = np.sqrt(np.mean((sm.smoothed_s[:, 200:] - truth) ** 2))
    # the filter replayed offline is the servo's own estimate
    np.testing.assert_allclose(sm.filtered_s[:, 1:], loop.offset_estimate_s[:, 1:], rtol=0, atol=1e-12)
    assert rms_s < 0.8 * rms_f
    # and the smoother's own error bar is honest (within 25 %)
    assert rms_s == pytest.approx(np.sqrt(np.mean(sm.smoothed_sigma_s[:, 200:] ** 2)), rel=0.25)


def test_the_control_phase_adds_steps_and_corrections_before_each_second():
    from chronofuse.discipline.loop import LoopRun

    z = np.zeros((1, 4))
    loop = LoopRun(z, z, np.array([[1e-9, 1e-9, 0.0, 0.0]]), np.array([[0.0, 5e-9, 0.0, 0.0]]), z, z,
                   np.ones((1, 4), bool), np.zeros((1, 4), bool), 1.0)
    np.testing.assert_allclose(control_phase_s(loop), [[0.0, 1e-9, 7e-9, 7e-9]])

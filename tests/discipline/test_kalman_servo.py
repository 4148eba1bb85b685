"""Kalman servos: the estimation core with a control input, holdover, and the robust variants' rules."""


import numpy as np
import pytest

from chronofuse.analysis.theory import adev_theory
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.kalman import KalmanServo, effective_clock_noise
from chronofuse.discipline.kalman_adaptive import AdaptiveKalmanServo
from chronofuse.discipline.kalman_gated import GatedKalmanServo
from chronofuse.discipline.kalman_huber import HuberKalmanServo
from chronofuse.discipline.loop import close_loop
from chronofuse.estimation.filter import KalmanFilter
from chronofuse.models.oscillator import PowerLaw
from chronofuse.models.oscillator_presets import preset

OCXO = preset("ocxo")
SIGMA = 8e-9


def _ramp(steps, y0=2e-10, x0=0.0, drift=0.0, trials=1, noise=0.0, seed=0):
    t = np.arange(steps, dtype=float)
    x = x0 + y0 * t + 0.5 * drift * t**2
    rng = np.random.default_rng(seed)
    return np.broadcast_to(x, (trials, steps)) + noise * rng.standard_normal((trials, steps))


@pytest.mark.parametrize("tau", [10.0, 100.0, 1000.0])
def test_folding_flicker_keeps_the_allan_variance_at_the_matching_tau(tau):
    h0, hm2 = effective_clock_noise(OCXO.h, tau)
    two_state = PowerLaw(h0=h0, hm2=hm2)
    full = PowerLaw(h0=OCXO.h.h0, hm1=OCXO.h.hm1, hm2=OCXO.h.hm2)
    assert adev_theory(two_state, np.array([tau]), 1.0)[0] == pytest.approx(adev_theory(full, np.array([tau]), 1.0)[0],
                                                                          rel=1e-12)


def test_the_servos_estimate_is_the_estimation_layers_filter_on_the_uncontrolled_offsets():
    # A linear filter with a known input: its estimate equals the plain filter's on the offsets with the
    # input's effect removed, plus that effect (second method: estimation.filter.KalmanFilter).
    rng = np.random.default_rng(4)
    steps = 400
    servo = KalmanServo(OCXO.h, SIGMA, step_threshold_s=None)
    x_free = _ramp(steps, 1e-9) + SIGMA * rng.standard_normal((1, steps))
    loop = close_loop(servo, x_free, np.zeros(steps))
    c = np.concatenate([[0.0], np.cumsum(loop.freq_adj[0, :-1])])  # dt = 1
    F, Q, H = servo.model()
    P0 = np.diag([1e-7**2, 1e-8**2, 1e-14**2])
    kf = KalmanFilter(F, Q, H, np.array([[SIGMA**2]]), np.zeros(3), P0).fit()
    ref = kf.run((loop.offset_s[0] - c)[None, :, None])
    np.testing.assert_allclose(loop.offset_estimate_s[0], ref.x[0, :, 0] + c, rtol=0, atol=1e-15)


def test_the_kalman_servo_learns_frequency_and_drift_and_holds_them_in_holdover():
    steps, drift = 20_000, 1e-14
    x_free = _ramp(steps, y0=5e-10, drift=drift)
    ref = np.zeros(steps)
    ref[15_000:] = np.nan  # holdover for the last 5000 s
    servo = KalmanServo(PowerLaw(h0=1e-24, hm2=1e-33), 1e-9, drift_psd_per_s3=1e-38, steer_s=100.0,
                        step_threshold_s=None)
    run = close_loop(servo, x_free, ref)
    err_holdover = abs(run.phase_s[0, -1] - run.phase_s[0, 15_000])
    free_err = 0.5 * drift * 5000**2  # what drift alone would add with the frequency held perfectly
    assert not run.used[0, 15_000:].any()
    assert err_holdover < 0.01 * free_err


def test_streaming_equals_batch_for_every_kalman_servo():
    rng = np.random.default_rng(7)
    z = SIGMA * rng.standard_normal((3, 150)) + 1e-9 * np.arange(150)
    z[:, 30:40] = np.nan
    z[0, 80] = 3e-7
    z[2, 90:] += 2e-6  # a step beyond the threshold
    dac = Dac.for_oscillator(OCXO)
    for cls in (KalmanServo, AdaptiveKalmanServo, GatedKalmanServo, HuberKalmanServo):
        servo = cls(OCXO.h, SIGMA, dac=dac)
        batch = servo.run(z)
        for i in range(3):
            servo.reset()
            outs = [servo.step(v) for v in z[i]]
            for field in ("freq_adj", "phase_step_s", "offset_estimate_s", "innovation_s", "used"):
                got = np.array([getattr(o, field) for o in outs])
                assert np.array_equal(getattr(batch, field)[i], got, equal_nan=got.dtype != bool), (cls.name, field, i)


def test_the_adaptive_filter_scales_r_by_lambda_max_only_when_the_innovations_are_wild():
    servo = AdaptiveKalmanServo(OCXO.h, SIGMA, window=5, lambda_min=1.0, lambda_max=10.0)
    state = servo.initial_state(2)
    state["window"] = np.array([[1e-9, -1e-9, 2e-9, 0.0, 1e-9], [5e-8, -6e-8, 4e-8, -5e-8, 6e-8]])
    r = SIGMA**2
    r_k, accept, _ = servo._weigh(state, np.array([0.0, 0.0]), np.zeros(2), r, np.ones(2, bool))
    assert r_k.tolist() == [r, 10.0 * r] and accept.all()


def test_the_ar1_drift_option_decays_the_drift_state():
    servo = AdaptiveKalmanServo(OCXO.h, SIGMA, drift_ar1=0.99)
    F, _, _ = servo.model()
    assert F[2, 2] == 0.99 and F[0, 1] == 1.0


def test_the_gate_rejects_an_outlier_but_accepts_a_persistent_step():
    steps = 400
    x_free = _ramp(steps, 0.0, noise=SIGMA, seed=1)
    ref = np.zeros(steps)
    ref[200] = 500e-9  # one outlier
    ref[300:] = 300e-9  # a persistent step, below the jam-sync threshold
    servo = GatedKalmanServo(OCXO.h, SIGMA, max_rejects=20, step_threshold_s=None)
    run = close_loop(servo, x_free, ref)
    assert not run.used[0, 200] and run.used[0, 199] and run.used[0, 201]
    assert not run.used[0, 300:320].any() and run.used[0, 320]


def test_the_huber_update_downweights_large_innovations_only():
    servo = HuberKalmanServo(OCXO.h, SIGMA, huber_c=1.5)
    state = servo.initial_state(3)
    s0 = np.zeros(3)
    r = SIGMA**2
    e = np.array([0.5, 1.5, 6.0]) * SIGMA
    r_k, _, _ = servo._weigh(state, e, s0, r, np.ones(3, bool))
    np.testing.assert_allclose(r_k, [r, r, r * 6.0 / 1.5])


def test_a_kalman_servo_is_refused_with_a_nonpositive_measurement_sigma():
    with pytest.raises(ValueError, match="measurement_sigma_s"):
        KalmanServo(OCXO.h, 0.0).initial_state(1)

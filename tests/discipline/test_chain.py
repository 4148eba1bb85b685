"""The chain: qErr settings checked on simulated truth, integrity alarms to holdover, the one library call."""

import dataclasses

import numpy as np
import pytest

from chronofuse.analysis.stability import oadev
from chronofuse.analysis.theory import corrected_pps_adev
from chronofuse.discipline.chain import ChainConfig, corrected_pps_error, discipline_run
from chronofuse.discipline.kalman_gated import GatedKalmanServo
from chronofuse.discipline.states import Reason, State
from chronofuse.models.oscillator import simulate_oscillator
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers


def _rms(a):
    return float(np.sqrt(np.nanmean(a**2)))


def test_the_u_blox_qerr_sign_removes_the_sawtooth_and_the_other_sign_doubles_it():
    rx = simulate_receivers("open-sky", 20_000, 1, seed=1)
    right = corrected_pps_error(rx.pps_error_s, rx.epochs.qerr_s, +1, 0)[0, 0]
    wrong = corrected_pps_error(rx.pps_error_s, rx.epochs.qerr_s, -1, 0)[0, 0]
    taus = np.array([1.0, 2.0, 4.0])
    theory = corrected_pps_adev(rx.environment.model, taus)  # the sawtooth-free 1PPS (analysis.theory)
    np.testing.assert_allclose(oadev(right, 1.0, taus).dev, theory, rtol=0.1)
    # the wrong sign adds the sawtooth twice: uniform over two 48 MHz ticks, rms 2 T / sqrt(12)
    assert _rms(wrong - right) == pytest.approx(2 / 48e6 / np.sqrt(12), rel=0.05)
    assert np.all(oadev(wrong, 1.0, taus).dev > 1.5 * theory)


def test_pairing_qerr_with_the_wrong_pulse_leaves_the_sawtooth_in():
    rx = simulate_receivers("open-sky", 3000, 1, seed=2)
    aligned = corrected_pps_error(rx.pps_error_s, rx.epochs.qerr_s, +1, 0)
    shifted = corrected_pps_error(rx.pps_error_s, rx.epochs.qerr_s, +1, 1)
    # the simulated messages are already aligned with their pulses: lag 1 mixes two sawtooth values
    assert _rms(np.diff(shifted)) > 1.5 * _rms(np.diff(aligned))


def _run(epochs, pps, steps, trials=1):
    osc = preset("ocxo")
    free = simulate_oscillator(osc, steps, 1.0, seed=3, trials=trials).x_s
    servo = GatedKalmanServo(osc.h, 20e-9)
    return discipline_run(servo, free, pps, epochs, ChainConfig(integrity_pfa=1e-6, alarm_hold_s=300.0))


def test_an_integrity_alarm_on_every_receiver_puts_the_gpsdo_in_holdover_and_says_why():
    steps = 4000
    rx = simulate_receivers("open-sky", steps, 2, seed=4)
    bias = np.array(rx.epochs.clock_bias_s)
    bias[..., 2500:] += 3e-6  # every receiver's clock bias jumps 3 us: a detector alarm
    epochs = dataclasses.replace(rx.epochs, clock_bias_s=bias)
    run = _run(epochs, rx.pps_error_s, steps)
    assert run.alarm[0, :, 2500:2510].any(axis=1).all()
    k = int(np.flatnonzero(run.states.reason[0] == Reason.INTEGRITY_ALARM)[0])
    assert 2500 <= k <= 2505 and run.states.state[0, k] == State.HOLDOVER
    assert not run.loop.used[0, k:k + 200].any()  # the excluded receivers no longer steer


def test_no_alarm_on_clean_receivers_keeps_the_gpsdo_locked():
    steps = 4000
    rx = simulate_receivers("open-sky", steps, 2, seed=5)
    run = _run(rx.epochs, rx.pps_error_s, steps)
    assert run.states.seconds_in()["holdover"] == 0.0
    assert run.states.state[0, -1] == State.LOCKED

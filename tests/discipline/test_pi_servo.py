"""PI servo and the closed loop: the source paper's preset, design from bandwidth, streaming == batch, null baseline."""

import math

import numpy as np
import pytest
from scipy.signal import lfilter

from chronofuse.discipline.dac import Dac
from chronofuse.discipline.loop import close_loop
from chronofuse.discipline.pi import PiServo
from chronofuse.discipline.null import NullServo


def _closed_loop_theory(x_free, kp, ki):
    # Independent second method: the error recursion x_{k+1} = (2 - kp - ki) x_k - (1 - kp) x_{k-1}
    # + second difference of the free phase, i.e. S(z) = (z - 1)^2 / (z^2 - (2 - kp - ki) z + 1 - kp).
    return lfilter([1.0, -2.0, 1.0], [1.0, -(2.0 - kp - ki), 1.0 - kp], x_free, axis=-1)


def test_the_closed_loop_equals_the_pi_loops_transfer_function():
    rng = np.random.default_rng(0)
    y = 1e-9 + 1e-11 * rng.standard_normal((3, 500))
    x_free = np.concatenate([np.zeros((3, 1)), np.cumsum(y, axis=1)[:, :-1]], axis=1)
    for kp, ki in ((0.5, 0.1), (0.05, 0.001)):
        run = close_loop(PiServo(kp, ki, step_threshold_s=None), x_free, np.zeros(500))
        np.testing.assert_allclose(run.phase_s, _closed_loop_theory(x_free, kp, ki), rtol=0, atol=1e-18)


def test_the_seed_preset_is_a_three_second_loop_with_damping_079():
    servo = PiServo()
    assert (servo.kp, servo.ki) == (0.5, 0.1)
    roots = np.roots([1.0, -(2 - 0.5 - 0.1), 1 - 0.5])
    assert np.all(np.abs(roots) < 1)  # stable
    assert servo.time_constant_s == pytest.approx(1 / math.sqrt(0.1))
    designed = PiServo.from_bandwidth(math.sqrt(0.1) / (2 * math.pi), damping=0.5 / (2 * math.sqrt(0.1)))
    assert designed.kp == pytest.approx(0.5) and designed.ki == pytest.approx(0.1)


def test_a_pi_designed_from_bandwidth_has_the_poles_of_the_continuous_loop():
    fn, zeta = 1e-4, 0.7
    servo = PiServo.from_bandwidth(fn, zeta)
    wn = 2 * math.pi * fn
    poles = np.roots([1.0, -(2 - servo.kp - servo.ki), 1 - servo.kp])
    s_poles = np.log(poles.astype(complex))  # z = exp(s dt), dt = 1
    expected = np.roots([1.0, 2 * zeta * wn, wn**2])
    np.testing.assert_allclose(np.sort_complex(s_poles), np.sort_complex(expected), rtol=1e-3)


def test_a_constant_frequency_offset_is_removed_and_the_integral_learns_it():
    y0 = 3e-9
    x_free = y0 * np.arange(3000.0)[None, :]
    run = close_loop(PiServo.from_bandwidth(0.01, 1.0, step_threshold_s=None), x_free, np.zeros(3000))
    assert abs(run.phase_s[0, -1]) < 1e-15
    assert run.freq_adj[0, -1] == pytest.approx(-y0, rel=1e-9)


def test_without_a_reference_the_pi_holds_its_last_frequency():
    servo = PiServo(0.2, 0.01)
    for z in (1e-8, 2e-8, -1e-8):
        servo.step(z)
    held = servo.step(None)
    assert not held.used
    integral = 0.0
    for z in (0.0, 2e-8, -1e-8):  # the first sample jam-syncs the 1PPS: it enters as 0
        integral = integral + 0.01 * z / 1.0
    assert servo.step(float("nan")).freq_adj == held.freq_adj == -(0.0 + integral)


def test_streaming_and_batch_replay_agree_to_the_last_bit():
    rng = np.random.default_rng(3)
    z = 1e-8 * rng.standard_normal((4, 300))
    z[:, 40:60] = np.nan
    z[1, 100] = 5e-6  # a step
    dac = Dac(bits=12, range_V=5.0, efc_gain_per_V=8e-8)
    for servo in (PiServo(dac=dac), PiServo.from_bandwidth(0.002), NullServo()):
        batch = servo.run(z)
        for i in range(z.shape[0]):
            servo.reset()
            outs = [servo.step(v) for v in z[i]]
            assert np.array_equal(batch.freq_adj[i], [o.freq_adj for o in outs])
            assert np.array_equal(batch.phase_step_s[i], [o.phase_step_s for o in outs])
            assert np.array_equal(batch.used[i], [o.used for o in outs])
            assert np.array_equal(batch.near_rail[i], [o.near_rail for o in outs])


def test_batch_replay_does_not_change_the_servo_and_returns_read_only_arrays():
    servo = PiServo()
    servo.step(1e-8)
    before = {k: v.copy() for k, v in servo._state.items()}
    result = servo.run(np.zeros((2, 10)))
    assert all(np.array_equal(before[k], servo._state[k]) for k in before)
    with pytest.raises(ValueError):
        result.freq_adj[0, 0] = 1.0


def test_the_first_sample_jam_syncs_the_1pps_and_a_large_offset_after_a_gap_steps_it_again():
    x_free = np.full((1, 200), 3e-3)  # 3 ms off, no frequency error
    ref = np.zeros(200)
    ref[50] = 5e-6  # an outlier within a continuous reference: no step
    ref[100:110] = np.nan
    ref[110:] = -4e-6  # back after a gap, 4 us away: step
    run = close_loop(PiServo(step_threshold_s=1e-6), x_free, ref)
    assert run.phase_step_s[0, 0] == pytest.approx(-3e-3)
    assert np.all(np.abs(run.phase_s[0, 1:50]) < 1e-15)
    assert run.phase_step_s[0, 50] == 0.0
    assert np.flatnonzero(run.phase_step_s[0]).tolist() == [0, 110]
    assert run.phase_step_s[0, 110] == pytest.approx(-(run.phase_s[0, 110] + 4e-6), rel=1e-9)


def test_the_null_servo_leaves_the_oscillator_free_running():
    rng = np.random.default_rng(1)
    x_free = np.cumsum(1e-11 * rng.standard_normal((2, 100)), axis=1)
    run = close_loop(NullServo(), x_free, 1e-8 * rng.standard_normal(100))
    assert np.array_equal(run.phase_s, x_free)
    assert not run.freq_adj.any()


def test_dac_quantization_in_the_loop_applies_only_whole_lsbs():
    dac = Dac(bits=10, range_V=5.0, efc_gain_per_V=8e-8)
    x_free = 1e-9 * np.arange(400.0)[None, :]
    run = close_loop(PiServo.from_bandwidth(0.01, dac=dac, step_threshold_s=None), x_free, np.zeros(400))
    codes = run.freq_adj / dac.frequency_step
    np.testing.assert_allclose(codes, np.rint(codes), atol=1e-9)
    # the residual phase error is bounded by what one LSB accumulates over the loop's time constant
    assert np.abs(run.phase_s[0, 300:]).max() < dac.frequency_step * 100


def test_a_multiphase_counter_in_the_loop_quantizes_offsets_to_its_resolution():
    from chronofuse.discipline.counter import MultiPhaseCounter

    counter = MultiPhaseCounter()
    x_free = 1e-10 * np.arange(300.0)[None, :] + 1e-7
    run = close_loop(PiServo.from_bandwidth(0.01, step_threshold_s=None), x_free, np.zeros(300), counter=counter, seed=2)
    err = run.offset_s - run.phase_s
    assert np.all(np.abs(err) <= counter.resolution_s * 1.0001)
    assert np.sqrt(np.mean(err**2)) == pytest.approx(counter.resolution_s / math.sqrt(6) * 4 / 4, rel=0.25)


@pytest.mark.parametrize("damping", [0.5, 0.707, 1.0, 2.0])
def test_the_highest_designable_bandwidth_is_the_discrete_loops_stability_edge(damping):
    # The closed loop's poles, z^2 - (2 - kp - ki) z + (1 - kp) = 0, leave the unit circle at max_natural_hz:
    # an independent check of the bound by the poles themselves, just inside and just outside it.
    from chronofuse.discipline.pi import PiServoConfig, max_natural_hz
    from chronofuse.validation import InputError

    edge = max_natural_hz(damping)

    def radius(natural_hz):
        u = 2 * math.pi * natural_hz
        kp, ki = 2 * damping * u, u * u
        return max(abs(np.roots([1.0, -(2 - kp - ki), 1 - kp])))

    assert radius(0.999 * edge) < 1.0 < radius(1.001 * edge)
    PiServo.from_bandwidth(0.999 * edge, damping)
    with pytest.raises(InputError, match="natural_hz"):
        PiServo.from_bandwidth(1.001 * edge, damping)
    with pytest.raises(ValueError, match="unstable"):
        PiServoConfig(natural_hz=1.001 * edge, damping=damping)
    with pytest.raises(ValueError, match="2 kp \\+ ki"):
        PiServoConfig(kp=1.9, ki=0.3)

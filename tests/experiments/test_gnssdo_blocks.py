"""The gnssdo trials in blocks on several processes give the numbers of one run of all of them.

Oracles: the unblocked path (``evaluate(simulate_gnssdo(...))``, every trial's seconds at once); each model's
own run of more trials (a block's trial ``i`` is trial ``first_trial + i``); one :func:`discipline_run` per servo
(for the shared pre-loop stages); the plain numpy Riccati recursion (for the compiled bound).
"""

import math

import numpy as np
import pytest

import chronofuse.experiments.gnssdo as g
from chronofuse.discipline.bound import _riccati, clairvoyant_servo
from chronofuse.discipline.chain import ChainConfig, discipline_run, discipline_runs
from chronofuse.discipline.dac import Dac
from chronofuse.models.oscillator import simulate_oscillator
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers


def _close(a, b, path=""):
    """Every number of two summaries equal within 1e-9 (relative), every other value equal."""
    if isinstance(a, dict):
        assert set(a) == set(b), path
        for k in a:
            _close(a[k], b[k], f"{path}/{k}")
    elif isinstance(a, (list, tuple, np.ndarray)):
        assert len(a) == len(b), path
        for i, (u, v) in enumerate(zip(a, b)):
            _close(u, v, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        if a is None or b is None:
            assert a is b, path
        elif math.isnan(a):
            assert math.isnan(b), path
        else:
            assert a == pytest.approx(b, rel=1e-9, abs=1e-12), path
    else:
        assert a == b, path


def test_a_block_of_trials_is_those_trials_of_the_whole_run():
    osc = preset("ocxo")
    whole = simulate_oscillator(osc, 600.0, 1.0, 7, trials=4)
    part = simulate_oscillator(osc, 600.0, 1.0, 7, trials=2, first_trial=2)
    assert np.array_equal(whole.x_s[2:], part.x_s)
    rx = simulate_receivers("urban-canyon", 600, 3, 11, trials=4)
    rx_part = simulate_receivers("urban-canyon", 600, 3, 11, trials=1, first_trial=3)
    assert np.array_equal(rx.pps_error_s[3:], rx_part.pps_error_s, equal_nan=True)
    free, _ = g._free_phase(osc, 600, 4, np.random.SeedSequence(5))
    free_part, _ = g._free_phase(osc, 600, 1, np.random.SeedSequence(5), first_trial=1)
    assert np.array_equal(free[1:2], free_part)
    # a different block is different trials
    assert not np.array_equal(whole.x_s[:2], part.x_s)


def test_the_shared_pre_loop_stages_give_each_servo_its_own_run():
    osc = preset("ocxo")
    env = g.scenario_environment("urban-canyon", 3600)
    root = np.random.SeedSequence(3)
    free, _ = g._free_phase(osc, 3600, 2, root)
    rx = simulate_receivers(env, 3600, 3, 4, trials=2)
    dac = Dac.for_oscillator(osc)
    config = ChainConfig(receiver_monitor=g.plausibility_monitors(osc, env, 3)[0], states=g.state_config(osc))
    servos = (g.make_controller("gated-kalman", osc, env, 3, dac), g.make_controller("pi", osc, env, 3, dac))
    together = discipline_runs(servos, free, rx.pps_error_s, rx.epochs, config)
    for servo, run in zip(servos, together):
        alone = discipline_run(servo, free, rx.pps_error_s, rx.epochs, config)
        assert np.array_equal(alone.phase_s, run.phase_s)
        assert np.array_equal(alone.states.state, run.states.state)
        assert np.array_equal(alone.reference_error_s, run.reference_error_s, equal_nan=True)
    assert not np.array_equal(together[0].phase_s, together[1].phase_s)  # two servos, two loops
    with pytest.raises(TypeError):
        discipline_runs((), free, rx.pps_error_s, rx.epochs, config)


def test_the_compiled_bound_is_the_numpy_riccati_recursion():
    servo = clairvoyant_servo(preset("ocxo"), g.scenario_environment("open-sky", 1.0), 3)
    F, Q, H = servo.model()
    r = servo.design()[1] ** 2
    P0 = servo.prior_covariance()
    mask = np.random.default_rng(2).random(3000) > 0.05
    mask[:7] = False
    mask[1000:1400] = False
    expected = np.full(mask.size, np.inf)
    P = None
    for k in range(mask.size):
        if P is None:
            if not mask[k]:
                continue
            P = P0.copy()
        expected[k] = P[0, 0]
        if mask[k]:
            Ph = P @ H[0]
            P = P - np.outer(Ph, Ph) / (H[0] @ Ph + r)
        P = F @ P @ F.T + Q
    got = _riccati(F, Q, H, r, P0, mask)
    assert np.array_equal(np.isfinite(got), np.isfinite(expected))
    fin = np.isfinite(expected)
    np.testing.assert_allclose(got[fin], expected[fin], rtol=1e-10)


@pytest.mark.parametrize("scenario", ["outage", "urban-canyon"])
def test_trials_in_blocks_on_two_processes_summarise_as_one_run(monkeypatch, scenario):
    setup = g.GnssdoSetup(scenario=scenario, duration_s=3600, trials=3, seed=4, design="datasheet")
    one = g.evaluate(g.simulate_gnssdo(setup))
    monkeypatch.setattr(g, "BLOCK_TRIALS", 1)
    blocks = g.run_gnssdo(setup, workers=2)
    _close(one, blocks)
    assert blocks["trials"] == 3 and blocks["state_changes_trial0"] == one["state_changes_trial0"]
    # a block of other trials is not the same run
    other = g.summarize(g.design_gnssdo(setup), g.trial_stats(g.simulate_trials(g.design_gnssdo(setup), 1, 2)))
    assert other["time_error_rms_ns"] != pytest.approx(one["time_error_rms_ns"], rel=1e-6)


def test_workers_are_refused_by_name():
    with pytest.raises(Exception, match="workers"):
        g._workers(0, 3)

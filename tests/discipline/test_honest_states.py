"""LOCKED is a claim about the truth: never made with |TE| at or above the lock threshold, on a DAC rail, or
with no usable receiver, whatever the oscillator preset and the scenario."""

import dataclasses

import numpy as np
import pytest

from chronofuse.discipline.chain import ChainConfig, discipline_run
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.states import Reason, State
from chronofuse.experiments.gnssdo import (SCENARIOS, GnssdoSetup, evaluate, make_controller, scenario_environment,
                                           simulate_gnssdo, state_config)
from chronofuse.models.oscillator import simulate_oscillator
from chronofuse.models.oscillator_presets import PRESETS, preset
from chronofuse.models.receiver import simulate_receivers

THRESHOLD_S = state_config(preset("ocxo")).lock_threshold_s


def _combinations():
    # Every preset under the data-sheet design (the state machine is under test, not the loop's design),
    # and the default preset under the fitted default design, which locks for longer.
    for scenario in SCENARIOS:
        for oscillator in sorted(PRESETS):
            if (scenario, oscillator) == ("spoofing", "tcxo"):
                # The TCXO's own noise puts the slowest drag it can refuse before 100 ns at 9.07 ns/s
                # (DragMonitor.slowest_rate, docs/gnssdo/spoofing.md); the scenario drags at 2 ns/s.
                yield pytest.param(scenario, oscillator, "datasheet", marks=pytest.mark.xfail(strict=True, reason=(
                    "a 2 ns/s drag is below the 9.07 ns/s the TCXO can tell from its own noise before 100 ns")))
            else:
                yield scenario, oscillator, "datasheet"
        yield scenario, "ocxo", "fit"
    # The case that once failed (seed 5, trial 1, from 3140 s): one urban-canyon receiver left, erring +35..50 ns
    # for minutes, the TCXO running off at 3 ns/s: a single 10 s average lagged the offset (32 ns filtered, 65 ns
    # measured) and LOCKED stayed 6 s at a true 102-113 ns. Brown's lag-free level and the margin of two of
    # the fused reference's standard deviations (31 ns for that receiver) now end the claim in time.
    yield "urban-canyon", "tcxo", "fit"


@pytest.mark.slow
@pytest.mark.parametrize("scenario, oscillator, design", list(_combinations()))
def test_no_second_is_reported_locked_with_the_time_error_above_the_threshold(scenario, oscillator, design):
    sim = simulate_gnssdo(GnssdoSetup(scenario=scenario, oscillator=oscillator, duration_s=7200, trials=2, seed=5,
                                      design=design))
    run = sim["run"]
    locked = run.states.state == State.LOCKED
    assert not (locked & (np.abs(run.phase_s) >= THRESHOLD_S)).any()
    assert not (locked & run.loop.near_rail).any()
    assert evaluate(sim)["locked_over_threshold_seconds"] == 0.0


def _railed_run(frequency_offset: float):
    """An OCXO whose EFC pulls only +-3e-9, started ``frequency_offset`` off, disciplined in open sky."""
    osc = dataclasses.replace(preset("ocxo"), efc_gain_per_V=3e-9 / 2.5)
    dac = Dac.for_oscillator(osc)
    steps = 7200
    truth = simulate_oscillator(osc, float(steps), 1.0, 1, trials=2)
    free = truth.x_s + frequency_offset * truth.t_s
    env = scenario_environment("open-sky", steps)
    rx = simulate_receivers(env, steps, 3, 2, trials=2)
    servo = make_controller("gated-kalman", osc, env, 3, dac)
    return discipline_run(servo, free, rx.pps_error_s, rx.epochs, ChainConfig(states=state_config(osc)))


def test_a_loop_on_its_dac_rail_is_never_reported_locked():
    run = _railed_run(4e-9)  # outside the EFC's reach: the DAC saturates and the time error runs away
    assert run.loop.near_rail[:, 600:].all()
    assert np.abs(run.phase_s[:, -1]).min() > 1e-6
    assert not (run.states.state == State.LOCKED).any()


def test_the_same_loop_inside_its_range_locks_and_a_rail_reached_later_is_an_alarm_with_its_reason():
    run = _railed_run(1e-9)
    assert (run.states.state[:, -1] == State.LOCKED).all()
    # Now push it onto the rail after lock: the free oscillator jumps 3e-9 in frequency at 4000 s.
    osc = dataclasses.replace(preset("ocxo"), efc_gain_per_V=3e-9 / 2.5)
    steps = 7200
    truth = simulate_oscillator(osc, float(steps), 1.0, 1, trials=2)
    t = truth.t_s
    free = truth.x_s + 1e-9 * t + 3e-9 * np.maximum(t - 4000.0, 0.0)
    env = scenario_environment("open-sky", steps)
    rx = simulate_receivers(env, steps, 3, 2, trials=2)
    servo = make_controller("gated-kalman", osc, env, 3, Dac.for_oscillator(osc))
    run = discipline_run(servo, free, rx.pps_error_s, rx.epochs, ChainConfig(states=state_config(osc)))
    states, reasons = run.states.state, run.states.reason
    assert (states[:, 3999] == State.LOCKED).all()
    for i in range(2):
        k = 4000 + int(np.flatnonzero(states[i, 4000:] != State.LOCKED)[0])
        assert states[i, k] == State.ALARM
        assert reasons[i, k] in (Reason.DAC_RAIL, Reason.FREQUENCY_EXCURSION, Reason.TIME_ERROR_EXCURSION)
        assert np.abs(run.phase_s[i, :k]).max() < THRESHOLD_S
    assert not ((states == State.LOCKED) & run.loop.near_rail).any()


def test_with_no_usable_receiver_the_gnssdo_is_never_locked():
    setup = GnssdoSetup(scenario="open-sky", duration_s=3600, trials=2, outage_start_s=0.0, outage_s=3600.0,
                        design="datasheet")
    sim = simulate_gnssdo(setup)
    summary = evaluate(sim)
    assert summary["no_usable_receiver"]
    assert (sim["run"].states.state == State.FREE_RUN).all()
    assert summary["convergence_s"] is None


@pytest.mark.slow
@pytest.mark.parametrize("oscillator", ["ocxo", "rb", "csac"])
def test_the_predicted_holdover_sigma_is_the_holdover_error_the_gnssdo_then_makes(oscillator):
    # 16 trials locked for 2 h, then an hour of holdover: the rms of the time error accumulated over the hour
    # against the sigma the state machine predicted at the last locked second (horizon 1 h). With 16 trials the
    # rms is known to about 18 % (chi-square, 16 degrees of freedom): the ratio is asked within 0.6..1.5.
    setup = GnssdoSetup(scenario="open-sky", oscillator=oscillator, duration_s=14_400, trials=16, seed=8,
                        outage_start_s=7200.0, outage_s=3600.0, design="datasheet")
    run = simulate_gnssdo(setup)["run"]
    err = run.phase_s[:, 10_800] - run.phase_s[:, 7199]
    sigma = run.states.holdover_sigma_s[:, 7199]
    assert run.states.holdover_ready[:, 7199].all() and (run.states.state[:, 7199] == State.LOCKED).all()
    assert 0.6 < np.sqrt(np.mean(err**2)) / np.median(sigma) < 1.5
    assert np.all(np.abs(err) < 4.0 * sigma)

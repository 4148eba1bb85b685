"""Spoofing caught through the oscillator: a coherent drag-off of every receiver puts the GNSSDO in holdover before
its output's |TE| reaches 100 ns (the PRTC-A budget) down to the slowest rate the oscillator's ADEV allows; one
spoofed receiver of three leaves the output as it was; the monitor's statistic is what its theory says."""

import dataclasses
import math

import numpy as np
import pytest

from chronofuse.discipline.chain import ChainConfig, corrected_pps_error, discipline_run
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.plausibility import DragMonitor, ReferenceNoise
from chronofuse.discipline.states import Reason, State
from chronofuse.experiments.gnssdo import _free_phase, make_controller, plausibility_monitors, reference_noise, state_config
from chronofuse.models.environment import receiver_environment
from chronofuse.models.oscillator import simulate_oscillator
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.seeding import root_seed

BUDGET_S = 100e-9
ONSET_S = 7200.0


def _spoofed_run(oscillator: str, rate: float = 0.0, accel: float = 0.0, affected=None, steps: int = 12_000,
                 trials: int = 1, seed: int = 3, integrity_pfa=None, plausibility: bool = True, receivers: int = 3):
    osc = preset(oscillator)
    env = dataclasses.replace(receiver_environment("open-sky"), spoof_start_s=ONSET_S if (rate or accel) else None,
                              spoof_rate_s_per_s=rate, spoof_accel_s_per_s2=accel, affected_receivers=affected)
    free, _ = _free_phase(osc, steps, trials, root_seed(seed))
    rx = simulate_receivers(env, steps, receivers, seed + 1, trials=trials)
    monitors = plausibility_monitors(osc, env, receivers) if plausibility else (None, None)
    config = ChainConfig(states=state_config(osc), receiver_monitor=monitors[0], reference_monitor=monitors[1],
                         integrity_pfa=integrity_pfa)
    servo = make_controller("gated-kalman", osc, env, receivers, Dac.for_oscillator(osc))
    return discipline_run(servo, free, rx.pps_error_s, rx.epochs, config)


def _check_caught(run):
    x = run.phase_s[0]
    over = np.flatnonzero(np.abs(x[int(ONSET_S):]) >= BUDGET_S)
    refused = np.flatnonzero(run.states.reason[0, int(ONSET_S):] == Reason.IMPLAUSIBLE_REFERENCE)
    assert refused.size, "never refused"
    assert over.size == 0 or refused[0] < over[0], f"refused at +{refused[0]} s, |TE| >= 100 ns from +{over[0]} s"
    assert run.states.state[0, int(ONSET_S) + refused[0]] == State.HOLDOVER
    locked = run.states.state[0] == State.LOCKED
    assert not (locked & (np.abs(x) >= BUDGET_S)).any()


@pytest.mark.slow
@pytest.mark.parametrize("rate_ns_s", [0.2, 2.0, 20.0, 100.0])
@pytest.mark.parametrize("shape", ["linear", "quadratic"])
def test_a_coherent_drag_off_puts_the_ocxo_gnssdo_in_holdover_before_100_ns(rate_ns_s, shape):
    rate = rate_ns_s * 1e-9
    # Quadratic: the drag's rate grows from 0 and reaches rate_ns_s after 1000 s.
    kw = {"rate": rate} if shape == "linear" else {"accel": rate / 1000.0}
    _check_caught(_spoofed_run("ocxo", **kw))


@pytest.mark.slow
@pytest.mark.parametrize("shape", ["linear", "quadratic"])
def test_at_0_05_ns_per_s_the_rubidium_gnssdo_is_caught_in_time(shape):
    kw = {"rate": 0.05e-9} if shape == "linear" else {"accel": 0.05e-9 / 1000.0}
    _check_caught(_spoofed_run("rb", steps=14_000, **kw))


def test_the_slowest_drag_caught_follows_from_the_oscillators_adev():
    noise = reference_noise(receiver_environment("open-sky"))
    ocxo = DragMonitor.for_oscillator(preset("ocxo"), noise)
    rb = DragMonitor.for_oscillator(preset("rb"), noise)
    rate_ocxo, w_ocxo = ocxo.slowest_rate(BUDGET_S)
    rate_rb, _ = rb.slowest_rate(BUDGET_S)
    # The OCXO's flicker floor (5e-12) sets its limit: 5 sigma of 2 W^2 sigma_y^2 plus the receiver's part at
    # W = 1024 s; 0.05 ns/s (the 100 ns budget in 2000 s) is below it, 0.2 ns/s above it. The Rb's floor
    # (5e-13) takes it below 0.05 ns/s.
    assert 0.05e-9 < rate_ocxo < 0.2e-9 and w_ocxo == 1024
    osc_part = 2 * 1024**2 * (preset("ocxo").h.h0 / 2048 + 2 * math.log(2) * preset("ocxo").h.hm1
                              + 2 * math.pi**2 / 3 * preset("ocxo").h.hm2 * 1024)
    assert ocxo.statistic_var_s2(1024) > osc_part
    assert rate_rb < 0.05e-9


def test_the_monitors_statistic_has_the_variance_its_theory_gives():
    osc = preset("ocxo")
    env = receiver_environment("open-sky")
    monitor = DragMonitor.for_oscillator(osc, reference_noise(env))
    steps = 40_000
    x = simulate_oscillator(osc, float(steps), 1.0, 5, trials=6).x_s
    rx = simulate_receivers(env, steps, 1, 6, trials=6)
    y = x - corrected_pps_error(rx.pps_error_s, rx.epochs.qerr_s)[:, 0]
    c = np.concatenate([np.zeros((6, 1)), np.cumsum(y, axis=-1)], axis=-1)
    for w in (16, 256, 1024):
        m = monitor.block(w)
        b = (c[:, m:] - c[:, :-m]) / m
        d = b[:, 2 * w:] - 2 * b[:, w:-w] + b[:, :-2 * w]
        model = math.sqrt(monitor.statistic_var_s2(w) - monitor.noise.second_difference_var(monitor.block(w, True), w)
                          + monitor.noise.second_difference_var(m, w))
        assert 0.8 < np.std(d) / model < 1.25, (w, np.std(d), model)


def test_the_compiled_monitor_equals_its_numpy_twin_through_a_refusal_and_a_readmission():
    osc = preset("ocxo")
    monitor = DragMonitor.for_oscillator(osc, ReferenceNoise(3e-9, ((5e-9, 15.0),)), readmit_s=60)
    steps = 2600
    x = simulate_oscillator(osc, float(steps), 1.0, 1, trials=2).x_s
    e = 3e-9 * np.random.default_rng(0).standard_normal((2, steps))
    t = np.arange(steps)
    e[0] += np.where((t > 1200) & (t < 1400), 1e-9 * (t - 1200), 0.0)
    admitted = np.random.default_rng(1).random((2, 1, steps)) > 0.1
    y = (x - e)[:, None, :]
    fast = monitor.run(y, admitted, fast=True)
    slow = monitor.run(y, admitted, fast=False)
    assert np.array_equal(fast.plausible, slow.plausible) and np.array_equal(fast.readmitted, slow.readmitted)
    assert np.allclose(fast.statistic, slow.statistic, equal_nan=True)
    assert not fast.plausible[0, 0].all() and fast.readmitted[0, 0].any() and fast.plausible[1, 0].all()


@pytest.mark.slow
@pytest.mark.parametrize("integrity_pfa", [None, 1e-4])
def test_one_spoofed_receiver_of_three_costs_no_more_than_losing_it(integrity_pfa):
    # The oracle is the run of the two honest receivers alone (receiver streams do not depend on how many
    # receivers are drawn): once the spoofed one is refused the output can be no better, and the drag
    # before the refusal must not make it more than 10 % worse. Measured, 2 trials of 21,600 s after the
    # onset: 3.58 against 3.59 ns with integrity off, 3.70 against 3.96 ns at P_fa 1e-4. Against all
    # three receivers clean (3.26 ns, integrity off) it is 1.10x (1.19x with receiver 1 spoofed instead): the
    # third receiver's share, which no defence can keep.
    steps = 21_600
    honest = _spoofed_run("ocxo", steps=steps, trials=2, integrity_pfa=integrity_pfa, receivers=2)
    spoofed = _spoofed_run("ocxo", rate=2e-9, affected=(2,), steps=steps, trials=2, integrity_pfa=integrity_pfa)
    after = slice(int(ONSET_S), steps)

    def rms(run):
        return float(np.sqrt(np.mean(run.phase_s[:, after] ** 2)))

    assert rms(spoofed) <= 1.10 * rms(honest), (rms(spoofed), rms(honest))
    # The spoofed receiver is out of the fusion from soon after the onset to the end, never re-admitted.
    assert not spoofed.usable[:, 2, int(ONSET_S) + 600:].any()
    assert (spoofed.states.state[:, -1] == State.LOCKED).all()


def test_the_chain_with_its_plausibility_stages_streams_as_it_runs_through_a_drag_and_its_end():
    from chronofuse.discipline.chain import gnssdo_frame
    from chronofuse.discipline.stages import gnssdo_pipeline
    from chronofuse.estimation.pipeline import compare_streaming_to_batch

    osc = preset("ocxo")
    steps = 1500
    env = dataclasses.replace(receiver_environment("open-sky"), spoof_start_s=700.0, spoof_rate_s_per_s=2e-9)
    free, _ = _free_phase(osc, steps, 2, root_seed(2))
    rx = simulate_receivers(env, steps, 3, 5, trials=2)
    pps = rx.pps_error_s.copy()
    pps[..., 900:] -= rx.spoof_offset_s[..., 900:]  # the spoofer stops at 900 s: the receivers come back
    noise = reference_noise(env)
    monitor = DragMonitor.for_oscillator(osc, noise, max_horizon_s=128, readmit_s=60)
    config = ChainConfig(states=dataclasses.replace(state_config(osc), lock_hold_s=20.0), receiver_monitor=monitor,
                         reference_monitor=monitor)
    servo = make_controller("gated-kalman", osc, env, 3, Dac.for_oscillator(osc))
    pipe = gnssdo_pipeline(servo, config, 10**9).fit()
    frame = gnssdo_frame(free, pps, rx.epochs)
    names = ["receiver_plausible", "fresh", "usable", "loop_reference_s", "implausible", "phase_s", "gnssdo_state",
             "gnssdo_reason", "holdover_sigma_s"]
    assert compare_streaming_to_batch(pipe, frame, rtol=1e-9, atol=1e-15, names=names) == []
    out = pipe.run(frame)
    assert not np.asarray(out["receiver_plausible"])[..., 750:900].any()  # refused during the drag
    assert np.asarray(out["fresh"])[..., 900:].any() and np.asarray(out["receiver_plausible"])[..., -1].all()


def _gap_series(steps=4000, gap=(1000, 2000), seed=4):
    """An OCXO against a white 3 ns reference, three series with a gap: clean, dragged at 2 ns/s from inside the
    gap on, stepped by 300 ns inside the gap."""
    osc = preset("ocxo")
    x = simulate_oscillator(osc, float(steps), 1.0, seed, trials=1).x_s[0]
    t = np.arange(steps)
    e = 3e-9 * np.random.default_rng(seed).standard_normal((3, steps))
    e[1] += np.where(t > 1200, 2e-9 * (t - 1200), 0.0)
    e[2] += np.where(t > 1500, 300e-9, 0.0)
    admitted = np.ones((3, steps), bool)
    admitted[:, gap[0]:gap[1]] = False
    return osc, (x - e)[None], admitted[None]


@pytest.mark.parametrize("fast", [True, False])
def test_a_series_back_from_a_gap_is_held_to_the_prediction_made_before_it(fast):
    # A drag or a step that happened while the series was away is a frequency offset or a jump to every second
    # difference after the gap, which sees nothing before it; only the oscillator's holdover prediction from
    # before the gap can tell.
    osc, y, admitted = _gap_series()
    monitor = DragMonitor.for_oscillator(osc, ReferenceNoise(3e-9), readmit_s=120)
    run = monitor.run(y, admitted, fast=fast)
    plausible = run.plausible[0]
    assert plausible[:, :1000].all()
    # Clean: trusted again from its first sample that agrees (the first, but for one in 370), and from then on.
    back = np.flatnonzero(plausible[0, 2000:])
    assert back[0] <= 2 and plausible[0, 2000 + back[0]:].all()
    # Dragged (1.6 us by the gap's end) and stepped: never trusted again.
    assert not plausible[1:, 2000:].any()


def test_the_compiled_monitor_equals_its_numpy_twin_across_gaps():
    osc, y, admitted = _gap_series(steps=3000, gap=(700, 1300), seed=8)
    admitted = admitted & (np.random.default_rng(2).random(admitted.shape) > 0.2)
    admitted[..., 2000:2040] = False  # a second gap, longer than recheck_gap_s, with no drag in it
    monitor = DragMonitor.for_oscillator(osc, ReferenceNoise(3e-9, ((5e-9, 15.0),)), readmit_s=60)
    fast, slow = monitor.run(y, admitted, fast=True), monitor.run(y, admitted, fast=False)
    assert np.array_equal(fast.plausible, slow.plausible) and np.array_equal(fast.readmitted, slow.readmitted)
    clean = fast.plausible[0, 0]
    assert clean[1400:2000].all() and clean[2060:].all() and not fast.plausible[0, 1, 1300:].any()
    assert not fast.plausible[0, 2, 1500:].all()  # its step comes after the gap: the second differences see it


@pytest.mark.slow
@pytest.mark.parametrize("oscillator", ["ocxo", "csac", "rb"])
def test_a_drag_that_began_in_an_outage_is_refused_when_the_receivers_come_back(oscillator):
    # The onset is at half the run (1800 s), inside an outage from 824 to 2234 s: the receivers come back
    # 0.9 us off and still dragging, and the history before the outage is too short for any second difference
    # to span it. Found by a hostile audit: LOCKED was claimed at 2-4 us for up to 820 s.
    from chronofuse.experiments.gnssdo import GnssdoSetup, simulate_gnssdo

    setup = GnssdoSetup(scenario="spoofing", oscillator=oscillator, duration_s=3601, trials=3, seed=7490, receivers=1,
                        controller="adaptive-kalman", integrity_pfa=1e-3, outage_start_s=824.2, outage_s=1409.7)
    run = simulate_gnssdo(setup)["run"]
    locked = run.states.state == State.LOCKED
    assert not (locked & (np.abs(run.phase_s) >= BUDGET_S)).any()
    assert not locked[:, 2300:].any() and run.implausible[:, 2240:].all()
    # The same outage without the spoofer: the receivers are trusted again at once and the output locks.
    honest = simulate_gnssdo(dataclasses.replace(setup, scenario="open-sky"))["run"]
    assert not honest.implausible[:, 2234:].any()
    assert (honest.states.state[:, 2600:] == State.LOCKED).mean() > 0.95


@pytest.mark.parametrize("fast", [True, False])
def test_a_drag_that_starts_as_the_series_comes_back_from_a_long_gap_is_refused(fast):
    # The drag starts with the new history, so every second difference of it is zero (a frequency offset),
    # and after a 5000 s gap the phase prediction's 5 sigma is 0.6 us wide (random-walk FM): 300 s of watch
    # let it through, and it was LOCKED at 0.1-4.8 us (found by the adversarial audit). The frequency since
    # the return is off by the drag's rate, which the oscillator cannot make.
    osc = preset("ocxo")
    steps = 9000
    x = simulate_oscillator(osc, float(steps), 1.0, 6, trials=2).x_s
    t = np.arange(steps)
    e = 3e-9 * np.random.default_rng(6).standard_normal((2, steps))
    e[0] += np.where(t >= 6000, 1e-9 * (t - 6000), 0.0)  # series 1: the same gap, honest
    admitted = np.ones((2, steps), bool)
    admitted[:, 1000:6000] = False
    monitor = DragMonitor.for_oscillator(osc, reference_noise(receiver_environment("open-sky")))
    run = monitor.run((x - e)[:, None, :], admitted[:, None, :], fast=fast)
    dragged, honest = run.plausible[0, 0], run.plausible[1, 0]
    refused = np.flatnonzero(~dragged[6000:])
    assert refused.size and refused[-1] == steps - 6001 and refused[0] < 600  # refused within 600 s, for good
    assert honest[6002:].all()


@pytest.mark.slow
@pytest.mark.parametrize("oscillator", ["ocxo", "csac"])
def test_a_spoofer_that_starts_as_a_long_outage_ends_is_never_claimed_locked(oscillator):
    # `--scenario spoofing --outage-start 1200 --outage 6000`: the drag starts at 7200 s, the second the
    # receivers come back; the audit measured 12,537 (OCXO) and 10,204 (CSAC) trial-seconds LOCKED at 1.8-14 us.
    from chronofuse.experiments.gnssdo import GnssdoSetup, simulate_gnssdo

    run = simulate_gnssdo(GnssdoSetup(scenario="spoofing", oscillator=oscillator, duration_s=14400, trials=2, seed=3,
                                      outage_start_s=1200, outage_s=6000))["run"]
    locked = run.states.state == State.LOCKED
    assert not (locked & (np.abs(run.phase_s) >= BUDGET_S)).any()
    assert run.implausible[:, 7800:].all()


def _outlier_series(steps=3000, seed=9):
    """An OCXO against a white 10 ns reference with 2 % of its samples 300 ns rms off (the ``outliers``
    scenario's pulses, and a 1.5 us one at 1000 s): series 0 clean, series 1 stepped by 400 ns at 2000 s, series 2 dragged at 2 ns/s from
    2000 s."""
    osc = preset("ocxo")
    rng = np.random.default_rng(seed)
    x = simulate_oscillator(osc, float(steps), 1.0, seed, trials=1).x_s[0]
    t = np.arange(steps)
    e = 10e-9 * rng.standard_normal((3, steps))
    e += np.where(rng.random((3, steps)) < 0.02, 300e-9 * rng.standard_normal((3, steps)), 0.0)
    e[:, 1000] += 1.5e-6  # and one of 5 sigma of those pulses (about one an hour in a receiver)
    e[1] += np.where(t >= 2000, 400e-9, 0.0)
    e[2] += np.where(t >= 2000, 2e-9 * (t - 2000), 0.0)
    return osc, (x - e)[None], np.ones((1, 3, steps), bool)


@pytest.mark.parametrize("fast", [True, False])
def test_single_outliers_refuse_nothing_and_a_step_or_a_drag_is_still_refused(fast):
    # Before the clip one 300 ns-class pulse held a 4 s block mean over its threshold at W = 16 for longer than
    # ``persist`` and refused a clean receiver for 300 s: with one receiver in the outliers scenario (OCXO,
    # 4 trials of 7200 s) LOCKED fell from 0.92 to 0.75 against the test switched off.
    osc, y, admitted = _outlier_series()
    noise = ReferenceNoise(math.sqrt((10e-9) ** 2 + 0.02 * (300e-9) ** 2))  # outliers folded in (reference_noise)
    monitor = DragMonitor.for_oscillator(osc, noise)
    run = monitor.run(y, admitted, fast=fast)
    p = run.plausible[0]
    assert p[:, :2000].all() and p[0].all()
    assert not p[1, 2000:2010].all() and not p[2, 2000:2600].all()
    # Negative: without the clip the same outliers refuse the clean series.
    bare = dataclasses.replace(monitor, clip=False).run(y, admitted, fast=fast).plausible[0]
    assert not bare[0].all()


def test_the_compiled_monitor_equals_its_numpy_twin_through_outliers_a_step_and_gaps():
    osc, y, admitted = _outlier_series(steps=2600, seed=12)
    admitted = admitted & (np.random.default_rng(3).random(admitted.shape) > 0.15)
    admitted[..., 1200:1240] = False
    monitor = DragMonitor.for_oscillator(osc, ReferenceNoise(20e-9, ((5e-9, 15.0),)), readmit_s=60)
    fast, slow = monitor.run(y, admitted, fast=True), monitor.run(y, admitted, fast=False)
    assert np.array_equal(fast.plausible, slow.plausible) and np.array_equal(fast.readmitted, slow.readmitted)
    assert np.allclose(fast.statistic, slow.statistic, equal_nan=True)


def test_the_twins_agree_on_the_offset_a_series_is_let_back_in_with():
    # Series 0 clean, 1 stepped by 150 ns at 2000 s (refused, let back in once the tolerance covers it), 2 away
    # from 1960 s to 2000 s and back 150 ns off (watched, trusted only late), 3 stepped for 100 s only.
    osc = preset("ocxo")
    steps = 5500
    x = simulate_oscillator(osc, float(steps), 1.0, 5, trials=1).x_s[0]
    t = np.arange(steps)
    e = 10e-9 * np.random.default_rng(5).standard_normal((4, steps))
    e[1:3] += np.where(t >= 2000, 150e-9, 0.0)
    e[3] += np.where((t >= 2000) & (t < 2100), 150e-9, 0.0)
    admitted = np.ones((1, 4, steps), bool)
    admitted[0, 2, 1960:2000] = False
    monitor = DragMonitor.for_oscillator(osc, ReferenceNoise(10e-9))
    fast, slow = monitor.run((x - e)[None], admitted, fast=True), monitor.run((x - e)[None], admitted, fast=False)
    assert np.allclose(fast.unresolved_s, slow.unresolved_s, rtol=1e-9, atol=0)
    u = fast.unresolved_s[0, :, -1]
    assert u[0] == 0.0 and u[1] > 150e-9 and u[2] > 150e-9  # the miss plus the tolerance: over the step
    # The step went back: let back in 1000 s later on a miss of a few ns, and the tolerance of a prediction
    # 1000 s long (a step of that size then could not be told from the oscillator's wander).
    assert 0.0 < u[3] < 70e-9
    assert (fast.unresolved_s[0, :, :2000] == 0.0).all()


def test_the_summary_says_which_drags_the_receivers_let_the_oscillator_catch():
    # Open sky: the table of docs/gnssdo/spoofing.md. Urban canyon: the multipath puts every horizon's threshold
    # above 100 ns, so the summary must not name a rate (a drag of 0.3 ns/s lay 1000-1250 s there unnamed) and
    # says from which time error a drag is refused at all.
    from chronofuse.experiments.gnssdo import GnssdoSetup, drag_check, evaluate, simulate_gnssdo

    sky = drag_check(plausibility_monitors(preset("ocxo"), receiver_environment("open-sky"), 3)[0])
    assert sky["slowest_rate_ns_per_s"] == pytest.approx(0.0708, rel=0.01) and sky["horizon_s"] == 1024
    assert sky["refused_from_te_ns"] < 100.0
    canyon = drag_check(plausibility_monitors(preset("ocxo"), receiver_environment("urban-canyon"), 3)[0])
    assert canyon["slowest_rate_ns_per_s"] is None and canyon["horizon_s"] is None
    assert 100.0 < canyon["refused_from_te_ns"] < 200.0
    setup = GnssdoSetup(scenario="urban-canyon", duration_s=3600, seed=1, design="datasheet")
    assert evaluate(simulate_gnssdo(setup))["drag_check"] == canyon
    assert evaluate(simulate_gnssdo(dataclasses.replace(setup, plausibility=False)))["drag_check"] is None


@pytest.mark.parametrize("fast", [True, False])
def test_a_train_of_pulses_is_not_hidden_by_the_clip(fast):
    # A pulse of 600 ns every 4th second moves the reference's mean by 150 ns at once; clipped pulse by pulse
    # it would enter the test as a 15 ns shift. Clipped once in 64 s per side at most, the rest is seen.
    osc = preset("ocxo")
    steps = 2000
    x = simulate_oscillator(osc, float(steps), 1.0, 21, trials=1).x_s[0]
    t = np.arange(steps)
    e = 10e-9 * np.random.default_rng(21).standard_normal(steps)
    e += np.where((t >= 1000) & (t % 4 == 0), 600e-9, 0.0)
    monitor = DragMonitor.for_oscillator(osc, ReferenceNoise(10e-9))
    plausible = monitor.run((x - e)[None, None], np.ones((1, 1, steps), bool), fast=fast).plausible[0, 0]
    assert plausible[:1000].all()
    refused = np.flatnonzero(~plausible[1000:])
    assert refused.size and refused[0] < 60


def _stepped_run(pps_step, gap=None, receivers: int = 3, steps: int = 12_000):
    osc = preset("ocxo")
    env = receiver_environment("open-sky")
    free, _ = _free_phase(osc, steps, 1, root_seed(3))
    rx = simulate_receivers(env, steps, receivers, 4, trials=1)
    pps = rx.pps_error_s + pps_step(np.arange(steps))
    if gap is not None:
        pps[..., gap[0]:gap[1]] = np.nan
    monitors = plausibility_monitors(osc, env, receivers)
    config = ChainConfig(states=state_config(osc), receiver_monitor=monitors[0], reference_monitor=monitors[1])
    servo = make_controller("gated-kalman", osc, env, receivers, Dac.for_oscillator(osc))
    return discipline_run(servo, free, pps, rx.epochs, config)


@pytest.mark.parametrize(("size_ns", "gap_s", "receivers"), [(105, 0, 3), (150, 0, 3), (300, 0, 3), (105, 0, 1),
                                                               (150, 40, 3), (150, 200, 3)])
def test_a_coherent_step_just_over_the_budget_is_never_claimed_locked(size_ns, gap_s, receivers):
    # The audit's finding: a step of every receiver just over the budget is refused at once, but the holdover
    # prediction's tolerance grows over it within minutes and the receivers are let back in; the loop walks to
    # them. Their miss and the tolerance are kept off the lock threshold, so the output (TE = the step) is
    # never claimed LOCKED again, and says why. Steps of 105-300 ns, straight or after a gap of 40 or 200 s.
    onset = int(ONSET_S)
    gap = (onset - gap_s, onset) if gap_s else None
    run = _stepped_run(lambda t: np.where(t >= onset, size_ns * 1e-9, 0.0), gap=gap, receivers=receivers)
    locked = run.states.state[0] == State.LOCKED
    assert locked[onset - 600:onset - gap_s].all()  # locked before it (the negative control is below)
    assert not (locked & (np.abs(run.phase_s[0]) >= BUDGET_S)).any()
    assert not locked[onset + 30:].any()  # refused within seconds, and never LOCKED again
    if size_ns <= 150:  # let back in before the end: the loop follows the step, and the state says why not LOCKED
        assert (np.abs(run.phase_s[0, -600:]) > 0.8 * size_ns * 1e-9).all()
        assert run.states.state[0, -1] == State.ALARM
        assert Reason.UNRESOLVED_OFFSET in set(run.states.reason[0, onset:].tolist())


@pytest.mark.parametrize("stepped", ["staggered", "two of three"])
def test_receivers_stepped_one_after_another_or_two_of_three_are_never_claimed_locked(stepped):
    # The audit's finding against the first vouching rule (any receiver without a bound set the others'
    # aside): steps of 300 ns on receiver 0 at 3000 s, 1 at 5000 s and 2 at 7000 s left all three 300 ns off
    # with no bound (LOCKED at 313 ns), and 150 ns on two of three LOCKED at 134 ns. A receiver is now vouched
    # for only once it agrees with the clean ones.
    if stepped == "staggered":
        starts = np.array([3000, 5000, 7000])[:, None]
        pert = lambda t: np.where(t >= starts, 300e-9, 0.0)  # noqa: E731
    else:
        pert = lambda t: np.where((t >= 5000) & (np.arange(3)[:, None] < 2), 150e-9, 0.0)  # noqa: E731
    run = _stepped_run(pert)
    locked = run.states.state[0] == State.LOCKED
    assert locked[2000:3000].all()
    assert not (locked & (np.abs(run.phase_s[0]) >= BUDGET_S)).any()
    # The loop did follow the receivers (the output is off by their fused step), and the state says why it
    # is not LOCKED.
    assert np.abs(run.phase_s[0, -1]) > 80e-9 and Reason.UNRESOLVED_OFFSET in set(run.states.reason[0].tolist())


def _ladder(t):
    # Rung i at 3000 + 1500 i s moves receiver i mod 3 to the mean of the other two plus 24 ns: each rung is
    # under the vouching tolerance (26 ns in open sky), all of them add up (a second audit's attack).
    offsets, out = np.zeros(3), np.zeros((3, t.size))
    for i in range(8):
        r = i % 3
        offsets[r] = np.delete(offsets, r).mean() + 24e-9
        out[r, t >= 3000 + 1500 * i] = offsets[r]
    return out


def _gap_return(t):
    # Receivers 0 and 1 stepped by 150 ns at 7200 s (refused, let back in with bounds); receiver 2 away from
    # 7100 to 10100 s comes back carrying the step and agrees with its own prediction at once (a second
    # audit's attack: it then vouched for the others).
    out = np.where(t >= 7200, 150e-9, 0.0) * np.ones((3, 1))
    out[2, 7100:10100] = np.nan
    return out


@pytest.mark.parametrize("attack", ["ladder", "gap return"])
def test_vouching_launders_neither_a_ladder_of_small_steps_nor_a_receiver_back_from_a_gap(attack):
    pert, steps = (_ladder, 15_000) if attack == "ladder" else (_gap_return, 14_000)
    run = _stepped_run(pert, steps=steps)
    locked = run.states.state[0] == State.LOCKED
    assert locked[2000:3000].all()
    assert not (locked & (np.abs(run.phase_s[0]) >= BUDGET_S)).any()  # before: LOCKED at 180 and 177 ns
    assert np.abs(run.phase_s[0, -1]) > 100e-9 and run.states.state[0, -1] == State.ALARM


@pytest.mark.parametrize("rate_ns_s", [0.1, 2.0])
def test_after_a_refused_drag_the_holdover_keeps_the_oscillators_frequency_not_the_drags(rate_ns_s):
    # Before, the loop held over on the frequency the drag had taught it before the refusal: 1 h after a
    # 0.1 ns/s drag was refused, |TE| was 512 ns rms (6 seeds) against 39 ns for an outage at that second.
    # Now it holds over on the prediction from before the excursion (the oscillator's own frequency).
    onset = int(ONSET_S)
    t = np.arange(onset + 3 * 3600)
    run = _stepped_run(lambda t: np.where(t >= onset, rate_ns_s * 1e-9 * (t - onset), 0.0), steps=t.size)
    refused = np.flatnonzero(run.states.reason[0, onset:] == Reason.IMPLAUSIBLE_REFERENCE)
    k0 = onset + refused[0]
    assert (run.states.state[0, k0:k0 + 3600] == State.HOLDOVER).all()
    assert np.abs(run.phase_s[0, k0 + 3600]) < 100e-9  # before: 0.1 ns/s gave 512 ns rms here


def test_the_summary_counts_the_seconds_not_claimed_locked_for_an_unresolved_offset():
    from chronofuse.experiments.gnssdo import unresolved_alarm_seconds

    onset = int(ONSET_S)
    stepped = _stepped_run(lambda t: np.where(t >= onset, 150e-9, 0.0))
    alarm = (stepped.states.state[0] == State.ALARM).sum()
    seconds = unresolved_alarm_seconds(stepped.states)[0]
    assert 0 < seconds <= alarm and seconds > 0.9 * (stepped.states.state[0, onset:] == State.ALARM).sum()
    clean = _stepped_run(lambda t: 0.0 * t)  # the negative: no refusal, nothing unresolved
    assert unresolved_alarm_seconds(clean.states)[0] == 0


def test_a_step_that_goes_back_is_locked_again():
    # The negative control: a 150 ns step that goes away after 100 s is refused, and let back in when the
    # receivers agree with the prediction again, with a miss and a tolerance of a few ns: LOCKED again.
    onset = int(ONSET_S)
    run = _stepped_run(lambda t: np.where((t >= onset) & (t < onset + 100), 150e-9, 0.0))
    locked = run.states.state[0] == State.LOCKED
    refused = np.flatnonzero(run.states.reason[0, onset:] == Reason.IMPLAUSIBLE_REFERENCE)
    assert refused.size and refused[0] < 10
    assert locked[onset + 1500:].all()
    assert not (locked & (np.abs(run.phase_s[0]) >= BUDGET_S)).any()

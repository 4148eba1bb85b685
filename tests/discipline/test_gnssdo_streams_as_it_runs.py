"""The GNSSDO is one program live and batch: its discipline chain, on a recorded 1PPS (what ``gnssdo --reference``
runs) and on simulated receivers (the whole chain, integrity and plausibility on), stepped second by second in
chunks of any sizes gives what its batch run gives, and the batch run of any prefix of the record gives the
first seconds of the full run (the batch path uses no second it has not reached), through a reference
outage, the EFC at its rail and a spoofer's drag-off ramp."""

import copy
import dataclasses
import math

import numba
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from chronofuse.discipline.chain import ChainConfig, gnssdo_frame
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.servo import Servo
from chronofuse.discipline.servo_kernel import SAMPLE
from chronofuse.discipline.stages import gnssdo_pipeline
from chronofuse.discipline.states import Reason, State
from chronofuse.estimation.pipeline import stack_steps
from chronofuse.experiments.gnssdo import (_free_phase, make_controller, plausibility_monitors, reference_frame,
                                           reference_pipeline, reference_servo, reference_spread_s, state_config)
from chronofuse.io.pps_reference import read_pps_reference
from chronofuse.models.environment import receiver_environment
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.seeding import root_seed

STEPS = 1800
OUTAGE = slice(600, 800)  # no pulse: holdover
RAMP_FROM = 1100  # the spoofer's drag-off, 2 ns/s
#: The columns compared (every column the stages give, the states, the steering and the time error estimate).
REFERENCE_NAMES = ("phase_s", "offset_s", "freq_adj", "phase_step_s", "offset_estimate_s", "innovation_s", "used",
                   "near_rail", "gnssdo_state", "gnssdo_reason", "rail_alarm", "filtered_offset_s", "holdover_ready",
                   "holdover_sigma_s")


@pytest.fixture(scope="module")
def recording(real_data):
    """The recorded GPS 1PPS against an H-maser, first ``STEPS`` seconds, read as ``gnssdo --reference`` reads it."""
    e = read_pps_reference(real_data / "stability" / "gps" / "gps_1pps_phase_data.txt.gz")[:STEPS]
    return e - np.mean(e)


def _reference_chain(e, *, outage=False, ramp=False, rail=False):
    """The ``gnssdo --reference`` chain on the record ``e`` (servo designed on the clean record, as a user would),
    two trials; ``rail``: the EFC's span cut to +-1e-8 and trial 0's oscillator aging by 8e-12 /s, so that its
    steering reaches the rail while it is locked."""
    osc = preset("ocxo")
    free, _ = _free_phase(osc, STEPS, 2, root_seed(1))
    if rail:
        osc = dataclasses.replace(osc, dac_range_V=osc.dac_range_V * 0.05)
        t = np.arange(STEPS, dtype=float)
        free = free.copy()
        free[0] += 0.5 * 8e-12 * t**2
    servo = reference_servo(e, "gated-kalman", osc)
    spread = reference_spread_s(e)
    t = np.arange(STEPS)
    e = e.copy()
    if outage:
        e[OUTAGE] = np.nan
    if ramp:
        e = e + np.where(t >= RAMP_FROM, 2e-9 * (t - RAMP_FROM), 0.0)
    return reference_pipeline(servo, osc).fit(), reference_frame(e, free, spread)


def _stream(pipeline, frame, cuts=()):
    """``pipeline`` stepped second by second after a reset, as a live driver feeds it: chunk by chunk (``cuts``:
    the chunks' ends); at each chunk's end the pipeline is carried on as a deep copy (a checkpointed process)
    after a batch run of the frame so far, which must leave the streaming state alone."""
    pipeline.reset()
    steps = next(iter(frame.values())).shape[-1]
    out, start = [], 0
    for end in [*sorted(set(cuts)), steps]:
        for k in range(start, end):
            out.append(pipeline.step({n: v[..., k] for n, v in frame.items()}))
        if end < steps:
            pipeline.run({n: v[..., :end] for n, v in frame.items()})
            pipeline = copy.deepcopy(pipeline)
        start = end
    return out


def _mismatches(batch, streamed, names, rtol=1e-12):
    s = stack_steps(streamed, names)
    problems = []
    for name in names:
        b, v = np.asarray(batch[name]), np.asarray(s[name])
        if b.shape != v.shape:
            problems.append(f"{name}: shape {v.shape} streamed, {b.shape} batch")
        elif b.dtype.kind == "f":
            ok = np.isclose(v, b, rtol=rtol, atol=0.0, equal_nan=True)
            if not ok.all():
                k = np.flatnonzero(~ok.reshape(-1, b.shape[-1]).all(axis=0))
                problems.append(f"{name}: differs at {k.size} seconds, first {k[0]}")
        elif not np.array_equal(b, v):
            k = np.flatnonzero(~(b == v).reshape(-1, b.shape[-1]).all(axis=0))
            problems.append(f"{name}: differs at {k.size} seconds, first {k[0]}")
    return problems


@pytest.mark.parametrize("case", ["clean", "outage", "rail", "ramp", "all"])
def test_the_recorded_reference_chain_streams_second_by_second_exactly_as_it_runs(recording, case):
    on = {"outage": case in ("outage", "all"), "ramp": case in ("ramp", "all"), "rail": case in ("rail", "all")}
    pipe, frame = _reference_chain(recording, **on)
    batch = pipe.run(frame)
    assert _mismatches(batch, _stream(pipe, frame), REFERENCE_NAMES, rtol=0.0) == []  # to the last bit
    state = np.asarray(batch["gnssdo_state"])
    reason = np.asarray(batch["gnssdo_reason"])
    # the events happened (the comparison is not between two empty runs)
    assert (state == State.LOCKED).any()
    if on["outage"]:
        assert np.isin(state[:, OUTAGE], (State.HOLDOVER, State.FREE_RUN)).all()
        assert (reason[:, OUTAGE.start] == Reason.REFERENCE_LOST).all()
    if on["rail"]:  # trial 0 ages into the rail after its lock; trial 1 never reaches it
        locked = int(np.argmax(state[0] == State.LOCKED))
        assert np.asarray(batch["near_rail"])[0, locked:].any() and not np.asarray(batch["near_rail"])[1].any()
    if on["ramp"]:  # the drag pulls the time error off (no plausibility test on a record): an alarm
        assert (state[1, RAMP_FROM:] == State.ALARM).any() and not (state[1, :RAMP_FROM] == State.ALARM).any()


def test_a_wrong_stream_is_caught(recording):
    # the comparison can fail: the chain streamed over a record one nanosecond off from its 900th second
    pipe, frame = _reference_chain(recording)
    batch = pipe.run(frame)
    e = np.array(frame["reference_error_s"])
    e[:, 900:] += 1e-9
    other = {**frame, "reference_error_s": e, "loop_reference_s": e}
    problems = _mismatches(batch, _stream(pipe, other), REFERENCE_NAMES, rtol=0.0)
    assert problems and all("first 90" in p for p in problems if p.startswith(("phase_s", "offset_s")))


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                 HealthCheck.function_scoped_fixture])
@given(cuts=st.lists(st.integers(1, STEPS - 1), max_size=6))
def test_any_chunking_of_the_stream_and_any_prefix_run_agree_with_the_batch_run(recording, cuts):
    pipe, frame = _reference_chain(recording, outage=True, ramp=True, rail=True)
    batch = pipe.run(frame)
    assert _mismatches(batch, _stream(pipe, frame, cuts), REFERENCE_NAMES, rtol=0.0) == []
    for end in cuts:  # the batch run of the record so far: what a live run had said by then
        prefix = pipe.run({n: v[..., :end] for n, v in frame.items()})
        for name in REFERENCE_NAMES:
            assert np.array_equal(np.asarray(prefix[name]), np.asarray(batch[name])[..., :end], equal_nan=True), name


def _receivers_chain(steps=1200):
    """The whole chain (qualify, integrity at P_fa 1e-3, plausibility, fusion, UTC, loop, states) on three
    simulated receivers: all jammed for 150 s, receiver 2's clock stepped, then all dragged off at 2 ns/s; trial 0's oscillator 1.5e-8 off, beyond its EFC's span (+-1e-8)."""
    osc = preset("ocxo")
    env = dataclasses.replace(receiver_environment("open-sky"), jamming_start_s=400.0, jamming_duration_s=150.0,
                              spoof_start_s=800.0, spoof_rate_s_per_s=2e-9)
    free, _ = _free_phase(osc, steps, 2, root_seed(4))
    free = free.copy()
    free[0] += 1.5e-8 * np.arange(steps, dtype=float)
    osc = dataclasses.replace(osc, dac_range_V=osc.dac_range_V * 0.05)
    rx = simulate_receivers(env, steps, 3, 6, trials=2)
    monitor = plausibility_monitors(osc, env, 3)[0]
    config = ChainConfig(states=dataclasses.replace(state_config(osc), lock_hold_s=20.0), integrity_pfa=1e-3,
                         integrity_train_s=300.0, alarm_hold_s=60.0, receiver_monitor=monitor)
    servo = make_controller("gated-kalman", osc, env, 3, Dac.for_oscillator(osc))
    frame = gnssdo_frame(free, rx.pps_error_s, rx.epochs)
    bias = np.array(frame["clock_bias_s"])
    bias[:, 2, 650:] += 3e-6  # receiver 2's clock steps by 3 us: the integrity stage alarms and excludes it
    frame["clock_bias_s"] = bias
    return gnssdo_pipeline(servo, config, 10**9).fit(), frame


def test_the_whole_chain_on_receivers_streams_as_it_runs_through_an_outage_a_rail_and_a_drag():
    pipe, frame = _receivers_chain()
    batch = pipe.run(frame)
    names = [n for n in pipe.gives if n in batch.columns]
    # measured: every column to the last bit (the compiled fusion, plausibility and state kernels and their
    # streaming twins sum in the same order here; were that to change, 1e-12 relative is the allowance)
    assert _mismatches(batch, _stream(pipe, frame, (1, 399, 400, 617, 801)), names, rtol=0.0) == []
    state = np.asarray(batch["gnssdo_state"])
    reason = np.asarray(batch["gnssdo_reason"])
    assert np.isin(state[:, 400:550], (State.HOLDOVER, State.FREE_RUN)).all()  # the outage
    assert (reason[:, 400] == Reason.REFERENCE_LOST).all()
    assert (state[1, 550:800] == State.LOCKED).any() and (reason[:, 800:] == Reason.IMPLAUSIBLE_REFERENCE).any(axis=1).all()
    assert np.asarray(batch["near_rail"])[0].any() and not np.asarray(batch["near_rail"])[1].any()  # the rail
    excluded = np.asarray(batch["excluded"])
    assert excluded[:, 2, 650:].any(axis=-1).all() and not excluded[:, :2].any() and not excluded[..., :650].any()
    assert not np.asarray(batch["receiver_plausible"])[..., 1100:].any(axis=-1).all()  # the drag refused


def test_a_step_let_back_in_and_a_receiver_vouched_for_stream_as_they_run():
    # The unresolved offsets, the vouching and the holdover on the prediction, live and batch: receiver 0
    # stepped by 150 ns from 600 to 900 s (refused, let back in with a bound at 1776 s, vouched for by the other
    # two once it has agreed with them for a minute), then every receiver dragged at 0.3 ns/s from 4000 s up to
    # 180 ns (refused from 4197 s, held over on the prediction, receiver 1 let back in at 6922 s with a bound
    # nothing vouches for).
    osc = preset("ocxo")
    env = receiver_environment("open-sky")
    steps = 7000
    free, _ = _free_phase(osc, steps, 1, root_seed(8))
    rx = simulate_receivers(env, steps, 3, 9, trials=1)
    t = np.arange(steps)
    pps = rx.pps_error_s + np.where((np.arange(3)[:, None] == 0) & (t >= 600) & (t < 900), 150e-9, 0.0)
    pps = pps + np.clip(0.3e-9 * (t - 4000), 0.0, 180e-9)
    monitor = plausibility_monitors(osc, env, 3)[0]
    config = ChainConfig(states=state_config(osc), receiver_monitor=monitor)
    servo = make_controller("gated-kalman", osc, env, 3, Dac.for_oscillator(osc))
    pipe = gnssdo_pipeline(servo, config, 10**9).fit()
    frame = gnssdo_frame(free, pps, rx.epochs)
    batch = pipe.run(frame)
    names = [n for n in pipe.gives if n in batch.columns]
    assert _mismatches(batch, _stream(pipe, frame, (1500, 3000, 6800)), names) == []
    unresolved = np.asarray(batch["receiver_unresolved_s"])[0]
    assert unresolved[0, 3500] > 0.0 and (unresolved[1:, :3500] == 0.0).all()
    assert np.asarray(batch["unresolved_s"])[0, 3500] == 0.0  # vouched for
    assert np.asarray(batch["unresolved_s"])[0, -1] > 100e-9
    assert np.isfinite(np.asarray(batch["loop_reference_s"])[0, 5000])  # held over on the prediction


@numba.njit(SAMPLE, cache=False)
def _sample_after_warmup(offset_s, local_ts_s, weight, shift_s, applied, state, params, out):
    # proportional steering that starts only once the loop has run ``params[1]`` seconds: a backend that reads
    # the sample's time, as linuxptp's interface gives it (``local_ts``)
    used = not math.isnan(offset_s) and local_ts_s >= params[1]
    out[0] = offset_s
    out[1] = offset_s
    out[2] = 1.0 if used else 0.0
    if used:
        state[0] = -params[0] * offset_s
    return state[0]


class _WarmupServo(Servo):
    name = "warmup-p"
    kernel = _sample_after_warmup

    def __init__(self, warmup_s=300.0, *, dac=None):
        super().__init__(interval_s=1.0, dac=dac, step_threshold_s=1e-6, fast=True)
        self.warmup_s = warmup_s

    def _initial(self, n):
        return {"y": np.zeros(n)}

    def _control(self, state, z, valid, shift, weight):  # pragma: no cover (compiled only: the twin has no clock)
        raise NotImplementedError

    def _kernel_initial(self, n):
        return np.zeros((n, 1))

    def _kernel_params(self):
        return np.array([0.05, float(self.warmup_s)])


def test_a_servo_that_reads_the_samples_time_gets_the_same_time_streamed_as_in_batch(recording):
    # The loop stage gave its servo local_ts_s = 0 at every streamed second and k * dt in batch: a backend that
    # reads the time (here: no steering before 300 s) steered from the first second live and from 300 s in batch.
    osc = preset("ocxo")
    free, _ = _free_phase(osc, STEPS, 2, root_seed(1))
    pipe = reference_pipeline(_WarmupServo(dac=Dac.for_oscillator(osc)), osc).fit()
    frame = reference_frame(recording, free, reference_spread_s(recording))
    batch = pipe.run(frame)
    assert not np.asarray(batch["used"])[:, :300].any() and np.asarray(batch["used"])[:, 300:].all()
    assert _mismatches(batch, _stream(pipe, frame, (150, 301)), REFERENCE_NAMES, rtol=0.0) == []


def test_the_recorded_references_calibration_uses_only_its_first_four_hours(real_data):
    # No second of a --reference run depends on a later one: the cable offset, the servo's noise and the state
    # machine's margin come from the first CALIBRATION_S seconds, so a prefix of the record calibrates the same.
    from chronofuse.experiments.gnssdo import CALIBRATION_S, reference_offset_s, reference_sigma_s

    whole = read_pps_reference(real_data / "stability" / "gps" / "gps_1pps_phase_data.txt.gz")
    prefix = whole[:CALIBRATION_S + 1]
    for calibrate in (reference_offset_s, reference_sigma_s, reference_spread_s):
        assert calibrate(prefix) == calibrate(whole)
    later = whole.copy()
    later[CALIBRATION_S:] += 1e-6  # what happens after the calibration does not move it
    assert reference_offset_s(later) == reference_offset_s(whole)
    # and it is the record's offset: the whole-record mean is within a few ns of it on this receiver
    assert abs(reference_offset_s(whole) - np.mean(whole)) < 20e-9

"""Pipelines of stages: the contract (columns named once, fit in order, run mutates nothing) and streaming
equal to batch on whole pipelines, not only on single stages: the detection pipeline over hypothesis-drawn
scenarios (steps, ramps, drag-offs, millisecond resets, gaps, fix losses, training lengths), fed in any
chunks, and the whole GNSSDO chain second by second against its batch run."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from chronofuse.estimation.pipeline import Pipeline, compare_streaming_to_batch
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.integrity.watch import ClockWatch, DetectionSettings, detection_pipeline, watch_record
from chronofuse.io.grid import GridPlacer
from chronofuse.record import EpochRecord

NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0)


class _Add:
    needs = ("x",)
    gives = ("y",)

    def __init__(self):
        self.fitted_on = None

    def fit(self, frame=None):
        self.fitted_on = None if frame is None else np.asarray(frame["x"]).copy()
        return self

    def reset(self):
        self.total = 0.0

    def step(self, epoch):
        self.total += float(epoch["x"])
        return {"y": self.total}

    def run(self, frame):
        return {"y": np.cumsum(frame["x"])}


class _Twice(_Add):
    needs = ("y",)
    gives = ("z",)

    def fit(self, frame=None):
        self.seen = None if frame is None else np.asarray(frame["y"]).copy()
        return self

    def step(self, epoch):
        return {"z": 2 * epoch["y"]}

    def run(self, frame):
        return {"z": 2 * np.asarray(frame["y"])}


def test_a_stage_may_not_give_a_column_an_earlier_stage_gives():
    with pytest.raises(ValueError, match="already given"):
        Pipeline([("a", _Add()), ("b", _Add())])
    pipe = Pipeline([("a", _Add()), ("b", _Twice())])
    assert pipe.inputs == ("x",) and set(pipe.gives) == {"y", "z"}


def test_each_stage_is_fitted_on_the_training_frame_as_the_stages_before_it_transform_it():
    pipe = Pipeline([("a", _Add()), ("b", _Twice())]).fit({"x": np.array([1.0, 2.0, 3.0])})
    np.testing.assert_array_equal(pipe["b"].seen, [1.0, 3.0, 6.0])


def test_run_gives_read_only_columns_and_leaves_the_streaming_state_alone():
    pipe = Pipeline([("a", _Add()), ("b", _Twice())]).fit()
    pipe.reset()
    pipe.step({"x": 5.0})
    result = pipe.run({"x": np.arange(4.0)})
    assert not result["z"].flags.writeable
    assert pipe.step({"x": 1.0})["y"] == 6.0
    assert compare_streaming_to_batch(pipe, {"x": np.arange(10.0)}) == []


def test_the_comparison_finds_a_stage_whose_step_and_run_disagree():
    class Wrong(_Add):
        def run(self, frame):
            return {"y": np.cumsum(frame["x"]) + (np.arange(len(frame["x"])) == 3)}

    problems = compare_streaming_to_batch(Pipeline([("w", Wrong())]).fit(), {"x": np.ones(6)})
    assert problems and "first at epoch 3" in problems[0]


@st.composite
def scenarios(draw):
    """A clock-bias stream of 1 Hz epochs with what a receiver and an anomaly do to it, and how it arrives."""
    steps = draw(st.integers(120, 500))
    seed = draw(st.integers(0, 10_000))
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=steps, trials=1, seed=seed).measured_s[0]
    kind = draw(st.sampled_from(["none", "step", "ramp", "drag", "reset"]))
    onset = float(draw(st.integers(40, steps - 20)))
    if kind == "step":
        x = inject(x, Anomaly("step", onset, offset_s=draw(st.floats(2e-9, 5e-7))), 1.0)
    elif kind == "ramp":
        x = inject(x, Anomaly("ramp", onset, rate_s_per_s=draw(st.floats(1e-10, 1e-7))), 1.0)
    elif kind == "drag":
        x = inject(x, Anomaly("drag", onset, accel_s_per_s2=draw(st.floats(1e-12, 1e-9))), 1.0)
    elif kind == "reset":
        x = x.copy()
        x[int(onset):] += draw(st.sampled_from([-1e-3, 1e-3, 2e-3]))
    gaps = draw(st.lists(st.integers(0, steps - 1), max_size=6))
    x[gaps] = np.nan
    valid = np.ones(steps, dtype=bool)
    if draw(st.booleans()):
        lost = draw(st.integers(0, steps - 30))
        valid[lost : lost + draw(st.integers(1, 25))] = False
    t0 = draw(st.integers(0, 2**62 // 2))
    train = draw(st.sampled_from([None, 30.0, 60.0, 100.5]))
    chunks = draw(st.lists(st.integers(1, 60), min_size=1, max_size=30))
    return t0, x, valid, train, chunks


WINDOW = 10


def _settings(train):
    if train is None:
        return DetectionSettings(window=WINDOW, h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m)
    return DetectionSettings(window=WINDOW, train_s=train)
_COLUMNS = ("status", "repaired_bias_s", "clock_reset_s", "detector_input_s", "statistic", "threshold", "dof", "over",
            "state", "latch_event")


def _same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind == "f":
        return bool(np.allclose(a, b, rtol=1e-12, atol=0.0, equal_nan=True))
    return a.tolist() == b.tolist()


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios())
def test_the_detection_pipeline_streamed_in_any_chunks_equals_its_batch_run(scenario):
    t0, x, valid, train, chunks = scenario
    t = t0 + np.arange(x.size, dtype=np.int64) * 10**9
    raw = EpochRecord.from_arrays(t, {"clock_bias_s": x}, {"clock_bias_s": "s"}, source="scenario", valid=valid)
    # the grid: the whole record at once, and the same epochs arriving in the drawn chunks
    placer = GridPlacer()
    whole = EpochRecord.concat([placer.push(raw), placer.close()])
    settings_ = _settings(train)
    batch = watch_record(whole, settings_)
    watch, placer, a = ClockWatch(settings_), GridPlacer(), 0
    verdicts = []
    for n in chunks * (x.size // sum(chunks) + 1):
        if a >= x.size:
            break
        verdicts += watch.push(placer.push(raw[a : a + n]))
        a += n
    verdicts += watch.push(placer.close())
    watch.close()
    streamed = watch.result()
    assert streamed.fitted == batch.fitted and streamed.reasons == batch.reasons
    for name in _COLUMNS:
        assert _same(streamed.result[name], batch.result[name]), name
    # what the live driver said as it went: the batch verdicts (training epochs: unavailable while they arrive)
    after = ~batch.training
    assert [v.t_ns for v in verdicts] == np.asarray(whole.t_ns).tolist()
    assert [v.state for v, keep in zip(verdicts, after) if keep] == list(np.asarray(batch.result["state"])[after])


def test_the_fitted_detection_pipeline_steps_exactly_as_it_runs_on_a_ramp_with_resets_and_gaps():
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=1500, trials=1, seed=8).measured_s[0]
    x = inject(x, Anomaly("ramp", 600.0, rate_s_per_s=3e-8, duration_s=300.0), 1.0)
    x[1000:] += 1e-3  # a millisecond reset
    x[[200, 201, 1300]] = np.nan
    settings_ = DetectionSettings(train_s=300.0)
    pipe = detection_pipeline(settings_, 1.0)
    frame = {"t_ns": np.arange(1500, dtype=np.int64) * 10**9, "clock_bias_s": x, "valid": np.ones(1500, bool),
             "training": np.arange(1500) < 300}
    prepared = Pipeline(pipe.stages[:2]).run(frame)
    pipe.fit({k: np.asarray(v)[:300] for k, v in prepared.columns.items()})
    assert compare_streaming_to_batch(pipe, frame) == []
    state = pipe.run(frame)["state"]
    assert (state[620:900] == "alarm").all() and state[-1] == "ok"  # latched through the ramp, cleared after


def _gnssdo_inputs(integrity: bool, steps: int = 900):
    from chronofuse.discipline.chain import ChainConfig, gnssdo_frame
    from chronofuse.discipline.dac import Dac
    from chronofuse.experiments.gnssdo import DEFAULT_CONTROLLER, _free_phase, make_controller, scenario_environment
    from chronofuse.models.oscillator_presets import preset
    from chronofuse.models.receiver import simulate_receivers
    from chronofuse.seeding import child_seed, root_seed

    root = root_seed(3)
    osc = preset("ocxo")
    env = scenario_environment("urban-canyon", steps)
    free, _ = _free_phase(osc, steps, 2, root)
    rx = simulate_receivers(env, steps, 3, child_seed(root, 1), trials=2)
    servo = make_controller(DEFAULT_CONTROLLER, osc, env, 3, Dac.for_oscillator(osc))
    config = ChainConfig(integrity_pfa=1e-2 if integrity else None, integrity_train_s=200.0, alarm_hold_s=30.0)
    return servo, config, gnssdo_frame(free, rx.pps_error_s, rx.epochs)


@pytest.mark.slow
@pytest.mark.parametrize("integrity", [False, True])
def test_the_whole_gnssdo_chain_second_by_second_equals_its_batch_run(integrity):
    from chronofuse.discipline.stages import gnssdo_pipeline

    servo, config, frame = _gnssdo_inputs(integrity)
    pipe = gnssdo_pipeline(servo, config, 10**9).fit()
    names = ["usable", "excluded", "reference_error_s", "phase_s", "offset_s", "gnssdo_state", "gnssdo_reason"]
    assert compare_streaming_to_batch(pipe, frame, rtol=1e-9, atol=1e-15, names=names) == []
    if integrity:
        assert np.asarray(pipe.run(frame)["integrity_alarm"]).any()  # the chain's integrity did something


@pytest.mark.parametrize("name", ["cusum", "single-epoch"])
def test_another_detector_runs_in_the_same_pipeline_and_streams_as_it_runs(name):
    from chronofuse.integrity.baselines import CusumDetector, SingleEpochDetector

    def make(interval_s, s):
        model = dict(h0=s.h0, hm2=s.hm2, sigma_rho_m=s.sigma_rho_m)
        if name == "cusum":
            return CusumDetector(interval_s=interval_s, window=s.window, pfa=s.pfa, **model)
        return SingleEpochDetector(interval_s=interval_s, pfa=s.pfa, **model)

    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=800, trials=1, seed=9).measured_s[0]
    x = inject(x, Anomaly("step", 500.0, offset_s=1e-7), 1.0)
    x[300:] += 1e-3  # a millisecond reset: repaired before the detector, whichever it is
    t = np.arange(800, dtype=np.int64) * 10**9
    record = EpochRecord.from_arrays(t, {"clock_bias_s": x}, {"clock_bias_s": "s"}, source="sim", interval_ns=10**9)
    s = DetectionSettings(h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m, detector=make)
    batch = watch_record(record, s)
    watch = ClockWatch(s)
    for part in record.chunks(37):
        watch.push(part)
    watch.close()
    for column in _COLUMNS:
        assert _same(watch.result().result[column], batch.result[column]), column
    over = np.flatnonzero(np.asarray(batch.result["over"]))
    assert type(batch.detector).__name__.lower().startswith(name.split("-")[0])
    assert any(500 <= k <= 502 for k in over) and np.count_nonzero(batch.result["clock_reset_s"]) == 1

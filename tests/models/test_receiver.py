"""Tests of the GNSS timing-receiver truth model."""

from __future__ import annotations

import dataclasses
import datetime as dt

import allantools
import numpy as np
import pytest
from scipy import stats
from scipy.optimize import least_squares

from _helpers import read_stable32_table
from chronofuse.analysis.theory import corrected_pps_adev
from chronofuse.models.environment import ENVIRONMENTS, ReceiverEnvironment, receiver_environment
from chronofuse.models.receiver import DEFAULT_START_GPS_S, ReceiverTruth, sawtooth_s, simulate_receivers
from chronofuse.models.receiver_model import ReceiverModel
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns, gps_ns_to_utc

OPEN_SKY = ENVIRONMENTS["open-sky"].model
QUIET = dataclasses.replace(OPEN_SKY, white_sigma_s=0.0, multipath_sigma_s=0.0, wander_sigma_s=0.0)


def corrected(truth: ReceiverTruth) -> np.ndarray:
    """1PPS error with the announced qErr applied (u-blox sign: add it)."""
    return truth.pps_error_s + truth.epochs.qerr_s


def test_qerr_cancels_the_sawtooth_of_a_noiseless_receiver():
    truth = simulate_receivers(ReceiverEnvironment("quiet", QUIET), 5000, 3, seed=1)
    tick_s = 1.0 / QUIET.tick_hz
    assert np.abs(truth.pps_error_s).max() <= tick_s / 2 * (1 + 1e-9)
    # A uniform sawtooth over one tick: variance T^2 / 12.
    assert np.var(truth.pps_error_s) == pytest.approx(tick_s**2 / 12, rel=0.05)
    assert np.abs(corrected(truth)).max() <= 0.5e-12 + 1e-18


def test_sawtooth_puts_the_edge_on_the_nearest_tick():
    # Ticks every 1 ns at integer ns; the receiver aims 0.3 ns, then 1.8 ns, after whole seconds.
    aims = np.array([[[0.3e-9, 1.8e-9]]])
    q = sawtooth_s(aims, np.zeros((1, 1)), tick_hz=1e9, dt_s=1.0)
    np.testing.assert_allclose(q, [[[-0.3e-9, 0.2e-9]]], rtol=0, atol=1e-18)
    # A tick phase of 0.25 shifts the ticks by 0.25 ns.
    np.testing.assert_allclose(sawtooth_s(aims, np.full((1, 1), 0.25), 1e9, 1.0), [[[-0.05e-9, 0.45e-9]]],
                               rtol=0, atol=1e-18)
    # A clock of 1e9 + 0.2 ticks per second slips 0.2 tick per second against whole seconds.
    f_hz = 1e9 + 0.2
    np.testing.assert_allclose(sawtooth_s(np.zeros((1, 1, 3)), np.zeros((1, 1)), f_hz, 1.0),
                               [[[0.0, -0.2 / f_hz, -0.4 / f_hz]]], rtol=0, atol=1e-15)  # f_hz is rounded


def test_qerr_removal_leaves_white_plus_multipath_with_theoretical_std():
    model = dataclasses.replace(OPEN_SKY, wander_sigma_s=0.0, multipath_tau_s=5.0)
    truth = simulate_receivers(ReceiverEnvironment("no-wander", model), 20000, 4, seed=2)
    # White noise is scaled by GDOP/median = exp(s z), z ~ N(0, 1): E[(G/median)^2] = exp(2 s^2).
    var_theory = model.white_sigma_s**2 * np.exp(2 * model.gdop_log_sigma**2) + model.multipath_sigma_s**2
    assert np.std(corrected(truth)) == pytest.approx(np.sqrt(var_theory), rel=0.03)
    # The sawtooth is independent of the rest: raw variance = corrected variance + T^2 / 12.
    tick_s = 1.0 / model.tick_hz
    assert np.var(truth.pps_error_s) == pytest.approx(np.var(corrected(truth)) + tick_s**2 / 12, rel=0.05)


def test_multipath_autocorrelation_matches_exp_minus_lag_over_tau():
    model = dataclasses.replace(QUIET, multipath_sigma_s=10e-9, multipath_tau_s=20.0)
    x = corrected(simulate_receivers(ReceiverEnvironment("multipath", model), 40000, 8, seed=4))[0]
    x = x - x.mean(axis=-1, keepdims=True)
    var = np.mean(x * x)
    assert np.sqrt(var) == pytest.approx(10e-9, rel=0.05)
    for lag in (1, 5, 20, 40):
        rho = np.mean(x[:, :-lag] * x[:, lag:]) / var
        assert rho == pytest.approx(np.exp(-lag / 20.0), abs=0.04), lag


def test_open_sky_keeps_a_fix_with_gdop_below_two():
    truth = simulate_receivers("open-sky", 20000, 4, seed=5)
    ep = truth.epochs
    assert ep.has_fix.all() and (ep.fix_mode == 3).all() and ep.time_valid.all()
    assert np.mean(ep.gdop < 2.0) > 0.999
    assert ep.n_sats.min() >= 4
    assert np.isfinite(truth.pps_error_s).all()


def test_urban_canyon_gdop_and_fix_loss_follow_the_model_laws():
    model = ENVIRONMENTS["urban-canyon"].model
    truth = simulate_receivers("urban-canyon", 40000, 8, seed=6)
    ep = truth.epochs
    # GDOP is log-normal: P(GDOP > 5 | fix) = P(5 < G <= gdop_fix_max) / P(G <= gdop_fix_max).
    law = stats.lognorm(s=model.gdop_log_sigma, scale=model.gdop_median)
    expect = (law.cdf(model.gdop_fix_max) - law.cdf(5.0)) / law.cdf(model.gdop_fix_max)
    assert expect > 0.2  # "frequent GDOP > 5"
    assert np.mean(ep.gdop[ep.has_fix] > 5.0) == pytest.approx(expect, abs=0.05)
    # Outages start as a Poisson process and last geometric times: an M/G/inf occupancy, so the
    # receiver has no outage with probability exp(-rate * mean length).
    p_start = 1 - np.exp(-model.outage_rate_hz)
    expect_fix = np.exp(-p_start * model.outage_mean_s) * law.cdf(model.gdop_fix_max)
    assert ep.has_fix.mean() == pytest.approx(expect_fix, abs=0.008)
    lost = ~ep.has_fix
    assert lost.any()
    assert np.isnan(truth.pps_error_s[lost]).all() and np.isnan(ep.gdop[lost]).all()
    assert np.isnan(ep.clock_bias_s[lost]).all() and np.isnan(ep.qerr_s[lost]).all()
    assert ep.n_sats[lost].max() <= 3 and (ep.fix_mode[lost] == 1).all() and not ep.time_valid[lost].any()


def test_clock_bias_second_difference_has_the_spec_section_4_autocorrelation():
    """The noise model: r(0) = (2 q1 ts + 2/3 q2 ts^3 + 6 s2) / ts^2, r(1) = (-q1 ts + 1/6 q2 ts^3 - 4 s2) / ts^2,
    r(2) = s2 / ts^2, r(3) = 0, with q1 = h0 / 2, q2 = 2 pi^2 h_-2 and s2 the white measurement variance."""
    ts = 2.0
    model = dataclasses.replace(QUIET, white_sigma_s=1e-9, gdop_log_sigma=0.0, clock_h0=2e-17, clock_hm2=1e-18)
    bias = simulate_receivers(ReceiverEnvironment("clock", model), 80000, 4, seed=14, rate_hz=1 / ts).epochs.clock_bias_s[0]
    df = (bias[:, 2:] - 2 * bias[:, 1:-1] + bias[:, :-2]) / ts
    q1, q2, s2 = model.clock_h0 / 2, 2 * np.pi**2 * model.clock_hm2, model.white_sigma_s**2
    r0 = (2 * q1 * ts + 2 / 3 * q2 * ts**3 + 6 * s2) / ts**2
    theory = np.array([r0, (-q1 * ts + q2 * ts**3 / 6 - 4 * s2) / ts**2, s2 / ts**2, 0.0])
    sample = np.array([np.mean(df[:, : df.shape[1] - lag] * df[:, lag:]) for lag in range(4)])
    np.testing.assert_allclose(sample / r0, theory / r0, atol=0.03)


def test_jamming_window_has_no_fix_and_no_pulse():
    sc = receiver_environment("jamming")
    truth = simulate_receivers(sc, 1800, 3, seed=7, trials=2)
    inside = (truth.t_s >= sc.jamming_start_s) & (truth.t_s < sc.jamming_start_s + sc.jamming_duration_s)
    assert inside.sum() == 600
    assert not truth.epochs.has_fix[..., inside].any()
    assert np.isnan(truth.pps_error_s[..., inside]).all()
    assert (truth.epochs.n_sats[..., inside] == 0).all()
    assert truth.epochs.has_fix[..., ~inside].all()


@pytest.mark.parametrize(("rate_s_per_s", "accel_s_per_s2"), [(2e-9, 0.0), (0.0, 1e-11), (1e-9, 4e-12)])
def test_spoofing_drag_off_equals_its_formula_while_the_fix_stays_good(rate_s_per_s, accel_s_per_s2):
    spoofed = dataclasses.replace(receiver_environment("spoofing"), spoof_rate_s_per_s=rate_s_per_s,
                                  spoof_accel_s_per_s2=accel_s_per_s2)
    honest = ReceiverEnvironment("honest", spoofed.model)
    a = simulate_receivers(spoofed, 1500, 2, seed=8)
    b = simulate_receivers(honest, 1500, 2, seed=8)
    since = np.maximum(a.t_s - 600.0, 0.0)
    formula = rate_s_per_s * since + 0.5 * accel_s_per_s2 * since**2
    np.testing.assert_allclose(a.spoof_offset_s, np.broadcast_to(formula, a.spoof_offset_s.shape), rtol=1e-15, atol=0)
    assert a.epochs.has_fix.all() and np.nanmax(a.epochs.gdop) < 2.0
    # Same seed, same noise: the clock bias and the corrected 1PPS move by exactly the drag-off.
    np.testing.assert_allclose(a.epochs.clock_bias_s - b.epochs.clock_bias_s, a.spoof_offset_s, rtol=0, atol=1e-15)
    np.testing.assert_allclose(corrected(a) - corrected(b), a.spoof_offset_s, rtol=0, atol=1.01e-12)


def test_a_receiver_stream_does_not_depend_on_how_many_ran():
    small = simulate_receivers("urban-canyon", 600, 2, seed=9)
    large = simulate_receivers("urban-canyon", 600, 5, seed=9, trials=3)
    again = simulate_receivers("urban-canyon", 600, 2, seed=np.random.SeedSequence(9))
    np.testing.assert_array_equal(small.pps_error_s[0], large.pps_error_s[0, :2])
    np.testing.assert_array_equal(small.epochs.clock_bias_s, again.epochs.clock_bias_s)
    assert not np.array_equal(large.epochs.clock_bias_s[1, 0], large.epochs.clock_bias_s[2, 0])
    assert not np.array_equal(large.epochs.clock_bias_s[0, 0], large.epochs.clock_bias_s[0, 1])


def test_stream_seeds_are_the_documented_seed_sequence_children():
    # Receiver 1 of trial 2 is seeded by root.spawn(3)[2].spawn(2)[1]: a Generator with that seed
    # draws the first white-noise normals, whose scaled value is the only noise of this model.
    model = dataclasses.replace(QUIET, white_sigma_s=1e-9, gdop_log_sigma=0.0)
    truth = simulate_receivers(ReceiverEnvironment("white", model), 50, 2, seed=21, trials=3)
    child = np.random.SeedSequence(21).spawn(3)[2].spawn(2)[1]
    white = np.random.default_rng(child).standard_normal(50) * 1e-9
    np.testing.assert_allclose(corrected(truth)[2, 1], white, rtol=0, atol=1e-12)
    with pytest.raises(ValueError):
        truth.pps_error_s[0, 0, 0] = 0.0


def test_receivers_have_independent_errors():
    truth = simulate_receivers("open-sky", 20000, 4, seed=10)
    d = np.diff(corrected(truth)[0], axis=-1)
    r = np.corrcoef(d)
    off = r[~np.eye(4, dtype=bool)]
    # 2e4 samples: a sample correlation of independent series has sd ~ 1/sqrt(2e4) = 0.007.
    assert np.abs(off).max() < 0.035


def test_utc_label_is_gps_minus_leap_and_the_leap_is_announced():
    event = DEFAULT_START_GPS_S + 100
    truth = simulate_receivers("open-sky", 200, 1, seed=11, leap_event_gps_s=event, leap_announce_s=50)
    ep = truth.epochs
    gps_s = ep.gps_ns // NS_PER_S
    utc_s = ep.utc_ns()[0, 0] // NS_PER_S
    np.testing.assert_array_equal(utc_s, gps_s - ep.leap_s[0, 0])
    assert (ep.leap_s[0, 0][gps_s < event] == 18).all() and (ep.leap_s[0, 0][gps_s >= event] == 19).all()
    np.testing.assert_array_equal(ep.leap_pending[0, 0], (gps_s >= event - 50) & (gps_s < event))
    # The inserted second repeats one UTC label (POSIX style).
    assert len(np.unique(utc_s)) == len(utc_s) - 1
    # The default epoch is 2025-01-01T00:00:00 UTC (GPS - UTC = 18 s).
    utc0 = dt.datetime(1980, 1, 6) + dt.timedelta(seconds=int(utc_s[0]))
    assert utc0 == dt.datetime(2025, 1, 1)
    assert ep.gps_ns.dtype == np.int64 and ep.utc_ns().dtype == np.int64
    # Before the event the receiver's UTC is the leap-second table's (timescale.gps_ns_to_utc).
    before = gps_s < event
    np.testing.assert_array_equal(ep.utc_ns()[0, 0][before], datetime64_to_gps_ns(gps_ns_to_utc(ep.gps_ns[before])))


def test_decimated_runs_keep_integer_epochs_and_markov_time_constants():
    truth = simulate_receivers("open-sky", 1000, 1, seed=12, rate_hz=0.1)
    assert truth.pps_error_s.shape == (1, 1, 100)
    np.testing.assert_array_equal(np.diff(truth.epochs.gps_ns), 10 * NS_PER_S)


def test_to_frame_is_tidy_with_nanoseconds_at_the_edge():
    truth = simulate_receivers("jamming", 700, 3, seed=13, trials=2)
    frame = truth.to_frame(trial=1)
    assert len(frame) == 3 * 700
    assert list(frame.columns[:11]) == ["t_s", "receiver", "pps_error_ns", "qerr_ns", "fix", "n_sats", "gdop",
                                        "utc_s", "leap_s", "leap_pending", "clock_bias_ns"]
    row = frame[(frame.receiver == 3) & (frame.t_s == 5.0)].iloc[0]  # 1-based: array index 2
    assert row.pps_error_ns == pytest.approx(truth.pps_error_s[1, 2, 5] * 1e9)
    assert row.utc_s == truth.epochs.utc_ns()[1, 2, 5] // NS_PER_S
    assert frame.loc[frame.t_s >= 600, "pps_error_ns"].isna().all()


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: ReceiverModel(white_sigma_s=-1e-9), "white_sigma_s"),
        (lambda: ReceiverModel(tick_hz=0.0), "tick_hz"),
        (lambda: ReceiverModel(outlier_prob=1.5), "outlier_prob"),
        (lambda: ReceiverModel(multipath_tau_s=float("nan")), "multipath_tau_s"),
        (lambda: ReceiverModel(gdop_median=0.5), "gdop_median"),
        (lambda: ReceiverEnvironment("x", OPEN_SKY, spoof_accel_s_per_s2=float("inf")), "spoof_accel_s_per_s2"),
        (lambda: ReceiverEnvironment("x", OPEN_SKY, jamming_start_s=-5.0), "jamming_start_s"),
        (lambda: receiver_environment("desert"), "environment"),
        (lambda: simulate_receivers("open-sky", 100, 1, seed=0, rate_hz=0.3), "rate_hz"),
        (lambda: simulate_receivers("open-sky", 0, 1, seed=0), "duration_s"),
        (lambda: simulate_receivers("open-sky", 10, 0, seed=0), "n_receivers"),
        (lambda: simulate_receivers(ReceiverEnvironment("x", OPEN_SKY, affected_receivers=(3,)), 10, 2, seed=0),
         "affected_receivers"),
    ],
)
def test_validation_errors_name_the_field(make, field):
    with pytest.raises(ValueError, match=field):
        make()


def test_open_sky_preset_is_the_least_squares_fit_to_the_record_oadev_table(data_dir):
    """Refit white + two Gauss-Markov terms to Stable32's OADEV octave table (tau <= 8192 s) as the
    module docstring says, and check that the preset is that fit, to its printed rounding."""
    table = read_stable32_table(data_dir / "stability/gps/stable32_OADEV_octave.txt")
    keep = table["tau"] <= 8192
    tau, dev = table["tau"][keep], table["dev"][keep]

    def model_of(p):
        return dataclasses.replace(OPEN_SKY, gdop_log_sigma=0.0, white_sigma_s=np.exp(p[0]),
                                   multipath_sigma_s=np.exp(p[1]), multipath_tau_s=np.exp(p[2]),
                                   wander_sigma_s=np.exp(p[3]), wander_tau_s=np.exp(p[4]))

    fit = least_squares(lambda p: np.log(corrected_pps_adev(model_of(p), tau) / dev),
                        np.log([3e-9, 5e-9, 10.0, 5e-9, 1000.0]))
    best = model_of(fit.x)
    for name in ("white_sigma_s", "multipath_sigma_s", "multipath_tau_s", "wander_sigma_s", "wander_tau_s"):
        assert getattr(OPEN_SKY, name) == pytest.approx(getattr(best, name), rel=0.01), name
    preset_misfit = np.abs(np.log(corrected_pps_adev(OPEN_SKY, tau) / dev)).max()
    assert preset_misfit < 0.04
    assert preset_misfit < np.abs(fit.fun).max() + 0.01


def test_theoretical_adev_matches_the_simulated_one():
    taus = np.array([1.0, 4.0, 32.0, 256.0, 2048.0])
    truth = simulate_receivers("open-sky", 50_000, 6, seed=15)
    sim = np.sqrt(np.mean([allantools.oadev(x, rate=1.0, data_type="phase", taus=taus)[1] ** 2
                           for x in corrected(truth)[0]], axis=0))
    np.testing.assert_allclose(sim, corrected_pps_adev(OPEN_SKY, taus), rtol=0.1)


def test_gps_record_shows_no_48mhz_sawtooth(data_dir):
    """The reason the calibration compares the qErr-corrected series (module docstring, step 1)."""
    x = np.loadtxt(data_dir / "stability/gps/gps_1pps_phase_data.txt.gz")
    d2 = x[2:] - 2 * x[1:-1] + x[:-2]
    adev1_s = np.sqrt(np.mean(d2**2) / 2)
    sawtooth_only_s = np.sqrt(3) * (1 / 48e6) / np.sqrt(12)  # ADEV(1 s) of an i.i.d. uniform sawtooth
    assert adev1_s < 0.65 * sawtooth_only_s
    # Gaussian short-term noise (kurtosis 3); a uniform sawtooth's second difference has 2.4.
    assert stats.kurtosis(d2, fisher=False) == pytest.approx(3.0, abs=0.1)


def test_open_sky_corrected_1pps_has_the_adev_of_the_gps_maser_record(data_dir):
    table = read_stable32_table(data_dir / "stability/gps/stable32_ADEV_decade.txt")
    taus = np.array([1.0, 10.0, 100.0, 1000.0, 10000.0])
    ref = np.array([table["dev"][table["tau"] == t][0] for t in taus])
    truth = simulate_receivers("open-sky", 100_000, 8, seed=2016)

    def pooled_oadev(x):
        avar = [allantools.oadev(series, rate=1.0, data_type="phase", taus=taus)[1] ** 2 for series in x]
        return np.sqrt(np.mean(avar, axis=0))

    ratio = pooled_oadev(corrected(truth)[0]) / ref
    assert np.all((ratio > 1 / 1.2) & (ratio < 1.2)), ratio
    # With the 48 MHz sawtooth left in, 1 s stability is about twice the record's.
    raw_ratio = pooled_oadev(truth.pps_error_s[0][:, :20000])[0] / ref[0]
    assert raw_ratio > 1.5

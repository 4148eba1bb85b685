"""False alarms after training on real station clocks: the threshold's margin for a
noise fitted from few differences, the noise-change screen, and the rate over the stations with no event."""

import math

import numpy as np
import pytest
from scipy import linalg, stats

from chronofuse.integrity.detector import HodDetector, difference_autocorrelation, effective_squares
from chronofuse.integrity.modes import detect_file
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.integrity.stationarity import NOISE_CHANGE_ALPHA, noise_change


def _pfa_given_model(fitted: HodDetector, true_r, draws) -> float:
    """Exact P_fa of a full window of ``fitted`` on data of autocorrelation ``true_r``: ``T`` is a sum of chi2(1)
    weighted by the eigenvalues of ``D C D^T``, its tail evaluated on fixed chi2(1) draws."""
    n = fitted.whitener_.shape[0]
    col = np.zeros(n)
    col[:3] = true_r
    weights = np.linalg.eigvalsh(fitted.whitener_ @ linalg.toeplitz(col) @ fitted.whitener_.T)
    return float(((draws @ weights) > fitted.threshold_).mean())


def test_effective_squares_of_a_mean_square_match_the_simulated_variance_of_ma2_differences():
    # white phase noise only: df is the (1, -2, 1) filter of white noise, rho1 = -2/3, rho2 = 1/6
    r = difference_autocorrelation(0.0, 0.0, 1.0, 1.0)
    m = 50
    expected = m / (1.0 + 2.0 * ((2 / 3) ** 2 + (1 / 6) ** 2))
    assert effective_squares(m, r) == pytest.approx(expected)
    z = np.random.default_rng(3).standard_normal((20_000, m + 2))
    ms = np.mean(np.diff(z, 2, axis=1) ** 2, axis=1) / 6.0  # r(0) = 6 for unit white noise
    # a chi2(m_eff) / m_eff has variance 2 / m_eff
    assert np.var(ms) == pytest.approx(2.0 / expected, rel=0.08)


@pytest.mark.slow
@pytest.mark.parametrize("n_diff", [18, 100, 1000])
@pytest.mark.parametrize("noise", [ClockNoise(0.0, 0.0, 0.3), ClockNoise(3e-20, 1e-25, 0.09)], ids=["white PM", "mixed"])
def test_the_training_margin_keeps_pfa_at_or_below_nominal_in_90_percent_of_short_trainings(noise, n_diff):
    # the GRG clock product's setting: 30 s epochs, window 5, P_fa 1 %, 18 training differences per station
    pfa, ts, trials = 0.01, 30.0, 80
    true_r = difference_autocorrelation(noise.h0, noise.hm2, noise.sigma_rho_m, ts)
    draws = np.random.default_rng(1).standard_normal((40_000, 5)) ** 2
    x = simulate_clock_bias(noise, interval_s=ts, steps=n_diff + 2, trials=trials, seed=11).measured_s
    rates = np.array([_pfa_given_model(HodDetector(interval_s=ts, window=5, pfa=pfa, confidence=0.9).fit(row),
                                       true_r, draws) for row in x])
    assert (rates <= pfa).mean() >= 0.9, np.quantile(rates, [0.5, 0.9])


def test_the_noise_change_p_value_is_uniform_under_h0_and_finds_a_fourfold_variance_half_the_time():
    noise = ClockNoise(3e-20, 1e-25, 0.09)
    r = difference_autocorrelation(noise.h0, noise.hm2, noise.sigma_rho_m, 30.0)
    x = simulate_clock_bias(noise, interval_s=30.0, steps=45, trials=400, seed=5).measured_s
    df = np.diff(x, 2, axis=1) / 30.0
    p = np.array([noise_change(row[:18], row[18:], r)[1] for row in df])
    # Kolmogorov-Smirnov against U(0, 1): the equivalent-dof F test is an approximation, so 1 % level
    assert stats.kstest(p, "uniform").pvalue > 0.01
    assert (p < NOISE_CHANGE_ALPHA).mean() < 3 * NOISE_CHANGE_ALPHA
    # 18 against 25 correlated differences: a fourfold variance is found about half the time, ninefold nearly always
    doubled = np.array([noise_change(row[:18], 2.0 * row[18:], r)[1] for row in df])
    assert (doubled < NOISE_CHANGE_ALPHA).mean() > 0.4
    tripled = np.array([noise_change(row[:18], 3.0 * row[18:], r)[1] for row in df])
    assert (tripled < NOISE_CHANGE_ALPHA).mean() > 0.9


@pytest.fixture(scope="module")
def grg(real_data):
    return detect_file(real_data / "receivers/rinex/gnss_lib_py/grg21553.clk.gz", train_s=600.0, window=5, pfa=0.01)


@pytest.mark.slow
def test_after_training_the_grg_stations_with_no_event_alarm_within_twice_the_nominal_rate(grg):
    """Alarms over the tested epochs of the GRG stations with no clock event and no noise change.

    Tolerance: the issue asks for at most 2x nominal. If the detector ran exactly at nominal (1 %), the
    2068-odd tested epochs would see ~21 alarms; alarms of one event come in runs of up to window + 2 = 7
    epochs, so the count is about 5 x Binomial(~414 blocks, 1 %): mean 21, standard deviation ~10, and
    exceeding 2x (41) has a probability of a few percent. The 90 % confidence margin puts the expected rate
    below nominal (~0.3 % at 18 training differences in the simulation above), so passing at 2x is not luck
    of a nominal detector; and a rate of 0 would mean the screen had removed every alarm, so at least one
    alarm must remain among the quiet stations (they are not chosen by having none).
    """
    fa = grg["false_alarms"]
    assert fa["clock_event"] == ["TIXI", "CAS1"]
    assert len(fa["no_event"]) >= 90 and not fa["untested"]
    assert fa["n_tested"] >= 90 * 20
    assert 0 < fa["n_alarms"] <= 2 * fa["nominal"] * fa["n_tested"]
    # the stations set aside are those whose noise grew: every one of them with a ratio above 2.5
    rows = {r["station"]: r for r in grg["stations"]}
    assert all(rows[name]["noise_change"]["ratio"] > 2.5 for name in fa["noise_changed"])
    # and they are more than the screen's own error rate explains (binomial tail under H0 below 1e-4)
    assert stats.binom.sf(len(fa["noise_changed"]) - 1, len(fa["no_event"]) + len(fa["noise_changed"]),
                          NOISE_CHANGE_ALPHA) < 1e-4


@pytest.mark.slow
def test_every_millisecond_reset_of_the_grg_product_is_a_clock_event_not_an_alarm(grg):
    rows = {r["station"]: r for r in grg["stations"]}
    for name in grg["false_alarms"]["clock_event"]:
        events = rows[name]["clock_events"]
        sizes = np.array([e["size_s"] for e in events])
        np.testing.assert_allclose(np.abs(sizes), np.round(np.abs(sizes) / 1e-3) * 1e-3)
        assert rows[name]["n_alarms"] == 0, name


@pytest.mark.parametrize("n_diff", [18, 100, 1000])
def test_the_outlier_screen_leaves_a_clean_training_alone(n_diff):
    from chronofuse.integrity.noise_model import training_outliers

    x = simulate_clock_bias(ClockNoise(3e-20, 1e-25, 0.09), interval_s=30.0, steps=n_diff + 2, trials=300,
                            seed=17).measured_s
    # at 6 robust sigma: ~2e-9 per difference for Gaussian noise, a few times more at 18 (the MAD varies)
    assert training_outliers(x).any(axis=1).mean() <= 0.01


@pytest.mark.parametrize("kind", ["spike", "step"])
def test_one_outlier_in_training_neither_inflates_the_fitted_noise_nor_is_missed(kind):
    noise = ClockNoise(3e-20, 1e-25, 0.09)
    clean = simulate_clock_bias(noise, interval_s=30.0, steps=102, trials=1, seed=23).measured_s[0]
    x = clean.copy()
    size = 40.0 * math.sqrt(difference_autocorrelation(noise.h0, noise.hm2, noise.sigma_rho_m, 30.0)[0]) * 30.0
    if kind == "spike":
        x[60] += size
    else:
        x[60:] += size
    fitted = HodDetector(interval_s=30.0, window=5, pfa=0.01).fit(x)
    plain = HodDetector(interval_s=30.0, window=5, pfa=0.01).fit(x, robust=False)
    reference = HodDetector(interval_s=30.0, window=5, pfa=0.01).fit(clean)
    assert fitted.training_outliers_[60]
    assert fitted.r_[0] == pytest.approx(reference.r_[0], rel=0.3)
    assert plain.r_[0] > 5 * reference.r_[0]  # what one outlier did to the fit before


@pytest.mark.slow
def test_a_spike_in_a_grg_stations_training_is_left_out_and_no_longer_blinds_it(grg, real_data):
    # NRIL: a spike of ~40 ns against ~1 ns of noise in the last minute of its 600 s training
    from chronofuse.io.rinex_clock import read_station_clocks, station_clock_bias

    clocks = read_station_clocks(real_data / "receivers/rinex/gnss_lib_py/grg21553.clk.gz")
    d2 = np.diff(station_clock_bias(clocks, "NRIL").columns["clock_bias_s"][:20], 2)
    assert np.abs(d2).max() > 30e-9 and 1.4826 * np.median(np.abs(d2 - np.median(d2))) < 2e-9
    row = next(r for r in grg["stations"] if r["station"] == "NRIL")
    assert any(w.startswith("training outliers: 2 epoch(s)") for w in row["warnings"])
    assert row["noise"]["sigma_rho_m"] < 0.5  # ~1 ns of second-difference noise, not the spike's ~10 ns
    assert row["n_alarms"] > 0  # the ~16 ns jump after the gap is seen


def test_a_reference_clock_written_coarser_than_its_noise_is_not_screened_and_does_not_alarm(real_data):
    # CODE's WAB200CHE: second differences of 0 and +-1e-18 s (the file's last digit); those ticks are not outliers
    path = real_data / "receivers/rinex/gnss_lib_py/COD0MGXFIN_20211180000_01D_30S_CLK.CLK"
    doc = detect_file(path, station="WAB200CHE", train_s=600.0, window=5, pfa=0.01)
    assert not any(w.startswith("training outliers") for w in doc["warnings"])
    assert doc["n_tested"] > 90 and doc["n_alarms"] == 0

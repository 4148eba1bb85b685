"""The stability engine through the public API, against every Stable32 table in tests/data/stability.

Deviations, term counts and averaging times are compared to Stable32's printed precision (5
significant digits). Known differences, each explained where it is tested:
- ocxo: Stable32's OADEV, MDEV, TDEV, OHDEV and TOTDEV tables disagree with its own ADEV/HDEV tables
  of the same file by 0.05-0.2 % (e.g. OADEV(1 s) = 7.6143e-11 but ADEV(1 s) = 7.6106e-11, which must be
  equal), so they were made from a slightly different record; ADEV and HDEV match to printed precision
  with y = (f - mean f) / mean f up to m = 256 and within 1.2e-4 beyond (the same with f / mean f or
  (f - 1e7) / 1e7, so not a normalisation question), and are compared at 2e-4; the other five at 2e-3.
- TOTDEV bias: Stable32 corrects with its own alpha; the Cs5071A and GPS TOTDEV tables carry alpha >= 0
  (no correction) on every row, where this engine identifies alpha < 0 on the last rows (B1 rows, see
  test_noise_id.py), so those tables are compared without correction.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from _helpers import assert_close_printed, read_stable32_table

import chronofuse.analysis.stability as st
from chronofuse.analysis.stability import STATISTICS, compute, tau_grid
from chronofuse.analysis.stability.convert import fill_gaps
from chronofuse.analysis.stability.kernels_allan import adev_raw
from chronofuse.analysis.stability.kernels_total import totdev_raw


# (data set, table file, statistic, bias_correction, relative tolerance or None for printed precision)
TABLES = [
    ("phasedat", "phase_dat_adev_octave.txt", "adev", True, None),
    ("phasedat", "phase_dat_oadev_octave.txt", "oadev", True, None),
    ("phasedat", "phase_dat_mdev_octave.txt", "mdev", True, None),
    ("phasedat", "phase_dat_tdev_octave.txt", "tdev", True, None),
    ("phasedat", "phase_dat_hdev_octave.txt", "hdev", True, None),
    ("phasedat", "phase_dat_ohdev_octave.txt", "ohdev", True, None),
    ("phasedat", "phase_dat_totdev_octave.txt", "totdev", True, None),
    ("phasedat", "phase_dat_mtotdev_octave.txt", "mtotdev", True, None),
    ("phasedat", "phase_dat_mtotdev_octave_alpha0.txt", "mtotdev", True, None),
    ("phasedat", "phase_dat_ttotdev_octave.txt", "ttotdev", True, None),
    ("phasedat", "phase_dat_htotdev_octave.txt", "htotdev", True, None),
    ("phasedat", "phase_dat_htotdev_octave_nobias.txt", "htotdev", False, None),
    ("ocxo", "adev_octave.txt", "adev", True, 2e-4),
    ("ocxo", "hdev_octave.txt", "hdev", True, 2e-4),
    ("ocxo", "oadev_octave.txt", "oadev", True, 2e-3),
    ("ocxo", "mdev_octave.txt", "mdev", True, 2e-3),
    ("ocxo", "tdev_octave.txt", "tdev", True, 2e-3),
    ("ocxo", "ohdev_octave.txt", "ohdev", True, 2e-3),
    ("gps", "stable32_ADEV_decade.txt", "adev", True, None),
    ("gps", "stable32_OADEV_octave.txt", "oadev", True, None),
    ("gps", "stable32_MDEV_octave.txt", "mdev", True, None),
    ("gps", "stable32_TDEV_octave.txt", "tdev", True, None),
    ("gps", "stable32_HDEV_octave.txt", "hdev", True, None),
    ("gps", "stable32_OHDEV_octave.txt", "ohdev", True, None),
    ("gps", "stable32_TOTDEV_octave.txt", "totdev", False, None),
    ("Cs5071A", "adev_decade.txt", "adev", True, None),
    ("Cs5071A", "oadev_decade.txt", "oadev", True, None),
    ("Cs5071A", "mdev_decade.txt", "mdev", True, None),
    ("Cs5071A", "tdev_decade.txt", "tdev", True, None),
    ("Cs5071A", "hdev_decade.txt", "hdev", True, None),
    ("Cs5071A", "ohdev_decade.txt", "ohdev", True, None),
    ("Cs5071A", "totdev_decade.txt", "totdev", False, None),
    ("Cs5071A", "tierms_decade.txt", "tie_rms", True, None),
    ("Cs5071A", "mtie_decade.txt", "mtie", True, None),
]


@pytest.mark.parametrize("dataset, table, statistic, bias, rtol", TABLES, ids=[f"{t[0]}-{t[1]}" for t in TABLES])
def test_public_functions_reproduce_stable32_deviation_tables(records, data_dir, dataset, table, statistic, bias, rtol):
    ref = read_stable32_table(data_dir / "stability" / dataset / table)
    fn = getattr(st, statistic)
    res = fn(records[dataset], 1.0, ref["tau"], bias_correction=bias)
    np.testing.assert_array_equal(res.tau_s, ref["tau"])
    np.testing.assert_array_equal(res.n, ref["n"])
    if rtol is None:
        assert_close_printed(res.dev, ref["dev"], name=f"{dataset}/{table}")
    else:
        np.testing.assert_allclose(res.dev, ref["dev"], rtol=rtol)
    assert res.bias_corrected == (bias and STATISTICS[statistic].bias is not None)


def test_ocxo_totdev_with_bias_correction_matches_stable32_where_alpha_agrees(records, data_dir):
    ref = read_stable32_table(data_dir / "stability" / "ocxo" / "totdev_octave.txt")
    res = st.totdev(records["ocxo"], 1.0, ref["tau"])
    same = res.alpha == ref["alpha"]
    assert same.sum() >= 10
    # Stable32's ocxo TOTDEV table carries the 0.05-0.2 % offset of its OADEV table (module docstring).
    np.testing.assert_allclose(res.dev[same], ref["dev"][same], rtol=2e-3)


def test_octave_grid_runs_to_the_statistic_range_and_fills_every_field(records):
    x = records["phasedat"]
    for name in STATISTICS:
        res = compute(name, x, 1.0, tau_grid("octave", x.size, 1.0, name))
        k = res.tau_s.size
        assert k >= 3, name
        for field in ("dev", "n", "alpha", "edf", "lo", "hi"):
            assert getattr(res, field).shape == (k,), (name, field)
        assert res.statistic == name and res.ci == 0.683
        assert np.all(np.isfinite(res.dev)) and np.all(res.n > 0)
        assert np.all((res.alpha >= -2) & (res.alpha <= 2))
        if STATISTICS[name].edf_family == "none":
            assert np.isnan(res.edf).all() and np.isnan(res.lo).all()
        else:
            assert np.all(res.lo < res.dev) and np.all(res.dev < res.hi), name
        # TheoH's last times are TheoBR's, 0.75 m tau0 (its first are OADEV's, m tau0)
        factor = 0.75 if name == "theoh" else STATISTICS[name].tau_factor
        m = np.rint(res.tau_s / factor).astype(int)
        assert m.max() <= STATISTICS[name].max_m(x.size)
        assert m.max() * 2 > STATISTICS[name].max_m(x.size)  # octave grid reaches the last octave


def test_wrappers_are_compute_by_name(records):
    x = records["phasedat"][:300]
    for name in STATISTICS:
        taus = tau_grid("decade", x.size, 2.0, name)
        a = getattr(st, name)(x, 2.0, taus, ci=0.9, bias_correction=False)
        b = compute(name, x, 2.0, taus, ci=0.9, bias_correction=False)
        np.testing.assert_array_equal(a.dev, b.dev)
        np.testing.assert_array_equal(a.hi, b.hi)
        assert a.ci == 0.9 and not a.bias_corrected


def test_sample_rate_scales_tau_and_fractional_frequency_statistics(records):
    x = records["phasedat"]
    one = st.oadev(x, 1.0, tau_grid("octave", x.size, 1.0, "oadev"))
    ten = st.oadev(x, 10.0, tau_grid("octave", x.size, 10.0, "oadev"))
    np.testing.assert_allclose(ten.tau_s, one.tau_s / 10)
    # ADEV ~ phase difference / tau: ten times the rate, ten times the deviation; TDEV (seconds) unchanged.
    np.testing.assert_allclose(ten.dev, 10 * one.dev, rtol=1e-12)
    np.testing.assert_allclose(st.tdev(x, 10.0, one.tau_s / 10).dev, st.tdev(x, 1.0, one.tau_s).dev, rtol=1e-12)


def test_explicit_taus_select_the_same_points_as_the_grid(records):
    x = records["phasedat"]
    grid = st.mdev(x, 1.0, tau_grid("octave", x.size, 1.0, "mdev"))
    pick = st.mdev(x, 1.0, np.array([4.0, 1.0, 32.0]))
    np.testing.assert_array_equal(pick.tau_s, [4.0, 1.0, 32.0])
    for tau, dev in zip(pick.tau_s, pick.dev):
        assert dev == grid.dev[grid.tau_s == tau][0]
    th = st.theo1(x, 1.0, [1.5, 7.5])
    np.testing.assert_array_equal(th.tau_s, [1.5, 7.5])


def test_taus_beyond_the_range_are_dropped_with_a_warning(records):
    x = records["phasedat"]
    with pytest.warns(UserWarning, match="dropped"):
        res = st.adev(x, 1.0, [1.0, 2.0, 5000.0])
    np.testing.assert_array_equal(res.tau_s, [1.0, 2.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        st.adev(x, 1.0, [1.0, 200.0])
    with pytest.warns(UserWarning), pytest.raises(ValueError, match="tau_s"):
        st.adev(x, 1.0, [5000.0])


def test_skip_policy_passes_gaps_to_the_kernel_and_reports_them(records):
    x = records["phasedat"].copy()
    x[[10, 11, 500, 777]] = np.nan
    octave = tau_grid("octave", x.size, 1.0, "adev")
    res = st.adev(x, 1.0, octave)
    assert res.skipped == 4 and res.filled == 0
    m = np.rint(res.tau_s).astype(np.int64)
    dev, n = adev_raw(x, m, 1.0)
    np.testing.assert_array_equal(res.dev, dev)
    np.testing.assert_array_equal(res.n, n)
    full = st.adev(records["phasedat"], 1.0, octave)
    assert np.all(res.n <= full.n) and res.n[0] < full.n[0]
    # A gap costs degrees of freedom.
    assert res.edf[0] < full.edf[0]


def test_fill_policy_interpolates_gaps_and_reports_them(records):
    x = records["phasedat"].copy()
    x[[0, 10, 11, 500]] = np.nan  # one leading (trimmed) and three interior
    res = st.totdev(x, 1.0, tau_grid("octave", x.size - 1, 1.0, "totdev"), bias_correction=False)
    assert res.filled == 4 and res.skipped == 0
    xf, count = fill_gaps(x)
    assert count == 4 and xf.size == x.size - 1
    m = np.rint(res.tau_s).astype(np.int64)
    np.testing.assert_allclose(res.dev, totdev_raw(xf, m, 1.0)[0], rtol=1e-13)


def test_mtie_windows_ignore_missing_samples(records):
    x = records["phasedat"].copy()
    x[100] = 1e3  # an outlier...
    spoiled = st.mtie(x, 1.0, [1.0])
    x[100] = np.nan  # ...removed as a gap
    clean = st.mtie(x, 1.0, [1.0])
    assert spoiled.dev[0] > 900 and clean.dev[0] < 10 and clean.skipped == 1


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(x_s=np.zeros((10, 2)), rate_hz=1.0), "x_s"),
        (dict(x_s=np.zeros(100), rate_hz=0.0), "rate_hz"),
        (dict(x_s=np.zeros(100), rate_hz=-1.0), "rate_hz"),
        (dict(x_s=np.zeros(100), rate_hz=1.0, tau_s=[1.5]), "tau_s"),
        (dict(x_s=np.zeros(100), rate_hz=1.0, ci=1.2), "ci"),
        (dict(x_s=np.full(100, np.nan), rate_hz=1.0), "x_s"),
        (dict(x_s=np.array([0.0, np.inf, 1.0]), rate_hz=1.0), "x_s"),
        (dict(x_s=np.zeros(3), rate_hz=1.0), "x_s"),
    ],
)
def test_bad_inputs_raise_errors_naming_the_parameter(kwargs, match):
    kwargs.setdefault("tau_s", [1.0])
    with pytest.raises(ValueError, match=match):
        st.adev(**kwargs)


def test_taus_are_an_array_only_and_the_grid_helper_names_the_statistic_that_does_not_fit():
    with pytest.raises(TypeError, match="tau_grid"):
        st.adev(np.zeros(100), 1.0, "octave")
    np.testing.assert_array_equal(tau_grid("octave", 1001, 2.0, "adev"), [0.5, 1, 2, 4, 8, 16, 32, 64])  # m <= 200
    theo_m = [m for m in (2, 4, 10, 20, 40, 100, 200, 400, 1000) if m <= STATISTICS["theo1"].max_m(1001)]
    np.testing.assert_array_equal(tau_grid("decade", 1001, 1.0, "theo1"), 0.75 * np.array(theo_m))
    with pytest.raises(ValueError, match="too few for hdev"):
        tau_grid("octave", 4, 1.0, "hdev")


def test_theo1_rejects_odd_averaging_factors_and_unknown_statistics_are_named():
    x = np.cumsum(np.random.default_rng(0).standard_normal(200))
    with pytest.raises(ValueError, match="tau_s"):
        st.theo1(x, 1.0, [0.75])  # m = 1, odd
    with pytest.raises(ValueError, match="statistic"):
        compute("allan", x, 1.0, [1.0])
    with pytest.raises(TypeError, match="bias_correction"):
        compute("adev", x, 1.0, [1.0], bias_correction="yes")


def test_public_api_lists_every_statistic():
    for name in STATISTICS:
        assert name in st.__all__ and callable(getattr(st, name))
    assert set(STATISTICS) == {
        "adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev", "mtotdev", "htotdev", "ttotdev",
        "theo1", "theobr", "theoh", "tie_rms", "mtie",
    }
    x = st.frequency_to_phase(np.ones(4), 1.0)
    np.testing.assert_array_equal(st.phase_to_frequency(x, 1.0), np.ones(4))
    np.testing.assert_array_equal(st.averaging_factors(9), [1, 2, 4, 8])


def test_no_difference_statistic_depends_on_the_value_put_in_a_frequency_gap():
    """For phase integrated from frequency the "span" rule skips every term whose span holds a missing
    sample, so the value integrated across a missing frequency sample (the mean, or anything else) never
    reaches a result. Checked by integrating the same record with the gap filled by 0 and by 1e-8
    instead; and the "samples" rule (right for phase records) does depend on it, which is why frequency
    input takes "span"."""
    rng = np.random.default_rng(21)
    y = rng.standard_normal(3000) * 1e-11
    y[[100, 1500, 1501, 2222]] = np.nan
    phases = []
    for fill in (0.0, 1e-8):  # 1000 times the noise: any bridging term would show
        x = np.concatenate(([0.0], np.cumsum(np.where(np.isnan(y), fill, y))))
        x[1:][np.isnan(y)] = np.nan
        phases.append(x)
    np.testing.assert_array_equal(np.isnan(phases[0]), np.isnan(st.frequency_to_phase(y, 1.0)))
    for name in ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "tie_rms"):
        taus = tau_grid("octave", phases[0].size, 1.0, name)
        a, b = (compute(name, x, 1.0, taus, gap_rule="span") for x in phases)
        np.testing.assert_allclose(a.dev, b.dev, rtol=1e-9, err_msg=name)
        np.testing.assert_array_equal(a.n, b.n)
        assert a.gap_rule == "span" and a.skipped == 4
    a, b = (compute("oadev", x, 1.0, [64.0], gap_rule="samples") for x in phases)
    assert a.gap_rule == "samples" and abs(a.dev[0] / b.dev[0] - 1) > 0.01
    assert compute("mtie", phases[0], 1.0, [1.0]).gap_rule == "window"
    assert compute("totdev", phases[0], 1.0, [1.0]).gap_rule == "fill"


@pytest.mark.parametrize("statistic", ["oadev", "mdev", "hdev", "totdev", "mtie", "mtotdev"])
def test_kernel_and_noise_identification_side_by_side_give_the_sequential_result(statistic, monkeypatch):
    """Above SIDE_BY_SIDE_FROM samples the noise identification runs on a helper thread beside the kernel;
    both are pure functions of the record, so every field must equal the one-after-the-other result
    (with gaps, where the identification reads the filled record and the kernel the one with NaN)."""
    import chronofuse.analysis.stability.engine as engine

    rng = np.random.default_rng(5)
    x = np.cumsum(rng.standard_normal(3000)) * 1e-9 + rng.standard_normal(3000) * 1e-9
    x[[100, 101, 2500]] = np.nan
    taus = tau_grid("octave", x.size, 1.0, statistic)
    monkeypatch.setattr(engine, "SIDE_BY_SIDE_FROM", 10**12)
    alone = compute(statistic, x, 1.0, taus)
    monkeypatch.setattr(engine, "SIDE_BY_SIDE_FROM", 0)
    monkeypatch.setattr(engine.os, "cpu_count", lambda: 2)
    beside = compute(statistic, x, 1.0, taus)
    for field in ("tau_s", "dev", "n", "alpha", "alpha_method", "edf", "lo", "hi"):
        np.testing.assert_array_equal(getattr(beside, field), getattr(alone, field), err_msg=field)

"""Noise identification against Stable32's Alpha column and against simulated power-law noise.

Lag-1 ACF rows (at least 30 frequency averages at the averaging factor): every Stable32 table is
reproduced exactly, except two tables whose alpha is not an identification (module docstring of
chronofuse.analysis.stability.noise_id): Cs5071A TOTDEV (0 on every row, where ADEV of the same data
shows 2 and 1) and PHASE.DAT HTOTDEV "nobias" (2 on every row of a white-FM record).
B1/R(n) rows (fewer averages): only some are reproduced; Stable32's small-sample rule is not published
in enough detail (it even gives different answers for ADEV and OADEV at the same m), so the test pins
which rows agree, to catch regressions, and documents the others: 33 of the 75 B1 rows, with the
overlapping Allan variance in B1 for the overlapping statistics (34 with the non-overlapped one
everywhere, other rows; the overlapping one is kept because it gives SP 1065's published HTOTDEV of the
1000-point white-FM set, where the non-overlapped one calls it flicker PM; see test_bias.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from _helpers import read_stable32_table

import chronofuse.analysis.stability as st
from chronofuse.analysis.stability.noise_id import (
    MIN_ACF_POINTS,
    acf_noise_id,
    acf_noise_id_fast,
    b1_expected,
    b1_noise_id,
    identify_noise,
    identify_noise_methods,
    lag1_autocorrelation,
)


# (data set, table, statistic, averaging factors of the B1 rows whose alpha Stable32 and we agree on)
TABLES = [
    ("phasedat", "phase_dat_adev_octave.txt", "adev", [64]),
    ("phasedat", "phase_dat_oadev_octave.txt", "oadev", [128]),
    ("phasedat", "phase_dat_mdev_octave.txt", "mdev", [128]),
    ("phasedat", "phase_dat_tdev_octave.txt", "tdev", [128]),
    ("phasedat", "phase_dat_hdev_octave.txt", "hdev", [64]),
    ("phasedat", "phase_dat_ohdev_octave.txt", "ohdev", [128]),
    ("phasedat", "phase_dat_totdev_octave.txt", "totdev", [128, 256]),
    ("phasedat", "phase_dat_mtotdev_octave.txt", "mtotdev", []),
    ("phasedat", "phase_dat_ttotdev_octave.txt", "ttotdev", []),
    ("phasedat", "phase_dat_htotdev_octave.txt", "htotdev", []),
    ("ocxo", "adev_octave.txt", "adev", []),
    ("ocxo", "oadev_octave.txt", "oadev", [1024]),
    ("ocxo", "mdev_octave.txt", "mdev", [1024]),
    ("ocxo", "tdev_octave.txt", "tdev", [1024]),
    ("ocxo", "hdev_octave.txt", "hdev", []),
    ("ocxo", "ohdev_octave.txt", "ohdev", [1024]),
    ("ocxo", "totdev_octave.txt", "totdev", [1024]),
    ("gps", "stable32_ADEV_decade.txt", "adev", [10000, 20000]),
    ("gps", "stable32_OADEV_octave.txt", "oadev", [16384, 32768]),
    ("gps", "stable32_MDEV_octave.txt", "mdev", [16384, 32768]),
    ("gps", "stable32_TDEV_octave.txt", "tdev", [16384, 32768]),
    ("gps", "stable32_HDEV_octave.txt", "hdev", [8192, 16384]),
    ("gps", "stable32_OHDEV_octave.txt", "ohdev", [16384, 32768]),
    ("gps", "stable32_TOTDEV_octave.txt", "totdev", [16384, 65536]),
    ("Cs5071A", "adev_decade.txt", "adev", [20000, 40000, 100000]),
    ("Cs5071A", "oadev_decade.txt", "oadev", []),
    ("Cs5071A", "mdev_decade.txt", "mdev", []),
    ("Cs5071A", "tdev_decade.txt", "tdev", []),
    ("Cs5071A", "hdev_decade.txt", "hdev", [20000, 40000, 100000]),
    ("Cs5071A", "ohdev_decade.txt", "ohdev", []),
]


@pytest.mark.parametrize("dataset, table, statistic, b1_agree", TABLES, ids=[f"{t[0]}-{t[1]}" for t in TABLES])
def test_alpha_matches_stable32_on_every_lag1_acf_row_and_the_pinned_b1_rows(
    records, data_dir, dataset, table, statistic, b1_agree
):
    ref = read_stable32_table(data_dir / "stability" / dataset / table)
    x = records[dataset]
    res = st.compute(statistic, x, 1.0, ref["tau"], bias_correction=False)
    acf_rows = (x.size - 1) // ref["af"] >= MIN_ACF_POINTS
    np.testing.assert_array_equal(res.alpha[acf_rows], ref["alpha"][acf_rows])
    b1_rows = ~acf_rows
    agree = set(ref["af"][b1_rows & (res.alpha == ref["alpha"])].tolist())
    assert agree == set(b1_agree)


def test_alpha_of_tables_with_a_fixed_alpha_is_not_what_identification_gives(records, data_dir):
    # Documented non-reproductions: these two tables carry a constant alpha.
    cs = read_stable32_table(data_dir / "stability" / "Cs5071A" / "totdev_decade.txt")
    assert set(cs["alpha"].tolist()) == {0}
    ours = st.totdev(records["Cs5071A"], 1.0, cs["tau"][:4]).alpha
    adev_table = read_stable32_table(data_dir / "stability" / "Cs5071A" / "adev_decade.txt")
    np.testing.assert_array_equal(ours, adev_table["alpha"][:4])  # 2, 2, 2, 2 like Stable32's ADEV


def _simulate(alpha: int, n: int, rng: np.random.Generator) -> np.ndarray:
    """Phase (n,) of white PM (2), white FM (0) or random-walk FM (-2), unit innovations."""
    w = rng.standard_normal(n)
    if alpha == 2:
        return w
    if alpha == 0:
        return np.cumsum(w)
    return np.cumsum(np.cumsum(w))


@pytest.mark.parametrize("alpha", [2, 0, -2])
def test_lag1_acf_identifies_simulated_power_law_noise(alpha):
    rng = np.random.default_rng(1000 + alpha)
    x = _simulate(alpha, 20000, rng)
    m = np.array([1, 4, 16, 64], dtype=np.int64)
    np.testing.assert_array_equal(identify_noise(x, m, 2), np.full(4, alpha))
    np.testing.assert_array_equal(identify_noise(x, m, 3), np.full(4, alpha))


def test_flicker_pm_is_told_from_white_pm():
    # Flicker PM phase: 1/f noise by spectral shaping of white noise.
    rng = np.random.default_rng(7)
    n = 2**15
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n)
    f[0] = f[1]
    x = np.fft.irfft(spec / np.sqrt(f), n)
    assert acf_noise_id(x, 1, 2) == 1
    assert acf_noise_id(x, 8, 2) == 1


@pytest.mark.parametrize("alpha", [2, 0, -2])
def test_b1_identifies_simulated_noise_on_short_records(alpha):
    rng = np.random.default_rng(50 + alpha)
    hits = 0
    for _ in range(20):
        x = _simulate(alpha, 257, rng)
        assert acf_noise_id(x, 16, 2) is None  # 16 averages: below the ACF minimum
        hits += b1_noise_id(x, 16) == alpha
    assert hits >= 14  # B1 on 16 averages is a noisy estimator; most trials must still be right


def test_lag1_autocorrelation_of_white_noise_is_zero_and_of_a_random_walk_near_one():
    rng = np.random.default_rng(3)
    w = rng.standard_normal(100000)
    assert abs(lag1_autocorrelation(w)) < 0.01
    assert lag1_autocorrelation(np.cumsum(w)) > 0.99
    # First difference of white noise: r1 = -1/2 exactly in expectation.
    assert lag1_autocorrelation(np.diff(w)) == pytest.approx(-0.5, abs=0.01)


def test_b1_expectations_match_barnes_closed_forms():
    n = 25
    assert b1_expected(n, -1) == pytest.approx(1.0)
    assert b1_expected(n, 1) == pytest.approx(n / 2)
    assert b1_expected(n, 2) == pytest.approx(n * (n + 1) / 6)
    assert b1_expected(n, -2) == pytest.approx((n**2 - 1) / (1.5 * n * (n - 1)))
    assert b1_expected(n, 0) == pytest.approx(n * np.log(n) / (2 * (n - 1) * np.log(2)))


def test_unidentifiable_factors_hold_the_last_identified_alpha():
    rng = np.random.default_rng(9)
    x = _simulate(-2, 200, rng)
    # 199 frequency steps: m = 90 and 150 leave 2 and 1 averages, too few even for B1 (3).
    assert b1_noise_id(x, 90) is None and b1_noise_id(x, 150) is None
    alpha = identify_noise(x, np.array([150, 1, 90, 4], dtype=np.int64), 2)
    assert alpha[1] == -2
    assert alpha[0] == alpha[2] == alpha[3]  # held from m = 4, the largest identifiable factor


def test_the_method_of_each_alpha_is_reported_acf_from_30_averages_b1_below(records):
    import chronofuse.analysis.stability as stab

    dev = stab.adev(records["phasedat"], 1.0, stab.tau_grid("octave", 1001, 1.0, "adev"))  # 1001 points: m = 32 has 31 averages, m = 64 has 15
    m = np.rint(dev.tau_s).astype(int)
    assert (dev.alpha_method[m <= 32] == "acf").all()
    assert (dev.alpha_method[m >= 64] == "b1").all()
    assert dev.to_dict()["alpha_method"] == [str(v) for v in dev.alpha_method]


@pytest.mark.parametrize("seed", range(4))
def test_the_fused_numba_identification_equals_the_readable_numpy_twin(seed):
    """acf_noise_id_fast (one numba pass per difference) against acf_noise_id (np.diff, detrend, dots),
    on records mixing a frequency offset, drift and each power-law noise, at several factors."""
    rng = np.random.default_rng(seed)
    n = 3000
    white = rng.standard_normal(n)
    for x in (white, np.cumsum(white), np.cumsum(np.cumsum(white)), np.cumsum(np.cumsum(np.cumsum(white)))):
        x = x + 1e-3 * np.arange(n) + 1e-7 * np.arange(n) ** 2
        for m in (1, 2, 5, 16, 64):
            for dmax in (2, 3):
                assert acf_noise_id_fast(x, m, dmax) == acf_noise_id(x, m, dmax)


@pytest.mark.parametrize("seed", range(3))
def test_identification_over_a_grid_equals_the_readable_twin_at_each_factor(seed):
    """identify_noise_methods decimates each factor's phase from the previous factor's (x[::8] from
    x[::4]); on a grid mixing octave factors with ones the previous does not divide, every ACF row must be
    what the numpy twin gives for that factor alone, on records long enough to use blocks (> 2**17 terms)
    and short ones."""
    rng = np.random.default_rng(100 + seed)
    m = np.array([1, 2, 4, 8, 16, 24, 48, 5, 10, 64], dtype=np.int64)
    for n in (3000, 300_000):
        white = rng.standard_normal(n)
        for x in (white, np.cumsum(white), np.cumsum(np.cumsum(white))):
            alpha, method = identify_noise_methods(x, m, 2)
            for j, mj in enumerate(m):
                if method[j] == "acf":
                    assert alpha[j] == min(max(acf_noise_id(x, int(mj), 2), -2), 2)


def test_b1_in_numba_chooses_as_its_numpy_twin_does():
    """noise_id.b1_choice (one numba pass) picks the mu whose expected B1 brackets the twin's B1 (b1_ratio,
    numpy arrays), on the five power-law noises at factors from 3 to 300 frequency averages."""
    from chronofuse.analysis.stability.noise_id import b1_choice, b1_expected, b1_ratio

    rng = np.random.default_rng(7)
    checked = 0
    for alpha in (2, 1, 0, -1, -2):
        x = np.cumsum(np.cumsum(rng.standard_normal(4000))) if alpha == -2 else np.cumsum(rng.standard_normal(4000))
        if alpha == 2:
            x = rng.standard_normal(4000)
        for m in (13, 40, 133, 400, 1333):
            for overlapping in (False, True):
                b1 = b1_ratio(x, m, overlapping)
                n = (x.size - 1) // m
                cuts = [np.sqrt(b1_expected(n, mu) * b1_expected(n, mu + 1)) for mu in (-2, -1, 0)]
                assert b1_choice(x, m, overlapping) == int(np.sum(b1 > np.array(cuts)))
                checked += 1
    assert b1_choice(np.arange(5.0), 2, False) == -1 and b1_ratio(np.arange(5.0), 2) is None  # 2 averages
    assert checked == 50

"""ITU-T G.8272 / G.811 masks: limits at and around every breakpoint, pass/fail, margins.

The reference values are the recommendations' tables, re-evaluated here by hand at each breakpoint
(e.g. G.8272 Table 1 at tau = 273 s: 0.275e-3 * 273 + 0.025 us = 100.075 ns on the sloped row and
100 ns just above it) and cross-checked against allantools' independent transcription (allantools.mask).
"""

from __future__ import annotations

import numpy as np
import pytest
from allantools import mask as at_mask

from chronofuse.analysis.masks import MASKS, Mask, MaskSegment
from chronofuse.analysis.stability import Deviation, mtie, tau_grid, tdev

NS = 1e-9

# (clock, metric, tau_s, expected limit in ns) at, just below and just above each breakpoint.
BREAKPOINTS = [
    ("prtc-a", "mtie", 0.2, 0.275e-3 * 0.2 * 1e3 + 25.0),
    ("prtc-a", "mtie", 273.0, 0.275e-3 * 273.0 * 1e3 + 25.0),
    ("prtc-a", "mtie", 273.001, 100.0),
    ("prtc-a", "mtie", 1e5, 100.0),
    ("prtc-b", "mtie", 54.5, 0.275e-3 * 54.5 * 1e3 + 25.0),
    ("prtc-b", "mtie", 54.51, 40.0),
    ("prtc-b", "mtie", 1e4, 40.0),
    ("prtc-a", "tdev", 100.0, 3.0),
    ("prtc-a", "tdev", 100.1, 0.03 * 100.1),
    ("prtc-a", "tdev", 1000.0, 30.0),
    ("prtc-a", "tdev", 5000.0, 30.0),
    ("prtc-b", "tdev", 50.0, 1.0),
    ("prtc-b", "tdev", 100.1, 0.01 * 100.1),
    ("prtc-b", "tdev", 500.0, 5.0),
    ("prtc-b", "tdev", 600.0, 5.0),
    ("g811", "mtie", 1000.0, 0.275e-3 * 1000.0 * 1e3 + 25.0),
    ("g811", "mtie", 1000.1, 1e-5 * 1000.1 * 1e3 + 290.0),
    ("g811", "tdev", 99.0, 3.0),
    ("g811", "tdev", 300.0, 9.0),
]


@pytest.mark.parametrize("clock, metric, tau_s, limit_ns", BREAKPOINTS)
def test_mask_limit_matches_the_recommendation_table_at_breakpoints(clock, metric, tau_s, limit_ns):
    mask = getattr(MASKS[clock], metric)
    assert mask.limit_s(tau_s)[0] == pytest.approx(limit_ns * NS, rel=1e-12)


ALLANTOOLS = {
    ("prtc-a", "mtie"): at_mask.prtcA_mtie,
    ("prtc-b", "mtie"): at_mask.prtcB_mtie,
    ("prtc-a", "tdev"): at_mask.prtcA_tdev,
    ("prtc-b", "tdev"): at_mask.prtcB_tdev,
    ("g811", "mtie"): at_mask.prc_mtie,
    ("g811", "tdev"): at_mask.prc_tdev,
}


@pytest.mark.parametrize("clock, metric", sorted(ALLANTOOLS))
def test_masks_agree_with_allantools_transcription_away_from_breakpoints(clock, metric):
    # allantools switches rows at tau < breakpoint (not <=), so compare off the breakpoints only.
    taus = np.array([0.3, 1.0, 7.0, 30.0, 77.0, 150.0, 333.0, 777.0, 2000.0, 9000.0])
    ours = getattr(MASKS[clock], metric).limit_s(taus)
    ref = np.array([ALLANTOOLS[clock, metric](t) for t in taus])
    np.testing.assert_allclose(ours, ref, rtol=1e-9)


def test_observation_intervals_at_or_below_0p1_s_are_not_evaluated():
    mask = MASKS["prtc-a"].mtie
    assert np.isnan(mask.limit_s([0.05, 0.1])).all()
    res = mask.check([0.1, 1.0], [1e-9, 1e-9])
    assert res.evaluated.tolist() == [False, True]
    assert res.status == "incomplete" and not res.passed  # a curve that stops at 1 s: the table goes to 273 s
    assert mask.check([0.1, 1.0], [1e-9, 1e-9], reach_s=273.0).passed


def test_check_passes_just_inside_and_fails_just_outside_each_breakpoint():
    mask = MASKS["prtc-b"].mtie
    tau = np.array([1.0, 54.5, 54.6, 1000.0])
    limit = mask.limit_s(tau)
    inside = mask.check(tau, limit * (1 - 1e-6))
    assert inside.passed and inside.passed_each.all()
    np.testing.assert_allclose(inside.margin_s, limit * 1e-6)
    outside_value = limit.copy()
    outside_value[2] *= 1 + 1e-6  # only the first point past the 54.5 s breakpoint violates
    outside = mask.check(tau, outside_value)
    assert not outside.passed
    assert outside.passed_each.tolist() == [True, True, False, True]
    assert outside.worst_margin_s == pytest.approx(-limit[2] * 1e-6)


def test_a_value_equal_to_the_limit_passes():
    mask = MASKS["prtc-a"].tdev
    res = mask.check([100.0, 1000.0], [3 * NS, 30 * NS])
    assert res.passed


def test_check_accepts_a_deviation_and_rejects_the_wrong_metric():
    rng = np.random.default_rng(5)
    x_s = 2 * NS * rng.standard_normal(4000)  # white PM, 2 ns rms: well inside PRTC-A
    res_mtie = MASKS["prtc-a"].check(mtie(x_s, 1.0, tau_grid("octave", x_s.size, 1.0, "mtie")))
    assert res_mtie.metric == "mtie" and res_mtie.passed
    res_tdev = MASKS["prtc-a"].check(tdev(x_s, 1.0, tau_grid("octave", x_s.size, 1.0, "tdev")))
    # the octave curve stops at 512 s and the table's rows at 1000 s: not a pass, and it says where
    assert res_tdev.metric == "tdev" and res_tdev.status == "incomplete" and res_tdev.not_covered_above_s == 512.0
    taus = np.append(tau_grid("octave", x_s.size, 1.0, "tdev"), 1000.0)
    assert MASKS["prtc-a"].check(tdev(x_s, 1.0, taus)).passed
    # PRTC-B's 1 ns TDEV is violated by 2 ns white PM at tau = tau0 (TDEV(tau0) = sigma_x = 2 ns).
    assert not MASKS["prtc-b"].check(tdev(x_s, 1.0, tau_grid("octave", x_s.size, 1.0, "tdev"))).passed
    with pytest.raises(ValueError, match="statistic"):
        MASKS["prtc-a"].mtie.check(tdev(x_s, 1.0, tau_grid("octave", x_s.size, 1.0, "tdev")))


def test_max_abs_time_error_limits_are_100_ns_and_40_ns():
    te = np.array([10e-9, -60e-9, np.nan, 30e-9])
    a = MASKS["prtc-a"].check_time_error(te)
    b = MASKS["prtc-b"].check_time_error(te)
    assert a.passed and a.max_abs_te_s == pytest.approx(60e-9) and a.margin_s == pytest.approx(40e-9)
    assert not b.passed and b.margin_s == pytest.approx(-20e-9)
    assert MASKS["prtc-b"].check_time_error(np.array([40e-9, -40e-9])).passed
    with pytest.raises(ValueError, match="max \\|TE\\|"):
        MASKS["g811"].check_time_error(te)


def test_mask_rejects_gaps_between_segments_and_bad_metric():
    seg1 = MaskSegment(0.1, 10.0, 1e-9, 0.0, "test")
    seg2 = MaskSegment(20.0, 30.0, 1e-9, 0.0, "test")
    with pytest.raises(ValueError, match="followed"):
        Mask("x", "mtie", (seg1, seg2))
    with pytest.raises(ValueError, match="metric"):
        Mask("x", "adev", (seg1,))
    with pytest.raises(ValueError, match="value_s"):
        MASKS["prtc-a"].mtie.check([1.0, 2.0])


def test_deviation_built_by_hand_is_checked_point_by_point():
    dev = Deviation(
        statistic="mtie",
        tau_s=np.array([1.0, 100.0, 1000.0]),
        dev=np.array([20e-9, 50e-9, 150e-9]),  # PRTC-A limits: 25.275, 52.5, 100 ns
        n=np.array([10, 10, 10]),
        alpha=np.zeros(3, dtype=int),
        edf=np.full(3, np.nan),
        lo=np.full(3, np.nan),
        hi=np.full(3, np.nan),
    )
    a = MASKS["prtc-a"].check(dev)
    assert a.passed_each.tolist() == [True, True, False]
    g = MASKS["g811"].check(dev)
    assert g.passed  # G.811 allows 300 ns at 1000 s


def test_a_phase_record_is_checked_for_mtie_tdev_and_max_time_error_at_once():
    rng = np.random.default_rng(8)
    x_s = 2 * NS * rng.standard_normal(4000)  # white PM, 2 ns rms: MTIE < 25 ns, TDEV(1 s) ~ 2 ns
    verdict_a = MASKS["prtc-a"].check(x_s, 1.0)
    assert verdict_a.passed and verdict_a.time_error.passed and verdict_a.status == "pass"
    np.testing.assert_array_equal(verdict_a.mtie.value_s, mtie(x_s, 1.0, verdict_a.mtie.tau_s).dev)
    assert {273.0, 2000.0} <= set(verdict_a.mtie.tau_s.tolist())  # the table's breakpoint and the record's reach
    # 3000 samples: TDEV reaches 750 s of the table's 1000 s, so the same record is no pass
    short = MASKS["prtc-a"].check(x_s[:3000], 1.0)
    assert short.status == "incomplete" and not short.passed and short.to_dict()["verdict"] == "INCOMPLETE"
    assert "not covered: tau > 750 s for TDEV" in short.summary()
    verdict_b = MASKS["prtc-b"].check(x_s, 1.0)
    assert not verdict_b.passed and not verdict_b.tdev.passed and verdict_b.time_error.passed
    shifted = MASKS["prtc-a"].check(x_s + 120 * NS, 1.0)  # a constant offset: only |TE| sees it
    assert shifted.mtie.passed and shifted.tdev.passed and not shifted.time_error.passed and not shifted.passed
    g = MASKS["g811"].check(x_s, 1.0)
    assert g.time_error is None and g.passed
    doc = verdict_b.to_dict()
    assert doc["passed"] is False and doc["tdev"]["passed"] is False and len(doc["mtie"]["tau"]) > 5
    with pytest.raises(ValueError, match="rate_hz"):
        MASKS["prtc-a"].check(x_s)


def test_clock_limit_by_metric_name():
    np.testing.assert_array_equal(MASKS["prtc-b"].limit_s("tdev", [50.0, 600.0]), [1 * NS, 5 * NS])
    with pytest.raises(ValueError, match="metric"):
        MASKS["prtc-b"].limit_s("adev", [1.0])


def test_mtie_crossing_between_octave_taus_fails():
    """G.8272 Table 1 rises 0.275 ns/s from 25 ns: 25.55 ns at 2 s, 25.825 ns at 3 s, 26.1 ns at 4 s. A step
    of 25.4 ns over 3 samples and 25.9 ns over 4 gives MTIE(2 s) = 25.4, MTIE(3 s) = MTIE(4 s) = 25.9 ns: the
    octave taus pass, tau 3 s fails, and the verdict must say so."""
    x = np.zeros(2000)
    x[1000:] = [0.0, 12.7, 25.4] + [25.9] * 997
    verdict = MASKS["prtc-a"].check(x * NS, 1.0)
    assert verdict.mtie.status == "fail"
    np.testing.assert_array_equal(verdict.mtie.failing_tau_s, [3.0])
    assert "MTIE fail at tau 3 s" in verdict.summary()


@pytest.mark.parametrize("seed", range(12))
def test_mtie_refinement_matches_every_factor(seed, monkeypatch):
    """Between its octave and breakpoint factors the MTIE check evaluates every factor the bounds
    MTIE(a) <= MTIE(m) <= MTIE(b) leave undecided: its failing taus and verdict are those of a brute-force
    MTIE at every factor against the formula of the table, on random walks with drift near the limit."""
    import chronofuse.analysis.masks as masks_mod

    monkeypatch.setattr(masks_mod, "_REFINE_SETTLED", 10**9)  # every settled failure evaluated too
    rng = np.random.default_rng(seed)
    n = 600
    x = np.cumsum(rng.normal(0.0, (1.0, 2.0, 4.0)[seed % 3], n)) * NS + 0.27 * NS * np.arange(n)
    if seed % 4 == 3:
        x[rng.choice(n, 20, replace=False)] = np.nan
    clock = MASKS["prtc-a"]
    res = clock._check_metric(clock.mtie, mtie, x, 1.0, None)
    m_all = np.arange(1, n // 2 + 1)
    brute = np.asarray(mtie(x, 1.0, m_all.astype(float)).dev)
    limit = 0.275e-9 * m_all + 25e-9
    limit[m_all > 273] = 100e-9
    failing = m_all[brute > limit * (1 + 1e-12)]
    np.testing.assert_array_equal(res.failing_tau_s, failing.astype(float))
    assert res.passed == (failing.size == 0)
    at = np.rint(res.tau_s).astype(int) - 1
    np.testing.assert_array_equal(res.value_s, brute[at])

"""A mask verdict is evaluated at the tables' breakpoints and ends, and is no pass where the record does not
cover the table: the oracles are the tables' rows (``mask_tables.py``) and MTIE of a phase ramp, which is
the ramp's slope times tau exactly (the peak-to-peak of a line over a window of tau)."""

import numpy as np

from chronofuse.analysis.masks import MASKS
from chronofuse.analysis.stability import mtie, tau_grid

NS = 1e-9


def test_a_violation_at_the_tables_end_is_found_though_no_octave_tau_is_there():
    # g8262-opt1: MTIE 25.25 tau^0.2 ns to 1000 s (Table 1): 100.53 ns at 1000 s, 87.5 ns at 512 s. A ramp of
    # 0.101 ns/s has MTIE 101 ns at 1000 s (over) and 51.7 ns at 512 s (inside); the octave grid of 2100
    # samples jumps from 512 s to 1024 s, beyond the table.
    slope = 0.101 * NS
    x = slope * np.arange(2100.0)
    assert 1000.0 not in tau_grid("octave", x.size, 1.0, "mtie").tolist()
    verdict = MASKS["g8262-opt1"].check(x, 1.0)
    res = verdict.mtie
    k = res.tau_s.tolist().index(1000.0)
    assert np.isclose(res.value_s[k], slope * 1000.0, rtol=1e-12)
    assert np.isclose(res.limit_s[k], 25.25 * 1000.0**0.2 * NS, rtol=1e-12)
    # every whole tau where the ramp's MTIE exceeds the row is found, the refinement between 512 s and
    # 1000 s (MTIE never decreases with tau) included: 0.101 tau > 25.25 tau^0.2 for tau > 250^1.25 = 994.0 s
    tau = np.arange(101.0, 1001.0)
    assert res.failing_tau_s.tolist() == tau[slope * tau > 25.25 * tau**0.2 * NS].tolist() == [995.0, 996.0, 997.0,
                                                                                                998.0, 999.0, 1000.0]
    assert verdict.status == "fail" and not verdict.passed
    # the same ramp 1 % flatter is inside the limit at 1000 s: the MTIE part passes there
    flat = MASKS["g8262-opt1"].check(x * 0.99, 1.0)
    assert flat.mtie.status == "pass"


def test_the_asked_taus_and_every_rows_ends_are_evaluated():
    x = 0.01 * NS * np.arange(30_000.0)
    got = MASKS["prtc-b"].check(x, 1.0, tau_s=[7.0, 600.0])
    taus = got.mtie.tau_s.tolist()
    # asked 7 and 600 s; rows (0.1, 54.5] and (54.5, inf): their covered ends 1, 54, 55 s; the reach 15000 s
    assert {7.0, 600.0, 1.0, 54.0, 55.0, 15_000.0} <= set(taus)
    np.testing.assert_allclose(got.mtie.value_s, 0.01 * NS * got.mtie.tau_s, rtol=1e-9)
    assert set(got.tdev.tau_s.tolist()) >= {100.0, 101.0, 500.0, 501.0, 7500.0}
    # a tau that is no whole number of sample intervals is not computed
    assert 7.5 not in MASKS["prtc-b"].check(x, 1.0, tau_s=[7.5]).mtie.tau_s.tolist()


def test_a_filtered_network_limit_fails_at_its_upper_end():
    # g8271.1-c: dTE_L MTIE 580 ns from 275 s to 10,000 s inclusive (Table 7-1). A ramp of 0.06 ns/s has
    # MTIE 600 ns at 10,000 s and 491.5 ns at 8192 s; the 0.1 Hz low-pass delays a ramp by 1/(2 pi 0.1 Hz)
    # = 1.6 s, which does not change its MTIE by more than 0.1 ns.
    x = 0.06 * NS * np.arange(20_500.0)
    verdict = MASKS["g8271.1-c"].check(x, 1.0)
    # failing: whole taus up to 10,000 s where 0.06 tau > 580 ns (tau > 9666.7 s), within the low-pass's
    # 0.1 ns; the refinement between the octave taus finds the first (past a run of settled failures it
    # evaluates only the worst, the verdict being a failure anyway)
    failing = verdict.mtie.failing_tau_s
    tau = np.arange(275.0, 10_001.0)
    assert verdict.status == "fail" and failing.max() == 10_000.0
    assert set(failing.tolist()) <= set(tau[0.06 * tau > 579.9])
    assert tau[0.06 * tau > 579.9].min() <= failing.min() <= tau[0.06 * tau > 580.1].min()
    k = verdict.mtie.tau_s.tolist().index(10_000.0)
    assert abs(verdict.mtie.value_s[k] - 600 * NS) < 0.2 * NS


def test_a_record_too_short_for_the_table_is_incomplete_not_a_pass():
    rng = np.random.default_rng(3)
    x = 5 * NS + 0.1 * NS * rng.standard_normal(60)
    for name, end in (("t-bc-a", 1000.0), ("prtc-a", 273.0), ("g8262-opt1", 1000.0)):
        verdict = MASKS[name].check(x, 1.0)
        assert verdict.status == "incomplete" and not verdict.passed, name
        assert verdict.mtie.not_covered_above_s == 30.0 and verdict.mtie.required_s == end
        assert "not covered: tau > 30 s for MTIE" in verdict.summary()
        assert verdict.to_dict()["verdict"] == "INCOMPLETE"
    # cTE is averaged over 1000 s: from 60 s of data it is not evaluated, and said so
    cls_a = MASKS["t-bc-a"].check(x, 1.0)
    assert not any(lim.quantity == "cte" for lim in cls_a.limits)
    assert any("averaged over 1000 s and the record spans 60 s" in n for n in cls_a.not_covered)
    # eight samples, PRTC-B
    assert MASKS["prtc-b"].check(x[:8], 1.0).status == "incomplete"
    # the same noise over 4000 s covers PRTC-A's tables (MTIE to 273 s, TDEV to 1000 s): a pass
    long = 5 * NS + 0.1 * NS * rng.standard_normal(4000)
    assert MASKS["prtc-a"].check(long, 1.0).status == "pass"


def test_a_failure_beats_an_uncovered_range_and_nothing_evaluated_is_no_failure():
    rng = np.random.default_rng(4)
    x = 5 * NS + 0.1 * NS * rng.standard_normal(60)
    assert MASKS["prtc-a"].check(x + 200 * NS, 1.0).status == "fail"  # max |TE| 205 ns > 100 ns
    nothing = MASKS["t-bc-d"].check(x, 1.0, offset="arbitrary")
    assert nothing.status == "not evaluated" and not nothing.passed
    assert nothing.to_dict()["verdict"] == "NOT EVALUATED"
    assert not nothing.summary().lower().startswith("fail")
    measured = MASKS["t-bc-d"].check(x, 1.0)  # max |TE_L| 5 ns: 5.x ns is over it
    assert measured.status == "fail"


def test_a_plot_colours_each_verdict_by_its_word():
    from chronofuse.report.stability_figure import VERDICT_COLORS, stability_figure

    rng = np.random.default_rng(5)
    x = 5 * NS + 0.1 * NS * rng.standard_normal(4000)
    verdicts = [MASKS["prtc-a"].check(x, 1.0), MASKS["prtc-a"].check(x[:60], 1.0), MASKS["prtc-b"].check(x + 50 * NS, 1.0)]
    assert [v.status for v in verdicts] == ["pass", "incomplete", "fail"]
    fig = stability_figure({"mtie": mtie(x, 1.0, tau_grid("octave", x.size, 1.0, "mtie"))}, verdicts=verdicts,
                           masks=[MASKS["prtc-a"]])
    texts = [t for ax in fig.axes for t in ax.texts if t.get_text().startswith("prtc")]
    colors = {t.get_text().split(" - ")[0]: t.get_color() for t in texts}
    assert colors == {"prtc-a: PASS": VERDICT_COLORS["pass"], "prtc-a: INCOMPLETE": VERDICT_COLORS["incomplete"],
                      "prtc-b: FAIL": VERDICT_COLORS["fail"]}

"""The positioning claims on the calibrated budget: intervals, verdicts that can be withheld, the floor."""

from __future__ import annotations

import numpy as np
import pytest

from chronofuse.experiments.positioning_claims import bootstrap_metric, simulated_claims, verdict


def test_a_verdict_is_given_only_when_the_interval_is_on_one_side_of_the_claim():
    assert verdict(0.5, 0.8, 0.9) == "reached"
    assert verdict(0.85, 0.95, 0.9).startswith("not decided")
    assert verdict(1.0, 1.2, 0.9).startswith("not reached")
    assert verdict(float("nan"), 1.0, 0.9) == "not measurable here"


def test_the_trial_bootstrap_interval_covers_the_truth_at_about_its_level():
    rng = np.random.default_rng(2)
    truth = np.percentile(np.hypot(*rng.standard_normal((2, 2_000_000))), 95)  # Rayleigh 95 %: 2.4477
    covered = 0
    for k in range(40):
        errors = rng.standard_normal((10, 300, 3))
        _, low, high = bootstrap_metric(lambda e: float(np.percentile(np.hypot(e[..., 0], e[..., 1]), 95)), errors,
                                        resamples=200, seed=k)
        covered += low <= truth <= high
    assert abs(truth - 2.4477) < 0.01 and covered >= 32  # nominal 95 %: 38 of 40; the bootstrap runs a little narrow


@pytest.mark.slow
def test_the_simulated_claims_are_calibrated_bounded_by_their_floor_and_judged():
    rows, stats, runs = simulated_claims(300.0, 4)
    by = {r["claim"]: r for r in rows}
    before = by["horizontal CEP95 before (m)"]
    assert abs(runs["calibration"]["cep95_m"] - 4.2) < 0.6  # the canyon reproduces the stated baseline
    after = by["horizontal CEP95 after (m)"]
    assert after["ci95"][0] <= after["ours"] <= after["ci95"][1]
    # the floor (error-free IMU, smoothed) is not beaten by any real IMU grade, and the GNSS/INS solutions
    # do not beat it either: it bounds
    floor = stats["gps+bds+error-free"]["gnss+ins+rts"]["cep95_m"]["value"]
    for grade in ("consumer", "industrial", "tactical"):
        assert stats[f"gps+bds+{grade}"]["gnss+ins+rts"]["cep95_m"]["value"] >= 0.95 * floor
    assert after["verdict"].startswith("not reached") and before["verdict"].startswith("calibrated")

"""Trials where an algorithm had no estimate are counted, reported and left out, never a crash nor a silent
drop; a lost first exchange does not blind the paper's chain for the whole run; fewer trials than the
interval rule allows give no interval, never a zero-width one."""

import warnings

import numpy as np
import pandas as pd
import pytest

from chronofuse.experiments.swarm import LinkScenario, knowledge_of, run_link, simulate_scenario
from chronofuse.experiments.sweep import summarize
from chronofuse.models.link import LinkModel
from chronofuse.sync.base import measurement_array
from chronofuse.sync.chain import RvcKfChain
from chronofuse.sync.fast import FastRvcKfChain
from chronofuse.sync.metrics import (MIN_INTERVAL_TRIALS, per_trial_mse, ratio_interval, rmse_interval,
                                     running_rmse_s, scored_trials)
from chronofuse.sync.registry import make_algorithm
from chronofuse.validation import InputError, InputWarning


def test_a_trial_with_no_estimate_has_a_nan_mse_without_a_runtime_warning():
    err = np.array([[np.nan, np.nan, np.nan], [1.0, np.nan, 3.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mse = per_trial_mse(err)
        running = running_rmse_s(err)
    assert np.isnan(mse[0]) and mse[1] == pytest.approx(5.0)
    assert scored_trials(mse).tolist() == [False, True]
    assert np.isnan(running[1]) and running[0] == pytest.approx(1.0)


def test_fewer_trials_than_the_rule_give_no_interval_and_enough_give_a_real_one():
    rng = np.random.default_rng(1)
    for n in (1, 2, MIN_INTERVAL_TRIALS - 1):
        mse = rng.exponential(1.0, n)
        r, lo, hi = rmse_interval(mse)
        q, qlo, qhi = ratio_interval(mse, np.ones(n))
        assert np.isfinite(r) and np.isfinite(q)
        assert np.isnan(lo) and np.isnan(hi) and np.isnan(qlo) and np.isnan(qhi)
    mse = rng.exponential(1.0, MIN_INTERVAL_TRIALS)
    r, lo, hi = rmse_interval(mse)
    assert lo < r < hi
    # one trial used to give lo == hi == the estimate: a zero-width "interval"
    assert np.isnan(rmse_interval(np.array([2.0]))[1])


def _lost_start_Z():
    sc = LinkScenario(velocity_m_s=1500.0, exchanges=200)
    Z = measurement_array(simulate_scenario(sc, 3, 2)[0])
    Z[0, :5, :4] = np.nan  # trial 0 loses its first five exchanges (t_i, t_b, t_r, velocity)
    config = make_algorithm("rtt-rvc-kf", knowledge_of(sc, None), urt_s=19e-9).config
    return Z, config


def test_the_paper_s_chain_starts_at_the_first_exchange_that_arrives_when_the_first_is_lost():
    Z, config = _lost_start_Z()
    slow = RvcKfChain(config).fit().run(Z).offset_s
    fast = FastRvcKfChain(config).fit().run(Z).offset_s
    assert np.isnan(slow[0, :5]).all() and np.isfinite(slow[0, 5:]).all()  # was NaN for the whole run
    assert np.isfinite(slow[1:]).all()
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-17)
    # trial 0 started at exchange 5 is the same filter started there on its own
    alone = RvcKfChain(config).fit().run(Z[:1, 5:]).offset_s
    assert np.abs(slow[0, 5:] - alone[0]).max() < 1e-9


def test_trials_with_no_exchange_are_counted_reported_and_left_out():
    sc = LinkScenario(exchanges=120, link=LinkModel(loss_fraction=0.999, loss_burst_mean=1000.0))
    with pytest.warns(InputWarning) as caught:
        res = run_link(sc, ["rtt-rvc-kf", "null"], trials=12, seed=0)
    mse = np.array(res["mse_per_trial_s2"]["rtt-rvc-kf"], dtype=float)
    unscored = res["unscored_trials"]["rtt-rvc-kf"]
    assert 0 < len(unscored) < 12  # the seed gives some trials no exchange at all, not all of them
    assert np.flatnonzero(np.isnan(mse)).tolist() == unscored
    assert res["rmse_s"]["rtt-rvc-kf"] == pytest.approx(np.sqrt(np.nanmean(mse)), rel=1e-12)
    assert res["unscored_trials"]["null"] == []  # the do-nothing estimator always has its prior mean
    texts = [str(w.message) for w in caught]
    assert any(f"rtt-rvc-kf: {len(unscored)} of 12 trials had no estimate" in t for t in texts), texts
    assert not any("below" in t for t in texts)  # 12 trials are enough for an interval


def test_loss_beyond_what_its_bursts_can_reach_is_refused_naming_both_fields():
    with pytest.raises(InputError) as exc:
        LinkModel(loss_fraction=0.999)
    assert exc.value.fields == ("loss_fraction", "loss_burst_mean") and "999" in str(exc.value)
    LinkModel(loss_fraction=0.5)  # the most independent losses reach
    LinkModel(loss_fraction=0.999, loss_burst_mean=999.0)


def test_a_sweep_summary_counts_the_trials_it_could_not_score():
    rows = [("velocity", 1.0, "a", j, v, 1.0) for j, v in enumerate([1.0, np.nan, 2.0] + [1.5] * 9)]
    table = pd.DataFrame(rows, columns=["param", "value", "algorithm", "trial", "rmse_ns", "bound_rms_ns"])
    with pytest.warns(InputWarning, match="1 of 12 trials had no estimate"):
        s = summarize(table).iloc[0]
    assert s["trials"] == 12 and s["unscored"] == 1
    assert s["rmse_ns"] == pytest.approx(np.sqrt(np.mean([1.0, 4.0] + [2.25] * 9)))
    assert s["rmse_lo_ns"] < s["rmse_ns"] < s["rmse_hi_ns"]

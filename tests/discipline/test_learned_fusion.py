"""The two learnt options beside inverse-variance fusion, on held-out simulated scenarios (measured verdicts)."""

import numpy as np
import pytest

from chronofuse.discipline.fusion import InverseVarianceFusion
from chronofuse.discipline.graph import GraphFusion, receiver_features
from chronofuse.discipline.ica import IcaFusion
from chronofuse.discipline.qualification import usable_epochs
from chronofuse.models.receiver import simulate_receivers


def _data(env, seed, steps=6000, receivers=4):
    rx = simulate_receivers(env, steps, receivers, seed=seed)
    e = (rx.pps_error_s + rx.epochs.qerr_s)[0]
    u = usable_epochs(rx.epochs)[0]
    x = np.cumsum(1e-11 * np.random.default_rng(seed).standard_normal(steps))  # a common oscillator phase
    z = np.where(u, x - e, np.nan)
    return z, e, u, receiver_features(z, u, rx.epochs.gdop[0], rx.epochs.n_sats[0]), x


def _rms(a):
    return float(np.sqrt(np.mean(a**2)))


def test_ica_weights_pass_the_common_mode_unchanged():
    z, _, u, _, x = _data("open-sky", 1)
    ica = IcaFusion().fit(z[:, u.all(axis=0)])
    assert ica.weights_.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(ica.fuse(np.tile(x, (4, 1))), x, rtol=0, atol=1e-15)


def test_ica_that_does_not_converge_says_so_in_its_fit_and_warns_nothing():
    import warnings

    z, _, u, _, _ = _data("open-sky", 1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        short = IcaFusion(max_iter=1).fit(z[:, u.all(axis=0)])
        full = IcaFusion().fit(z[:, u.all(axis=0)])
    assert short.n_iter_ == 1 and not short.converged_
    assert full.converged_ == (full.n_iter_ < full.max_iter)


@pytest.mark.slow
def test_ica_preprocessing_does_not_beat_inverse_variance_fusion_on_held_out_urban_data():
    z, _, u, _, _ = _data("urban-canyon", 1)
    ica = IcaFusion().fit(z[:, u.all(axis=0)])
    z2, _, u2, _, x2 = _data("urban-canyon", 2)
    ok = u2.all(axis=0)
    ica_rms = _rms(ica.fuse(z2[:, ok]) - x2[ok])
    iv = InverseVarianceFusion().run(z2[None], u2[None]).offset_s[0] - x2
    assert ica_rms > _rms(iv[ok])  # measured verdict: an option, not the default


def test_graph_weights_sum_to_one_over_usable_receivers_and_ignore_the_others():
    z, e, u, f, _ = _data("urban-canyon", 3, steps=800)
    g = GraphFusion(epochs=5, max_rows=500).fit(f, u.T, np.nan_to_num(e.T))
    w = g.weights(f, u.T)
    some = u.any(axis=0)
    np.testing.assert_allclose(w[some].sum(axis=1), 1.0, rtol=1e-5)
    assert np.all(w[~u.T] < 1e-6)


@pytest.mark.slow
def test_the_graph_model_trained_on_simulated_runs_stays_near_but_does_not_beat_inverse_variance_fusion_held_out():
    train = [_data(env, s) for env in ("open-sky", "urban-canyon") for s in (11, 12)]
    f = np.concatenate([d[3] for d in train])
    u = np.concatenate([d[2].T for d in train])
    e = np.concatenate([np.nan_to_num(d[1].T) for d in train])
    g = GraphFusion(epochs=150, max_rows=4000).fit(f, u, e)
    ratios = []
    for env in ("open-sky", "urban-canyon"):
        z, _, uu, ff, x = _data(env, 21)
        fg = g.fuse(z, ff, uu) - x
        iv = InverseVarianceFusion().run(z[None], uu[None]).offset_s[0] - x
        ok = np.isfinite(fg) & np.isfinite(iv)
        ratios.append(_rms(fg[ok]) / _rms(iv[ok]))
    # Measured (seed 21, 20000 s held out): 1.08 in open sky, 1.03 in urban canyon against the default 3600 s
    # memory. Against the former 300 s memory, whose weights wandered with the receivers' slow errors, the
    # graph model was ahead (0.93 and 1.01 on the same runs): what it learnt was mostly steadier weights.
    assert max(ratios) < 1.12
    assert min(ratios) > 0.98

"""Inverse-variance fusion of receivers against best-source selection."""

import numpy as np
import pytest

from chronofuse.discipline.fusion import InverseVarianceFusion
from chronofuse.discipline.qualification import usable_epochs
from chronofuse.models.receiver import simulate_receivers


def test_with_known_white_errors_fusion_reaches_the_inverse_variance_bound():
    # Three receivers, sigma 5, 10, 20 ns, white: the optimal fused variance is 1 / sum(1/sigma^2).
    rng = np.random.default_rng(0)
    sig = np.array([5e-9, 10e-9, 20e-9])
    steps, trials = 6000, 4
    e = sig[None, :, None] * rng.standard_normal((trials, 3, steps))
    common = 1e-6 * rng.standard_normal((trials, 1, steps))  # the oscillator's phase: common to all
    run = InverseVarianceFusion(memory_s=300.0).run(common - e, np.ones(e.shape, bool))
    err = run.offset_s[:, 1000:] - common[:, 0, 1000:]
    bound = 1.0 / np.sum(1.0 / sig**2)
    assert np.mean(err**2) == pytest.approx(bound, rel=0.08)
    # the learnt weights are near the inverse-variance ones (estimated over ~300 s: a few % of scatter)
    w = run.weights[:, :, 1000:].mean(axis=(0, 2))
    np.testing.assert_allclose(w, (1 / sig**2) / np.sum(1 / sig**2), atol=0.05)
    # and the reported variance matches what was achieved
    assert np.mean(run.variance_s2[:, 1000:]) == pytest.approx(bound, rel=0.15)


def test_selection_picks_the_best_receiver_and_fusion_beats_it():
    rng = np.random.default_rng(1)
    sig = np.array([10e-9, 12e-9, 30e-9])
    e = sig[None, :, None] * rng.standard_normal((2, 3, 5000))
    sel = InverseVarianceFusion("selection").run(-e, np.ones(e.shape, bool))
    fus = InverseVarianceFusion("fusion").run(-e, np.ones(e.shape, bool))
    assert sel.weights[:, 0, 1000:].mean() > 0.7
    rms_sel = np.sqrt(np.mean(sel.offset_s[:, 1000:] ** 2))
    rms_fus = np.sqrt(np.mean(fus.offset_s[:, 1000:] ** 2))
    assert rms_fus < 0.85 * rms_sel


def test_unusable_receivers_do_not_vote_and_no_receiver_gives_nan():
    z = np.array([[[1.0, 1.0, np.nan]], [[3.0, np.nan, np.nan]]]).transpose(1, 0, 2)  # (1, 2, 3)
    run = InverseVarianceFusion().run(z * 1e-9, np.isfinite(z))
    assert run.offset_s[0, 0] == pytest.approx(2e-9)
    assert run.offset_s[0, 1] == pytest.approx(1e-9)
    assert np.isnan(run.offset_s[0, 2])


@pytest.mark.slow
def test_fused_1pps_beats_best_source_selection_in_an_urban_canyon():
    rx = simulate_receivers("urban-canyon", 4000, 4, seed=11, trials=3)
    e = rx.pps_error_s + rx.epochs.qerr_s
    usable = usable_epochs(rx.epochs)
    fus = InverseVarianceFusion("fusion").run(-e, usable)
    sel = InverseVarianceFusion("selection").run(-e, usable)
    both = np.isfinite(fus.offset_s) & np.isfinite(sel.offset_s)
    rms = [np.sqrt(np.mean(r.offset_s[both] ** 2)) for r in (fus, sel)]
    assert rms[0] < 0.8 * rms[1]


@pytest.mark.parametrize("mode", ["fusion", "selection"])
def test_the_fusion_kernel_equals_its_numpy_twin(mode):
    rng = np.random.default_rng(9)
    z = np.array([4e-9, 8e-9, 15e-9])[None, :, None] * rng.standard_normal((2, 3, 800))
    usable = rng.random(z.shape) > 0.1
    fast = InverseVarianceFusion(mode, fast=True).run(z, usable)
    slow = InverseVarianceFusion(mode, fast=False).run(z, usable)
    np.testing.assert_allclose(fast.offset_s, slow.offset_s, rtol=1e-9, atol=1e-20)
    np.testing.assert_allclose(fast.weights, slow.weights, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(fast.variance_s2, slow.variance_s2, rtol=1e-9)


@pytest.mark.parametrize("fast", [True, False])
def test_a_receiver_back_from_an_exclusion_earns_its_weight_anew(fast):
    from chronofuse.discipline.fusion import InverseVarianceFusion

    rng = np.random.default_rng(4)
    steps = 2000
    z = np.stack([2e-9 * rng.standard_normal(steps), 2e-9 * rng.standard_normal(steps),
                  2e-9 * rng.standard_normal(steps)])[None]
    usable = np.ones(z.shape, bool)
    usable[0, 2, 1000:1500] = False  # excluded for 500 s
    fresh = np.zeros(z.shape, bool)
    fresh[0, 2, 1500] = True
    # A 300 s memory, so that the others' estimates have settled from the initial 20 ns within the 1000 s
    # before the exclusion (the default 3600 s memory would need most of a day).
    fusion = InverseVarianceFusion(fast=fast, memory_s=300.0)
    old = fusion.run(z, usable)
    new = fusion.run(z, usable, fresh)
    # Without the restart it returns with the weight it had (a third); with it, from the initial 20 ns.
    assert abs(old.weights[0, 2, 1500] - 1 / 3) < 0.1
    assert new.weights[0, 2, 1500] < 0.05
    assert np.allclose(new.weights[0, :, :1500], old.weights[0, :, :1500])
    # ... and earned back over several of its 300 s memories (the variance estimate decays from 20 ns).
    assert new.weights[0, 2, -1] > 3 * new.weights[0, 2, 1500]

"""The compiled kernels against their numpy twins: every servo, in streaming and in the closed loop."""

import numpy as np
import pytest

from chronofuse.discipline.dac import Dac
from chronofuse.discipline.kalman import KalmanServo
from chronofuse.discipline.kalman_adaptive import AdaptiveKalmanServo
from chronofuse.discipline.kalman_gated import GatedKalmanServo
from chronofuse.discipline.kalman_huber import HuberKalmanServo
from chronofuse.discipline.loop import close_loop
from chronofuse.discipline.pi import PiServo
from chronofuse.discipline.null import NullServo
from chronofuse.models.oscillator_presets import preset

OCXO = preset("ocxo")
SIGMA = 8e-9


def _servos(fast, dac):
    gm = ((5e-9, 15.0), (5e-9, 1500.0))
    return [NullServo(fast=fast, dac=dac), PiServo(fast=fast, dac=dac), PiServo.from_bandwidth(2e-3, fast=fast),
            KalmanServo(OCXO.h, SIGMA, fast=fast, dac=dac), KalmanServo(OCXO.h, 3e-9, gauss_markov=gm, fast=fast),
            AdaptiveKalmanServo(OCXO.h, SIGMA, fast=fast, dac=dac, drift_ar1=0.999),
            GatedKalmanServo(OCXO.h, SIGMA, fast=fast, max_rejects=5), HuberKalmanServo(OCXO.h, SIGMA, fast=fast)]


def _data(trials=3, steps=600, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(steps, dtype=float)
    free = 2e-7 + 3e-10 * t + np.cumsum(2e-12 * rng.standard_normal((trials, steps)), axis=1)
    ref = SIGMA * rng.standard_normal((trials, steps))
    ref[:, 100:130] = np.nan
    ref[0, 300] = 4e-7
    ref[1, 400:] += 1.5e-6  # a step beyond the jam-sync threshold
    return free, ref


@pytest.mark.parametrize("index", range(8))
@pytest.mark.parametrize("with_dac", [False, True])
def test_the_closed_loop_kernel_equals_the_numpy_twin(index, with_dac):
    dac = Dac.for_oscillator(OCXO) if with_dac else None
    free, ref = _data()
    fast = close_loop(_servos(True, dac)[index], free, ref)
    slow = close_loop(_servos(False, dac)[index], free, ref)
    for field in ("phase_s", "offset_s", "freq_adj", "phase_step_s", "offset_estimate_s", "innovation_s"):
        np.testing.assert_allclose(getattr(fast, field), getattr(slow, field), rtol=1e-7, atol=1e-17, err_msg=field)
    assert np.array_equal(fast.used, slow.used) and np.array_equal(fast.near_rail, slow.near_rail)


@pytest.mark.parametrize("index", range(8))
def test_the_streaming_kernel_equals_the_numpy_twin_and_its_own_batch(index):
    free, ref = _data(trials=2, steps=500, seed=1)
    z = free - ref
    fast, slow = _servos(True, None)[index], _servos(False, None)[index]
    a, b = fast.run(z), slow.run(z)
    np.testing.assert_allclose(a.freq_adj, b.freq_adj, rtol=1e-7, atol=1e-20)
    fast.reset()
    streamed = [fast.step(v).freq_adj for v in z[1]]
    assert np.array_equal(streamed, a.freq_adj[1])

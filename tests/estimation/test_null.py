"""The null estimator holds the last valid measurement; streaming equals batch."""

import numpy as np

from chronofuse.estimation.interface import compare_streaming_to_batch
from chronofuse.estimation.null import HoldLastEstimator


def test_holds_the_last_valid_measurement_and_its_innovation_is_the_change():
    Z = np.array([[[1.0], [np.nan], [4.0], [2.0]]])
    res = HoldLastEstimator().fit().run(Z)
    assert np.isnan(res.x_prior[0, 0, 0])
    np.testing.assert_array_equal(res.x[0, :, 0], [1.0, 1.0, 4.0, 2.0])
    np.testing.assert_array_equal(res.y[0, 1:, 0], [np.nan, 3.0, -2.0])
    assert res.skipped[0].tolist() == [False, True, False, False]


def test_streaming_equals_batch():
    rng = np.random.default_rng(0)
    Z = rng.standard_normal((3, 40, 2))
    Z[1, 10:13] = np.nan
    assert compare_streaming_to_batch(HoldLastEstimator(m=2).fit(), Z, rtol=0.0) == []

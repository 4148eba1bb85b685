"""Seed eqs. 47-51 on hand-computed cases."""

import numpy as np
import pytest

from chronofuse.sync.metrics import convergence_epochs, overhead, rmse_s, robustness, running_rmse_s


def test_rmse_and_running_rmse_match_hand_computation():
    err = np.array([[3.0, 0.0, np.nan], [4.0, 0.0, 1.0]])
    assert rmse_s(err) == pytest.approx(np.sqrt((9 + 16 + 1) / 5))
    np.testing.assert_allclose(running_rmse_s(err), [np.sqrt(12.5), 0.0, 1.0])


def test_convergence_is_the_first_epoch_at_or_below_the_threshold():
    err = np.array([[5.0, 2.0, 0.5, 3.0, 0.1]])
    assert convergence_epochs(err, 1.0) == 2
    assert convergence_epochs(err, 1.0, start=3) == 1
    assert convergence_epochs(err, 0.01) is None


def test_robustness_and_overhead():
    nominal = np.ones((1, 4))
    stress = np.array([[1.0, 5.0, 3.0, 0.5]])
    r = robustness(nominal, stress, threshold_s=1.0, stress_end=1)
    assert r["delta_rmse_s"] == pytest.approx(np.sqrt((1 + 25 + 9 + 0.25) / 4) - 1.0)
    assert r["recovery_epochs"] == 2
    o = overhead(0.01)
    assert o == {"messages_per_s": 200.0, "bits_per_s": 38400.0}

"""Positioning metrics against distributions whose percentiles are known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chronofuse.analysis.metrics import horizontal_cep_m, outage_bridging_s, vertical_95_m


def test_cep_of_a_circular_gaussian_is_its_rayleigh_percentiles():
    rng = np.random.default_rng(0)
    e = rng.normal(0.0, 2.0, (400_000, 2))
    # Rayleigh: CEP_p = sigma sqrt(-2 ln(1 - p)): 1.1774 sigma (50 %), 2.4477 sigma (95 %).
    assert horizontal_cep_m(e, 50) == pytest.approx(2.0 * math.sqrt(2 * math.log(2)), rel=0.01)
    assert horizontal_cep_m(e, 95) == pytest.approx(2.0 * math.sqrt(-2 * math.log(0.05)), rel=0.01)


def test_vertical_95_of_a_gaussian_is_1_96_sigma_and_nan_epochs_are_left_out():
    rng = np.random.default_rng(1)
    d = rng.normal(0.0, 3.0, 400_000)
    d[::10] = np.nan
    assert vertical_95_m(d) == pytest.approx(1.95996 * 3.0, rel=0.01)


def test_bridging_time_is_when_the_error_first_crosses_the_threshold():
    t = np.arange(100.0)
    err = np.where((t >= 40) & (t < 70), 0.5 * (t - 40), 0.1)[None, :].repeat(2, axis=0)
    err[1] *= 2.0  # the second trial drifts twice as fast: it sets the worst case
    outage = (t >= 40) & (t < 70)
    out = outage_bridging_s(err, outage, 1.0)
    assert out == {"2m": 3.0, "10m": 11.0}
    assert math.isnan(outage_bridging_s(err, np.zeros(100, bool), 1.0)["2m"])
    # An outage still going on when the record ends has no known length: it is left out.
    cut = outage.copy()
    cut[95:] = True
    assert outage_bridging_s(err, cut, 1.0) == {"2m": 3.0, "10m": 11.0}

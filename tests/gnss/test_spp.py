"""Single-point positioning on the RTKLIB stations' real RINEX: the surveyed header positions come back."""

from __future__ import annotations

import numpy as np
import pytest

from chronofuse.gnss.spp import single_point_position


@pytest.mark.parametrize("station", ["07590920", "30400920"])
def test_single_point_position_lands_near_the_header_position(rtklib, station):
    obs, nav = rtklib[station]
    pos, clock_s, used = single_point_position(obs, nav)
    assert np.isfinite(pos).all() and used.min() >= 4
    per_epoch = np.linalg.norm(pos - obs.approx_position_m, axis=1)
    mean_error = np.linalg.norm(pos.mean(axis=0) - obs.approx_position_m)
    # measured: 0759: 0.75 m (mean position), 0.88 m median per epoch; 3040: 1.07 m, 1.16 m
    assert mean_error < 1.5
    assert np.percentile(per_epoch, 95) < 10.0
    # the receiver clock moves smoothly (Trimble 5700: about 1.4 us/s here)
    assert np.median(np.abs(np.diff(clock_s, 2))) < 50e-9

"""Anomaly injection: step, ramp, drag-off, burst; on a receiver clock or one satellite channel."""

import numpy as np
import pytest

from chronofuse.integrity.inject import Anomaly, anomaly_profile, inject


def test_step_ramp_and_drag_follow_their_formulas_from_the_onset():
    t = np.arange(10) * 0.5
    tau = np.clip(t - 2.0, 0.0, None)
    on = t >= 2.0
    np.testing.assert_allclose(anomaly_profile(Anomaly("step", 2.0, offset_s=3e-8), 10, 0.5), np.where(on, 3e-8, 0.0))
    np.testing.assert_allclose(anomaly_profile(Anomaly("ramp", 2.0, rate_s_per_s=1e-9), 10, 0.5), 1e-9 * tau)
    np.testing.assert_allclose(anomaly_profile(Anomaly("drag", 2.0, accel_s_per_s2=4e-10), 10, 0.5), 0.5 * 4e-10 * tau**2)


def test_a_drag_off_is_a_constant_shift_of_the_second_difference():
    profile = anomaly_profile(Anomaly("drag", 5.0, accel_s_per_s2=2e-10), 40, 1.0)
    df = np.diff(profile, 2)
    np.testing.assert_allclose(df[6:], 2e-10, rtol=1e-9)


def test_duration_holds_the_offset_reached_and_ends_a_burst():
    ramp = anomaly_profile(Anomaly("ramp", 1.0, rate_s_per_s=1.0, duration_s=3.0), 8, 1.0)
    np.testing.assert_allclose(ramp, [0, 0, 1, 2, 3, 3, 3, 3])
    burst = anomaly_profile(Anomaly("burst", 2.0, sigma_s=1e-8, duration_s=3.0), 1000, 1.0, np.random.default_rng(0))
    assert (burst[:2] == 0).all() and (burst[5:] == 0).all() and (burst[2:5] != 0).all()


def test_burst_noise_has_the_requested_spread_and_needs_a_generator():
    burst = anomaly_profile(Anomaly("burst", 0.0, sigma_s=2e-9), 20_000, 1.0, np.random.default_rng(1))
    assert burst.std() == pytest.approx(2e-9, rel=0.03)
    with pytest.raises(ValueError, match="rng"):
        anomaly_profile(Anomaly("burst", 0.0, sigma_s=2e-9), 10, 1.0)


def test_inject_returns_a_copy_on_batches_and_keeps_missing_epochs():
    x = np.zeros((3, 20))
    x[1, 5] = np.nan
    y = inject(x, Anomaly("step", 10.0, offset_s=1.0), 1.0)
    assert (x[np.isfinite(x)] == 0).all()
    assert np.isnan(y[1, 5]) and (y[:, 10:] == 1.0).all() and (y[:, :10][np.isfinite(y[:, :10])] == 0).all()
    z = inject(x, Anomaly("burst", 0.0, sigma_s=1.0), 1.0, np.random.default_rng(2))
    assert not np.allclose(z[0], z[2])  # independent bursts per row


def test_a_satellite_channel_gets_the_anomaly_and_the_others_do_not():
    biases = np.zeros((50, 4))
    y = inject(biases, Anomaly("drag", 10.0, accel_s_per_s2=1e-9, channel=2), 1.0)
    assert (y[:, [0, 1, 3]] == 0).all()
    np.testing.assert_allclose(y[:, 2], anomaly_profile(Anomaly("drag", 10.0, accel_s_per_s2=1e-9), 50, 1.0))
    with pytest.raises(ValueError, match="channel"):
        inject(biases, Anomaly("step", 0.0, offset_s=1.0, channel=4), 1.0)


def test_bad_anomalies_name_the_field():
    with pytest.raises(ValueError, match="kind"):
        Anomaly("jump", 0.0, offset_s=1.0)
    with pytest.raises(ValueError, match="start_s"):
        Anomaly("step", -1.0, offset_s=1.0)
    with pytest.raises(ValueError, match="duration_s"):
        Anomaly("step", 0.0, offset_s=1.0, duration_s=0.0)


def test_each_kind_takes_its_size_in_a_field_named_with_its_unit_and_no_other():
    assert Anomaly("ramp", 0.0, rate_s_per_s=2e-10).magnitude == 2e-10
    assert [Anomaly(k, 0.0, **{f: 1.0}).unit for k, f in
            (("step", "offset_s"), ("ramp", "rate_s_per_s"), ("drag", "accel_s_per_s2"), ("burst", "sigma_s"))] == [
        "s", "s/s", "s/s^2", "s"]
    with pytest.raises(ValueError, match="rate_s_per_s == None"):
        Anomaly("ramp", 0.0)
    with pytest.raises(ValueError, match="offset_s == 1e-08, must be None for a ramp"):
        Anomaly("ramp", 0.0, rate_s_per_s=1e-10, offset_s=1e-8)
    with pytest.raises(ValueError, match="sigma_s"):
        Anomaly("burst", 0.0, sigma_s=-1e-9)
    with pytest.raises(TypeError):
        Anomaly("step", 0.0, 1e-8)  # the size is never positional: its unit must show at the call

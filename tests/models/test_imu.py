"""The IMU truth model: its Allan deviation, computed with our own stability engine, shows the datasheet."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

import chronofuse.analysis.stability as st
from chronofuse.models.imu import DEG, DEG_PER_H, IMU_GRADES, ImuModel, SensorErrors, imu_grade, simulate_imu

RATE_HZ = 100.0


def _static(model: ImuModel, seconds: float, trials: int, seed: int = 3):
    steps = int(seconds * RATE_HZ)
    zero = np.zeros((steps, 3))
    return simulate_imu(model, zero, zero, RATE_HZ, trials=trials, seed=seed)


def _pooled_adev(rate: np.ndarray, tau_s: np.ndarray):
    """Allan deviation of every (trial, axis) series of ``rate`` (trials, steps, 3), pooled, with its EDF."""
    series = rate.transpose(0, 2, 1).reshape(-1, rate.shape[1])
    devs = [st.oadev(st.frequency_to_phase(y, RATE_HZ), RATE_HZ, tau_s) for y in series]
    avar = np.mean([d.dev**2 for d in devs], axis=0)
    edf = len(devs) * np.asarray(devs[0].edf)
    return np.sqrt(avar), edf


def _inside_999(measured, theory, edf) -> np.ndarray:
    """Inside the 99.9 % chi-square interval of theory (15 checks in all: Bonferroni-safe at ~1.5 %)."""
    lo = theory * np.sqrt(stats.chi2.ppf(0.0005, edf) / edf)
    hi = theory * np.sqrt(stats.chi2.ppf(0.9995, edf) / edf)
    return (lo <= measured) & (measured <= hi)


@pytest.mark.parametrize("term", ["white_density", "bias_instability", "bias_random_walk"])
def test_each_gyro_error_term_alone_has_the_ieee_952_allan_deviation(term):
    err = SensorErrors(**{"white_density": 0.0, term: {"white_density": 0.01 * DEG, "bias_instability": 10 * DEG_PER_H,
                                                         "bias_random_walk": 1e-4 * DEG}[term]})
    model = ImuModel("one-term", gyro=err, accel=SensorErrors(white_density=0.0), source="test")
    truth = _static(model, 400.0, trials=4)
    tau = np.array([0.01, 0.1, 1.0, 10.0, 40.0])
    adev, edf = _pooled_adev(truth.gyro_rad_per_s, tau)
    inside = _inside_999(adev, err.allan_deviation(tau), edf)
    assert inside.all(), (adev / err.allan_deviation(tau), edf)


def test_the_tactical_grade_reads_back_its_datasheet_arw_and_bias_floor():
    model = imu_grade("tactical")
    truth = _static(model, 2000.0, trials=2)
    tau = np.array([1.0, 10.0, 100.0])
    adev, _ = _pooled_adev(truth.gyro_rad_per_s, tau)
    # ARW: sigma(1 s) = N (0.125 deg/sqrt(h)), within the few-percent bias-floor contribution.
    assert adev[0] == pytest.approx(model.gyro.white_density, rel=0.05)
    assert adev == pytest.approx(model.gyro.allan_deviation(tau), rel=0.1)
    # The accelerometer's VRW (0.065 ft/s/sqrt(h)) and its bias floor are comparable at 1 s: the sum shows.
    accel, _ = _pooled_adev(truth.accel_m_per_s2, tau)
    assert accel == pytest.approx(model.accel.allan_deviation(tau), rel=0.1)


def test_the_bias_instability_floor_is_0_664_b_where_it_dominates():
    err = SensorErrors(white_density=1e-6, bias_instability=1e-3)
    model = ImuModel("floor", gyro=err, accel=SensorErrors(white_density=0.0), source="test")
    adev, _ = _pooled_adev(_static(model, 200.0, trials=4).gyro_rad_per_s, np.array([1.0, 10.0, 50.0]))
    assert adev == pytest.approx(math.sqrt(2 * math.log(2) / math.pi) * 1e-3, rel=0.1)


def test_a_held_slow_bias_keeps_the_floor_from_a_few_bias_intervals_on():
    err = SensorErrors(white_density=1e-6, bias_instability=1e-3)
    model = ImuModel("floor", gyro=err, accel=SensorErrors(white_density=0.0), source="test")
    zero = np.zeros((40_000, 3))
    held = simulate_imu(model, zero, zero, RATE_HZ, trials=4, seed=3, bias_rate_hz=1.0)
    adev, _ = _pooled_adev(held.gyro_rad_per_s, np.array([1.0, 10.0, 50.0]))
    floor = math.sqrt(2 * math.log(2) / math.pi) * 1e-3
    assert adev[1:] == pytest.approx(floor, rel=0.1)
    # At one bias interval the overlapping averages straddle the holds and see less of it.
    assert 0.6 * floor < adev[0] < floor
    with pytest.raises(ValueError, match="bias_rate_hz"):
        simulate_imu(model, zero, zero, RATE_HZ, bias_rate_hz=30.0)


def test_scale_factor_and_misalignment_act_on_the_true_motion():
    err = SensorErrors(white_density=0.0, scale_factor=1e-2, misalignment_rad=1e-3)
    model = ImuModel("matrix", gyro=err, accel=err, source="test")
    omega = np.tile([0.1, -0.2, 0.3], (50, 1))
    truth = simulate_imu(model, omega, omega, RATE_HZ, trials=3, seed=1)
    expected = np.einsum("nij,tj->nti", truth.gyro_matrix, omega)
    assert np.allclose(truth.gyro_rad_per_s, expected, rtol=0, atol=1e-15)
    diag = np.diagonal(truth.gyro_matrix, axis1=1, axis2=2) - 1.0
    assert 0 < np.abs(diag).max() < 5e-2


def test_a_trial_does_not_depend_on_how_many_trials_run():
    zero = np.zeros((500, 3))
    one = simulate_imu(IMU_GRADES["consumer"], zero, zero, RATE_HZ, trials=1, seed=7)
    three = simulate_imu(IMU_GRADES["consumer"], zero, zero, RATE_HZ, trials=3, seed=7)
    assert np.array_equal(one.gyro_rad_per_s[0], three.gyro_rad_per_s[0])
    assert not np.array_equal(three.gyro_rad_per_s[0], three.gyro_rad_per_s[1])


def test_every_grade_cites_its_source_and_orders_by_quality():
    grades = [IMU_GRADES[g] for g in ("consumer", "industrial", "tactical")]
    assert all(g.source for g in grades)
    arw = [g.gyro.white_density for g in grades]
    assert arw[0] > arw[2] and grades[0].gyro.bias_instability > grades[1].gyro.bias_instability > grades[2].gyro.bias_instability


def test_truth_of_the_wrong_shape_is_refused_naming_it():
    with pytest.raises(ValueError, match="angular_rate_rad_per_s"):
        simulate_imu(IMU_GRADES["consumer"], np.zeros((10, 2)), np.zeros((10, 3)), RATE_HZ)
    with pytest.raises(ValueError, match="grade"):
        imu_grade("navigation")

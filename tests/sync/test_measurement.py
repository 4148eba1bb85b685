"""The complete two-way measurement model against the exact light-time simulation: both nodes moving in 3-D,
on the rotating Earth, with large offsets and skews, and the sizes of its terms."""

import numpy as np
import pytest

from chronofuse.constants import EARTH_ROTATION_RAD_PER_S as OMEGA
from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.models.earth_frame import EarthRotating
from chronofuse.models.kinematics import constant_velocity
from chronofuse.models.link import LinkModel, simulate_exchanges
from chronofuse.sync import measurement as M

NOISELESS = LinkModel(toa_model="none", urt_jitter_s=0.0, urt_fixed_s=37e-9)


def _run(a, b, offset=1e-6, skew=1e-6, steps=200, rate_a=2e-7, offset_a=5e-9):
    t = np.arange(steps + 2) * NOISELESS.interval_s
    xa = np.broadcast_to(offset_a + rate_a * t, (1, steps + 2)).copy()
    xb = np.broadcast_to(offset + (skew + rate_a) * t, (1, steps + 2)).copy()
    return simulate_exchanges(a, b, xa, xb, NOISELESS, steps, 0)


def _residual(ex):
    z1 = M.offset_measurement_s(ex.t_i_s, ex.t_b_s, ex.t_r_s)
    model = (ex.offset_s + ex.skew * M.skew_coefficient_s(ex.t_i_s, ex.t_b_s, ex.offset_s)
             + M.known_offset_terms_s(ex.t_i_s, ex.t_b_s, ex.radial_velocity_m_s, ex.a_los_velocity_m_s, ex.offset_s)
             + M.urt_coefficient(ex.radial_velocity_m_s) * ex.urt_s)
    return z1 - model


@pytest.mark.parametrize("earth", [False, True])
@pytest.mark.parametrize("offset, skew", [(1e-6, 1e-6), (-3e-6, -1e-7), (1e-3, 1e-6)])
def test_the_model_matches_exact_light_time_for_two_nodes_moving_in_3d(earth, offset, skew):
    a = constant_velocity([0, 0, 3000.0], [250.0, 30.0, 5.0])
    b = constant_velocity([150e3, 80e3, 5000.0], [-900.0, 1200.0, -20.0])
    if earth:
        a, b = EarthRotating(a, 10.0, 20.0), EarthRotating(b, 10.0, 20.0)
    ex = _run(a, b, offset, skew)
    # what is left is the transverse motion between the legs (2e-13 s here), not a term of the model
    assert np.max(np.abs(_residual(ex))) < 3e-13
    # without the skew's action over the light time the model is off by about eps_dot T_i / 2
    without = _residual(ex) + ex.skew * (ex.t_i_s - ex.offset_s) / 2.0
    assert np.max(np.abs(without)) == pytest.approx(abs(skew) * np.max(ex.tau_up_s) / 2.0, rel=0.05)


def test_a_common_velocity_along_the_line_is_the_d_v_over_c2_term_of_0_22_ns():
    a = constant_velocity([0.0, 0, 0], [250.0, 0, 0])
    b = constant_velocity([80e3, 0, 0], [250.0, 0, 0])
    ex = _run(a, b, offset=0.0, skew=0.0, rate_a=0.0, offset_a=0.0)
    known = M.known_offset_terms_s(ex.t_i_s, ex.t_b_s, ex.radial_velocity_m_s, ex.a_los_velocity_m_s)
    assert known[0, 0] == pytest.approx(80e3 * 250.0 / C**2, rel=1e-4)
    assert known[0, 0] == pytest.approx(0.2225e-9, rel=1e-3)
    assert np.max(np.abs(_residual(ex))) < 1e-15


def test_two_nodes_at_rest_on_the_equator_200_km_apart_east_west_see_the_sagnac_nanosecond():
    a = EarthRotating(constant_velocity([0.0, 0, 0], [0.0, 0, 0]), 0.0, 0.0)
    b = EarthRotating(constant_velocity([200e3, 0, 0], [0.0, 0, 0]), 0.0, 0.0)
    ex = _run(a, b, offset=0.0, skew=0.0, rate_a=0.0, offset_a=0.0)
    z1 = M.offset_measurement_s(ex.t_i_s, ex.t_b_s, ex.t_r_s) - M.urt_coefficient(0.0) * ex.urt_s
    r_a, r_b = a.position_at(np.zeros((1, 1)))[0, 0], b.position_at(np.zeros((1, 1)))[0, 0]
    sagnac = OMEGA * np.cross(r_a, r_b)[2] / C**2
    assert z1[0, 0] == pytest.approx(sagnac, rel=1e-3)
    assert sagnac == pytest.approx(1.03e-9, rel=0.01)


def test_a_urt_change_moves_the_offset_by_minus_half_and_the_range_by_plus_c_over_2():
    a = constant_velocity([0.0, 0, 0], [0.0, 0, 0])
    b = constant_velocity([50e3, 0, 0], [0.0, 0, 0])
    ex = _run(a, b, offset=0.0, skew=0.0, rate_a=0.0, offset_a=0.0)
    link2 = LinkModel(toa_model="none", urt_jitter_s=0.0, urt_fixed_s=42e-9)
    t = np.zeros((1, 202))
    ex2 = simulate_exchanges(a, b, t, t, link2, 200, 0)
    d1 = M.offset_measurement_s(ex2.t_i_s, ex2.t_b_s, ex2.t_r_s) - M.offset_measurement_s(ex.t_i_s, ex.t_b_s, ex.t_r_s)
    d3 = M.range_measurement_m(ex2.t_i_s, ex2.t_b_s, ex2.t_r_s) - M.range_measurement_m(ex.t_i_s, ex.t_b_s, ex.t_r_s)
    np.testing.assert_allclose(d1, M.URT_SIGNATURE[0] * 5e-9, rtol=1e-6)
    np.testing.assert_allclose(d3, M.URT_SIGNATURE[1] * 5e-9, rtol=1e-6)

"""The complete two-way measurement model: what one exchange's timestamps say about the clocks.

One model serves the filter (:mod:`chronofuse.sync.doppler`), the bound (:mod:`chronofuse.sync.pcrb`),
the URT calibration (:mod:`chronofuse.sync.calibration`) and the URT monitor
(:mod:`chronofuse.sync.monitor`), so none of them can leave a term out that the others keep.

Derivation (first order in ``v/c`` and in the clocks' rates). Exchange ``k``: A sends at true
time ``t1``; at ``t1`` the range is ``R``, the unit vector from A to B is ``u``, the nodes' inertial
velocities are ``v_A``, ``v_B`` and the radial velocity is ``v_r = u . (v_B - v_A)``. With ``Delta = t3 -
t1 ~ T_B + t_p - eps`` (B's reply leaves ``t_p`` after its stamp ``T_B``), the light-times are::

    tau_up   = R / (c - u.v_B)                  ~ (R/c) (1 + u.v_B / c)
    tau_down = (R + v_r Delta) / (c + u.v_A)    ~ ((R + v_r Delta)/c) (1 - u.v_A / c)

and the clocks move during the exchange: B's stamp of the request carries ``x_B(t2) = x_B(t1) + y_B
tau_up`` and A's stamp of the reply ``x_A(t4) = x_A(t1) + y_A (Delta + tau_down)``. The paper's eq. (1)
combination ``z1 = (T_i - T_r + T_B) / 2`` is then::

    z1 = eps + eps_dot (T_B + T_i - 2 eps) / 2          the offset's change over the exchange and the
                                                         light time (eps_dot = y_B - y_A)
            - v_r (T_B - T_i) / (2c)                     the range change between the two legs
            + (T_i - eps) (u . v_A) / c                  A's own motion along the line of sight:
                                                         R (u . v_A) / c^2
            - (1 + v_r / c) t_p / 2                      the URT
            + (delta_i - delta_r - j) / 2                TOA noise and URT jitter

The ``eps_dot T_i / 2`` part is the clock's frequency offset acting over the light time; ``R (u . v_A) /
c^2`` is the term that appears when both nodes move (0.22 ns for nodes 80 km apart flying at 250 m/s
along the line between them), and when the truth frame is the Earth-centred inertial one it includes the
Earth's rotation, i.e. the Sagnac effect ``omega . (r_A x r_B) / c^2`` (1.0 ns for 200 km east-west at
the equator). The paper's eq. (9) keeps only ``v T_B`` of the range change, with ``S1/c`` for the uplink;
its first-order light time leaves ``S1 v / (2 c^2)``.

What is left out: second-order light-time terms (below 1e-13 s up to 3000 m/s and 1000 km) and the
transverse motion between the legs, ``-|v_t|^2 Delta^2 / (4 R c)`` for a transverse relative speed
``v_t`` (2e-13 s at 170 km and 1700 m/s, checked against the exact simulation in the tests; it grows as
``1/R`` and reaches 1e-11 s only for encounters closer than about 1 km at 1000 m/s).

The round trip ``z3 = c (T_i + T_r - T_B) / 2`` measures the range::

    z3 = R (1 + v_r / (2c)) + v_r T_B / 2 - c eps_dot (T_B - eps) / 2 + (y_A + y_B) R / 2 + c t_p / 2
            + c (delta_i + delta_r + j) / 2

where ``y_A``, ``y_B`` are the clocks' own rates against true time (their sum, not their difference: with
rates of 1e-6 the term is 0.1 m at 200 km, slowly varying, and a range state absorbs it).

A URT change moves ``z1`` by ``-dt_p / 2`` and ``z3`` by ``+c dt_p / 2`` at once: the signature the URT
monitor tests for. The noise of ``z1`` and ``z3`` is correlated through the jitter ``j``.
"""

from __future__ import annotations

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C

__all__ = ["offset_measurement_s", "range_measurement_m", "skew_coefficient_s", "known_offset_terms_s",
           "urt_coefficient", "offset_noise_var_s2", "range_noise_var_m2", "offset_range_cov_s_m",
           "URT_SIGNATURE"]

#: How a change ``dt_p`` of the URT moves ``(z1 [s], z3 [m])``, per second of URT.
URT_SIGNATURE = np.array([-0.5, 0.5 * C])


def offset_measurement_s(t_i_s, t_b_s, t_r_s):
    """``z1 = (T_i - T_r + T_B) / 2``, s (the paper's eq. 1; IEEE 1588's offset from the four stamps)."""
    return (np.asarray(t_i_s) - np.asarray(t_r_s) + np.asarray(t_b_s)) / 2.0


def range_measurement_m(t_i_s, t_b_s, t_r_s):
    """``z3 = c (T_i + T_r - T_B) / 2``, m (the round trip less B's reply time)."""
    return C * (np.asarray(t_i_s) + np.asarray(t_r_s) - np.asarray(t_b_s)) / 2.0


def skew_coefficient_s(t_i_s, t_b_s, offset_s=0.0):
    """The coefficient of ``eps_dot`` in ``z1``: ``(T_B + T_i - 2 eps) / 2``, s."""
    return (np.asarray(t_b_s) + np.asarray(t_i_s) - 2.0 * np.asarray(offset_s)) / 2.0


def known_offset_terms_s(t_i_s, t_b_s, velocity_m_s, a_los_velocity_m_s, offset_s=0.0):
    """The geometric terms of ``z1`` that the node computes from its measurements, s:
    ``-v_r (T_B - T_i) / (2c) + (T_i - eps) (u . v_A) / c`` (module docstring)."""
    t_i, t_b = np.asarray(t_i_s), np.asarray(t_b_s)
    return (-np.asarray(velocity_m_s) * (t_b - t_i) / (2.0 * C)
            + (t_i - np.asarray(offset_s)) * np.asarray(a_los_velocity_m_s) / C)


def urt_coefficient(velocity_m_s):
    """``d z1 / d t_p = -(1 + v_r / c) / 2`` (the paper's eq. 18 has ``-c / (2c + v)``, equal to first order
    in the sign of ``v`` but not in its size; both are -1/2 within 1e-5 below 3000 m/s)."""
    return -(1.0 + np.asarray(velocity_m_s) / C) / 2.0


def offset_noise_var_s2(toa_sigma_s, urt_jitter_s, velocity_sigma_m_s=0.0, t_i_s=0.0, t_b_s=0.0):
    """Variance of ``z1`` about the model, s^2: ``(2 sigma_TOA^2 + sigma_j^2) / 4`` plus the Doppler noise
    entering through ``v_r (T_B - T_i) / (2c)``."""
    lever = (np.asarray(t_b_s) - np.asarray(t_i_s)) / (2.0 * C)
    return (2.0 * np.asarray(toa_sigma_s) ** 2 + urt_jitter_s**2) / 4.0 + (np.asarray(velocity_sigma_m_s) * lever) ** 2


def range_noise_var_m2(toa_sigma_s, urt_jitter_s):
    """Variance of ``z3``, m^2: ``c^2 (2 sigma_TOA^2 + sigma_j^2) / 4``."""
    return C**2 * (2.0 * np.asarray(toa_sigma_s) ** 2 + urt_jitter_s**2) / 4.0


def offset_range_cov_s_m(urt_jitter_s):
    """Covariance of the noises of ``z1`` and ``z3``, s m: ``-c sigma_j^2 / 4`` (the TOA terms cancel)."""
    return -C * urt_jitter_s**2 / 4.0

"""Closed-form offsets of one two-way exchange (the swarm paper's eqs. 1, 9, 18; IEEE 1588-2019 section 11.3).

Timestamps relative to the slot start, A's transmission ``t1 = 0``: ``t_i`` (B's arrival stamp,
IEEE ``t2``), ``t_b`` (B's reply stamp, ``t3``), ``t_r`` (A's arrival stamp, ``t4``). ``v`` is the
radial velocity (positive: opening), ``c`` the speed of light.
"""

from __future__ import annotations

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C

__all__ = ["ptp_offset_s", "ptp_delay_s", "rvc_offset_paper_s", "rvc_offset_exact_s", "urt_sensitivity"]


def ptp_offset_s(t_i_s, t_b_s, t_r_s):
    """IEEE 1588 offset ``((t2 - t1) - (t4 - t3)) / 2`` = the paper's eq. (1) ``(T_i - T_r + T_B) / 2``."""
    return (np.asarray(t_i_s) - np.asarray(t_r_s) + np.asarray(t_b_s)) / 2.0


def ptp_delay_s(t_i_s, t_b_s, t_r_s):
    """IEEE 1588 mean path delay ``((t2 - t1) + (t4 - t3)) / 2``."""
    return (np.asarray(t_i_s) + np.asarray(t_r_s) - np.asarray(t_b_s)) / 2.0


def rvc_offset_paper_s(t_i_s, t_b_s, t_r_s, v_m_s):
    """The paper's eq. (9): ``eps = (c (T_i - T_r + T_B) + v T_B) / (2c + v)`` (first-order light-time)."""
    t_i, t_b, t_r, v = (np.asarray(a) for a in (t_i_s, t_b_s, t_r_s, v_m_s))
    return (C * (t_i - t_r + t_b) + v * t_b) / (2.0 * C + v)


def rvc_offset_exact_s(t_i_s, t_b_s, t_r_s, v_m_s):
    """Velocity-compensated offset with the exact uplink light-time ``S1 / (c - v)``.

    With A at rest in the truth frame and B receding at constant ``v``: ``T_i = eps + S1/(c - v)`` and
    ``T_r = T_B - eps + (S1 + v (T_B - eps)) / c``; eliminating ``S1`` gives
    ``eps = (c (T_i - T_r + T_B) + v (T_B - T_i)) / (2c)``. The paper's eq. (9) is the same with ``S1/c`` for
    the uplink, which leaves the bias ``S1 v / (2 c^2)`` (0.89 ns at 80 km and 2000 m/s).
    """
    t_i, t_b, t_r, v = (np.asarray(a) for a in (t_i_s, t_b_s, t_r_s, v_m_s))
    return (C * (t_i - t_r + t_b) + v * (t_b - t_i)) / (2.0 * C)


def urt_sensitivity(v_m_s):
    """The paper's eq. (18): ``alpha = d eps / d t_p = -c / (2c + v)`` (about -1/2)."""
    return -C / (2.0 * C + np.asarray(v_m_s))

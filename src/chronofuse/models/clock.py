"""The two-state clock (phase and frequency) with white FM and random-walk FM, sampled exactly.

This is the clock model of SPEC section 4 (and of the receiver's free-running oscillator): per step
``dt`` the white-FM phase increment is ``N(0, h0 dt / 2)``, the random-walk frequency increment is
``dy ~ N(0, q2 dt)`` with ``q2 = 2 pi^2 h_-2``, and the phase that ``dy`` adds within the step is
``dy dt / 2 + N(0, q2 dt^3 / 12)``, so that the (phase, frequency) increments have the covariance
``q2 [[dt^3/3, dt^2/2], [dt^2/2, dt]]`` of the discrete two-state model (Van Dierendonck, McGraw and
Brown 1984; Brown and Hwang, *Introduction to Random Signals and Applied Kalman Filtering*). The second
difference of the phase then has SPEC section 4's autocorrelation exactly.
"""

from __future__ import annotations

import math

import numpy as np


def two_state_clock_phase_s(
    z_wfm: np.ndarray, z_rwfm: np.ndarray, z_rwfm_phase: np.ndarray, *, h0: float, hm2: float, dt_s: float
) -> np.ndarray:
    """Phase (s) of the two-state clock from unit-normal draws, ``x[..., 0] = 0``.

    ``z_wfm``, ``z_rwfm``, ``z_rwfm_phase`` are unit normals of one shape ``(..., steps)`` (the last
    step's draws are not used: they would move the phase after the record); ``h0`` (s) and ``hm2``
    (1/s) are the one-sided S_y coefficients, ``dt_s`` the step. Returns the phase, shape ``(..., steps)``.
    """
    q2 = 2.0 * math.pi**2 * hm2
    dy = math.sqrt(q2 * dt_s) * z_rwfm
    y_before = np.cumsum(dy, axis=-1) - dy  # random-walk frequency at the start of each step
    dx = (math.sqrt(h0 / 2.0 * dt_s) * z_wfm + y_before * dt_s + dy * (dt_s / 2.0)
          + math.sqrt(q2 * dt_s**3 / 12.0) * z_rwfm_phase)
    return np.concatenate([np.zeros(dx.shape[:-1] + (1,)), np.cumsum(dx[..., :-1], axis=-1)], axis=-1)

"""The clock's discrete process model (phase, frequency, drift) and the two-state clock sampled exactly.

Continuous model (Van Dierendonck, McGraw and Brown, "Relationship between Allan variances and Kalman
filter parameters", 16th PTTI, 1984; Brown and Hwang, *Introduction to Random Signals and Applied
Kalman Filtering*, 4th ed., sec. 9.3): phase ``x`` (s), fractional frequency ``y`` and, optionally,
frequency drift ``D`` (1/s), with ``dx/dt = y + w1``, ``dy/dt = D + w2``, ``dD/dt = w3``, white noises of
two-sided spectral densities ``q1 = h0 / 2`` (s, white FM), ``q2 = 2 pi^2 h_-2`` (1/s, random-walk FM) and
``q3`` (1/s^3, random-walk drift). Over a step ``dt`` the exact discretisation is ``s(k+1) = Phi s(k) + w(k)``::

    Phi = [[1, dt, dt^2/2],        Q = [[q1 dt + q2 dt^3/3 + q3 dt^5/20,  q2 dt^2/2 + q3 dt^4/8,  q3 dt^3/6],
           [0, 1,  dt    ],             [q2 dt^2/2 + q3 dt^4/8,          q2 dt + q3 dt^3/3,       q3 dt^2/2],
           [0, 0,  1     ]]             [q3 dt^3/6,                      q3 dt^2/2,               q3 dt    ]]

and the two-state model is the leading 2 x 2 block (``q3 = 0``). This module is the one home of ``Phi``
and ``Q``: the truth simulators sample them and the estimators (``chronofuse.estimation.process``) filter
with them.

:func:`two_state_clock_phase_s` samples the two-state model without a Cholesky factor (so any intensity may
be zero): per step the white-FM phase increment is ``N(0, q1 dt)``, the random-walk frequency increment is
``dy ~ N(0, q2 dt)``, and the phase that ``dy`` adds within the step is ``dy dt / 2 + N(0, q2 dt^3 / 12)``,
so that the (phase, frequency) increments have covariance ``Q`` above. The second difference of the phase
then has exactly the autocorrelation the HOD detector assumes (:mod:`chronofuse.integrity.noise_model`).
"""

from __future__ import annotations

import math

import numpy as np

from chronofuse.validation import check_choice, check_scalar


def clock_intensities(h0: float, hm2: float) -> tuple[float, float]:
    """``(q1, q2) = (h0 / 2, 2 pi^2 h_-2)``: white-FM (s) and random-walk-FM (1/s) spectral densities."""
    return 0.5 * h0, 2.0 * math.pi**2 * hm2


def clock_transition(dt_s: float, states: int = 2) -> np.ndarray:
    """``Phi`` of the clock over one step ``dt_s`` (s): shape (2, 2) for (phase, frequency), (3, 3) with drift."""
    check_scalar(dt_s, "dt_s", min_val=0.0)
    check_choice(states, "states", (2, 3))
    dt = float(dt_s)
    phi = np.array([[1.0, dt, 0.5 * dt**2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    return phi[:states, :states]


def clock_process_noise(dt_s: float, *, h0: float, hm2: float, drift_psd_per_s3: float = 0.0,
                        states: int = 2) -> np.ndarray:
    """``Q`` of the clock over one step ``dt_s`` (s), Van Dierendonck et al. 1984 (module docstring).

    ``h0`` (s) and ``hm2`` (1/s) are the one-sided ``S_y`` coefficients of white FM and random-walk FM;
    ``drift_psd_per_s3`` is ``q3``, the spectral density of the white noise driving the drift (needs
    ``states=3``). Returns (2, 2) or (3, 3), symmetric positive semi-definite.
    """
    check_scalar(dt_s, "dt_s", min_val=0.0)
    check_scalar(h0, "h0", min_val=0.0)
    check_scalar(hm2, "hm2", min_val=0.0)
    check_scalar(drift_psd_per_s3, "drift_psd_per_s3", min_val=0.0)
    check_choice(states, "states", (2, 3))
    if states == 2 and drift_psd_per_s3 != 0.0:
        raise ValueError(f"drift_psd_per_s3 == {drift_psd_per_s3}, must be 0 for the two-state clock (states=2)")
    q1, q2 = clock_intensities(h0, hm2)
    q3 = float(drift_psd_per_s3)
    dt = float(dt_s)
    q = np.array([
        [q1 * dt + q2 * dt**3 / 3.0 + q3 * dt**5 / 20.0, q2 * dt**2 / 2.0 + q3 * dt**4 / 8.0, q3 * dt**3 / 6.0],
        [q2 * dt**2 / 2.0 + q3 * dt**4 / 8.0, q2 * dt + q3 * dt**3 / 3.0, q3 * dt**2 / 2.0],
        [q3 * dt**3 / 6.0, q3 * dt**2 / 2.0, q3 * dt],
    ])
    return q[:states, :states]


def two_state_clock_phase_s(
    z_wfm: np.ndarray, z_rwfm: np.ndarray, z_rwfm_phase: np.ndarray, *, h0: float, hm2: float, dt_s: float
) -> np.ndarray:
    """Phase (s) of the two-state clock from unit-normal draws, ``x[..., 0] = 0``.

    ``z_wfm``, ``z_rwfm``, ``z_rwfm_phase`` are unit normals of one shape ``(..., steps)`` (the last
    step's draws are not used: they would move the phase after the record); ``h0`` (s) and ``hm2``
    (1/s) are the one-sided S_y coefficients, ``dt_s`` the step. Returns the phase, shape ``(..., steps)``.
    The (phase, frequency) increments are ``w = G z`` with ``G G^T =`` :func:`clock_process_noise`.
    """
    q2 = clock_intensities(h0, hm2)[1]
    dy = math.sqrt(q2 * dt_s) * z_rwfm
    y_before = np.cumsum(dy, axis=-1) - dy  # random-walk frequency at the start of each step
    dx = (math.sqrt(h0 / 2.0 * dt_s) * z_wfm + y_before * dt_s + dy * (dt_s / 2.0)
          + math.sqrt(q2 * dt_s**3 / 12.0) * z_rwfm_phase)
    return np.concatenate([np.zeros(dx.shape[:-1] + (1,)), np.cumsum(dx[..., :-1], axis=-1)], axis=-1)

"""Posterior Cramér–Rao bound of a moving two-way link (derivation: docs/sync/pcrb.md).

Tichavský, Muravchik and Nehorai, "Posterior Cramér-Rao bounds for discrete-time nonlinear
filtering", IEEE Trans. Signal Processing 46(5), 1998, eq. (21): for ``x(k+1) = F x(k) + w``,
``w ~ N(0, Q)``, ``z(k) = h_k(x(k)) + v``, ``v ~ N(0, R)``, the information ``J`` of the state obeys::

    J(k+1) = D22 - D21 (J(k) + D11)^-1 D12,
    D11 = F' Q^-1 F,   D12 = -F' Q^-1 = D21',   D22 = Q^-1 + E[H' R^-1 H],

with ``H`` the Jacobian of ``h_k`` and ``J(0) = P0^-1 + H0' R^-1 H0``; the bound is ``J^-1``.

The link model (that of :class:`~chronofuse.sync.chain.ProposedChain` ``filter="doppler"``):
state ``[eps, eps_dot, v]``; the clock block of ``Q`` from both oscillators' ``h0``, ``h-2``
(Van Dierendonck et al. 1984), the velocity a random walk of white acceleration ``accel_psd``
(a small value stands for the truth's constant velocity: ``Q`` must be invertible); the two
measurements of each exchange, the URT-compensated offset of seed eq. (1)
``z1 = eps + eps_dot T_B / 2 - v (T_B - T_i) / (2c)`` with variance ``(2 sigma_TOA^2 + sigma_jitter^2) / 4`` (the fixed
URT calibrated) and the Doppler velocity ``z2 = v`` with variance ``sigma_v^2``. ``T_i`` is taken at its
noiseless value ``range(k) / c``; the Jacobian's dependence on the noise is below 1e-12 relative.
At zero velocity it reduces to the static two-way bound of Skog and Händel (IEEE TSP 58(4), 2010),
checked in tests/sync/test_pcrb.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.estimation.interface import FrozenResult
from chronofuse.models.clock import clock_process_noise
from chronofuse.models.link import LinkModel
from chronofuse.models.oscillator import OscillatorModel
from chronofuse.validation import check_array, check_scalar

__all__ = ["PcrbResult", "tichavsky_pcrb", "link_model_matrices", "link_pcrb"]


@dataclass(frozen=True)
class PcrbResult(FrozenResult):
    """``bound`` (steps, n, n): the PCRB matrix after each exchange; ``offset_var_s2`` (steps,) and
    ``skew_var`` (steps,): its offset and fractional-frequency diagonal entries."""

    bound: np.ndarray
    offset_var_s2: np.ndarray
    skew_var: np.ndarray


def tichavsky_pcrb(F, Q, H_seq, R, P0) -> np.ndarray:
    """The PCRB ``J(k)^-1`` (steps, n, n) of a linear Gaussian model (module docstring's recursion).

    ``F`` (n, n), ``Q`` (n, n) invertible, ``H_seq`` (steps, m, n), ``R`` (m, m), ``P0`` (n, n) the prior
    covariance of the first state.
    """
    F, Q, R, P0 = (check_array(a, name, ndim=2) for a, name in ((F, "F"), (Q, "Q"), (R, "R"), (P0, "P0")))
    H_seq = check_array(H_seq, "H_seq", ndim=3)
    Qi, Ri = np.linalg.inv(Q), np.linalg.inv(R)
    D11 = F.T @ Qi @ F
    D12 = -F.T @ Qi
    J = np.linalg.inv(P0) + H_seq[0].T @ Ri @ H_seq[0]
    out = np.empty((H_seq.shape[0],) + F.shape)
    out[0] = np.linalg.inv(J)
    for k in range(1, H_seq.shape[0]):
        D22 = Qi + H_seq[k].T @ Ri @ H_seq[k]
        J = D22 - D12.T @ np.linalg.solve(J + D11, D12)
        J = 0.5 * (J + J.T)
        out[k] = np.linalg.inv(J)
    return out


def link_model_matrices(link: LinkModel, h0: float, hm2: float, steps: int, distance_m: float,
                        velocity_m_s: float, accel_psd: float = 1e-4):
    """``(F, Q, H_seq, R)`` of the moving two-way link model (module docstring)."""
    check_scalar(steps, "steps", min_val=1, integer=True)
    check_scalar(accel_psd, "accel_psd", min_val=0.0, include_min=False)
    dt = link.interval_s
    F = np.eye(3)
    F[0, 1] = dt
    Q = np.zeros((3, 3))
    Q[:2, :2] = clock_process_noise(dt, h0=h0, hm2=hm2)
    Q[2, 2] = accel_psd * dt
    rng_m = distance_m + velocity_m_s * dt * np.arange(int(steps))
    H = np.zeros((int(steps), 2, 3))
    H[:, 0, 0] = 1.0
    H[:, 0, 1] = link.reply_delay_s / 2.0  # eq. (1) averages eps over the exchange's T_B
    H[:, 0, 2] = -(link.reply_delay_s - rng_m / C) / (2.0 * C)
    H[:, 1, 2] = 1.0
    R = np.diag([(2.0 * link.toa_sigma_s**2 + link.urt_jitter_s**2) / 4.0, link.velocity_sigma_m_s**2])
    return F, Q, H, R


def link_pcrb(link: LinkModel, oscillator: OscillatorModel, steps: int, distance_m: float, velocity_m_s: float,
              *, accel_psd: float = 1e-4, offset_sigma_s: float = 1e-3, frequency_sigma: float = 1e-6,
              velocity_sigma_m_s: float = 3000.0) -> PcrbResult:
    """PCRB of offset and skew over ``steps`` exchanges of ``link`` between two ``oscillator`` clocks.

    The prior is broad (``offset_sigma_s``, ``frequency_sigma``, ``velocity_sigma_m_s``): the bound is
    then set by the exchanges, not by the prior.
    """
    F, Q, H, R = link_model_matrices(link, 2.0 * oscillator.h.h0, 2.0 * oscillator.h.hm2, steps, distance_m,
                                     velocity_m_s, accel_psd)
    P0 = np.diag([offset_sigma_s**2, frequency_sigma**2, velocity_sigma_m_s**2])
    bound = tichavsky_pcrb(F, Q, H, R, P0)
    return PcrbResult(bound=bound, offset_var_s2=bound[:, 0, 0].copy(), skew_var=bound[:, 1, 1].copy())

"""The Bayesian bound of a two-way link under its stated prior (derivation: docs/sync/pcrb.md).

For a linear Gaussian state-space model ``x(k+1) = Phi x(k) + w``, ``z(k) = H_k x(k) + n``, the posterior
Cramér–Rao bound (Van Trees' Bayesian bound; Tichavský, Muravchik and Nehorai, IEEE Trans. Signal
Processing 46(5), 1998, eq. (21)) is the Kalman filter's posterior covariance under the true model: no
estimator's mean-square error, averaged over the prior and the noise, is below it. The information form
of Tichavský's recursion (:func:`tichavsky_pcrb`) needs ``Q`` invertible; the covariance form
(:func:`bayesian_bound`) does not, and the tests check that both agree where both apply.

The link model (one model with the filter, :mod:`chronofuse.sync.measurement`):

* state ``[eps, y, g_1 .. g_M, b]``: the offset, the skew with random-walk FM, the flicker-FM components of
  :class:`~chronofuse.models.clock_markov.ClockMarkovModel`, and ``b`` the error of the calibrated URT
  (constant, prior sigma from :mod:`chronofuse.sync.calibration`, never observable from the link);
* the prior: ``eps ~ N(., offset_sigma^2)``, ``y ~ N(., skew_sigma^2)``, flicker parts stationary
  (:mod:`chronofuse.sync.prior`);
* one row per exchange, ``z1 = eps + c_k (y + sum g) + a_k b + n``, ``c_k = (T_B + T_i - 2 eps) / 2``,
  ``a_k = -(1 + v_k / c) / 2``, ``var(n) = (2 sigma_TOA,k^2 + sigma_j^2)/4`` (+ the Doppler lever term), the
  TOA sigma from each exchange's SNR; a lost exchange has no row. The geometric terms of ``z1`` are known
  and do not enter the bound. ``T_i`` and ``eps`` in ``c_k`` are the exchange's (the bound is
  conditional on the geometry, which the nodes know to far better than the coefficient needs).

The bound printed beside an RMSE is ``sqrt(mean_k P_k[eps, eps])`` over the run (``rms``) and its last value
(``final``); averaged over trials, ``sqrt(mean over trials and k)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.estimation.interface import FrozenResult
from chronofuse.models.clock_markov import ClockMarkovModel
from chronofuse.models.link import LinkModel
from chronofuse.models.oscillator import OscillatorModel
from chronofuse.sync.measurement import offset_noise_var_s2, skew_coefficient_s, urt_coefficient
from chronofuse.sync.prior import LinkPrior
from chronofuse.validation import check_array, check_scalar

__all__ = ["PcrbResult", "tichavsky_pcrb", "bayesian_bound", "link_rows", "exchange_bound", "link_pcrb"]


@dataclass(frozen=True)
class PcrbResult(FrozenResult):
    """``offset_var_s2`` (trials, steps): the bound on the offset's mean-square error after each exchange;
    ``skew_var`` (trials, steps): on the skew's; ``rms_s`` (trials,) and ``final_s`` (trials,): the offset
    bound's RMS over the run and its last value, s."""

    offset_var_s2: np.ndarray
    skew_var: np.ndarray
    rms_s: np.ndarray
    final_s: np.ndarray

    @property
    def mean_rms_s(self) -> float:
        """``sqrt(mean over trials and exchanges)``: the bound of an RMSE over all of them."""
        return float(np.sqrt(np.mean(self.offset_var_s2)))


def tichavsky_pcrb(F, Q, H_seq, R, P0) -> np.ndarray:
    """The PCRB ``J(k)^-1`` (steps, n, n) of a linear Gaussian model by Tichavský's information recursion.

    ``F`` (n, n), ``Q`` (n, n) invertible, ``H_seq`` (steps, m, n), ``R`` (m, m), ``P0`` (n, n) the prior
    covariance of the first state::

        J(k+1) = D22 - D21 (J(k) + D11)^-1 D12,  D11 = F' Q^-1 F,  D12 = -F' Q^-1,  D22 = Q^-1 + H' R^-1 H.
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


def bayesian_bound(Phi, Q, H, R, P0) -> np.ndarray:
    """The posterior covariance (trials, steps, n, n) of a scalar-measurement linear Gaussian model.

    ``Phi``, ``Q`` (n, n); ``H`` (trials, steps, n) one row per exchange (NaN: no measurement); ``R``
    (trials, steps) its noise variance; ``P0`` (n, n) or (trials, n, n) the prior covariance. Covariance
    form (``Q`` may be singular): ``P- = Phi P Phi' + Q``, ``P = P- - P- h h' P- / (h' P- h + r)``.
    """
    Phi, Q = check_array(Phi, "Phi", ndim=2), check_array(Q, "Q", ndim=2)
    H = check_array(H, "H", ndim=3, allow_nan=True)
    R = check_array(R, "R", ndim=2, allow_nan=True)
    trials, steps, n = H.shape
    P = np.broadcast_to(np.asarray(P0, dtype=np.float64), (trials, n, n)).copy()
    out = np.empty((trials, steps, n, n))
    for k in range(steps):
        if k:
            P = Phi @ P @ Phi.T + Q
        h, r = H[:, k], R[:, k]
        seen = np.isfinite(h).all(axis=1) & np.isfinite(r)
        h0 = np.where(seen[:, None], h, 0.0)
        Ph = np.einsum("tij,tj->ti", P, h0)
        s = np.einsum("ti,ti->t", h0, Ph) + np.where(seen, r, 1.0)
        P = P - np.where(seen, 1.0 / s, 0.0)[:, None, None] * Ph[:, :, None] * Ph[:, None, :]
        P = 0.5 * (P + np.swapaxes(P, 1, 2))
        out[:, k] = P
    return out


def link_rows(clock: ClockMarkovModel, t_i_s, t_b_s, offset_s, velocity_m_s, *, with_urt: bool = True) -> np.ndarray:
    """The measurement rows ``H`` (trials, steps, n) of ``z1`` over the state of the module docstring
    (``with_urt=False``: without the calibration state ``b``); NaN where the exchange was lost."""
    c = skew_coefficient_s(t_i_s, t_b_s, offset_s)
    m = clock.n_states - 2
    cols = [np.ones_like(c), c] + [c] * m
    if with_urt:
        cols.append(urt_coefficient(velocity_m_s) + 0.0 * c)
    H = np.stack(cols, axis=-1)
    return np.where(np.isfinite(c)[..., None], H, np.nan)


def _prior_covariance(clock: ClockMarkovModel, prior: LinkPrior, calibration_sigma_s, trials: int) -> np.ndarray:
    m = clock.n_states - 2
    n = clock.n_states + 1
    P0 = np.zeros((trials, n, n))
    P0[:, 0, 0] = prior.offset_sigma_s**2
    P0[:, 1, 1] = prior.skew_sigma**2
    P0[:, 2:2 + m, 2:2 + m] = np.diag(clock.flicker_variances())
    P0[:, -1, -1] = np.broadcast_to(np.asarray(calibration_sigma_s, dtype=np.float64), (trials,)) ** 2
    return P0


def exchange_bound(link: LinkModel, clock: ClockMarkovModel, prior: LinkPrior, *, t_i_s, t_b_s, offset_s,
                   velocity_m_s, snr_db, calibration_sigma_s=0.0) -> PcrbResult:
    """The bound for exchanges with this geometry (arrays (trials, steps); NaN ``t_i_s``: lost), under
    ``prior`` and a calibration of uncertainty ``calibration_sigma_s`` (scalar or (trials,))."""
    t_i = check_array(t_i_s, "t_i_s", ndim=2, allow_nan=True)
    Phi_c, Q_c = clock.discrete(link.interval_s)
    n = clock.n_states + 1
    Phi, Q = np.eye(n), np.zeros((n, n))
    Phi[:-1, :-1], Q[:-1, :-1] = Phi_c, Q_c
    H = link_rows(clock, t_i, t_b_s, offset_s, velocity_m_s)
    R = offset_noise_var_s2(link.toa_sigma_at(snr_db), link.urt_jitter_s, link.velocity_sigma_at(snr_db), t_i, t_b_s)
    P = bayesian_bound(Phi, Q, H, np.where(np.isfinite(t_i), R, np.nan),
                       _prior_covariance(clock, prior, calibration_sigma_s, t_i.shape[0]))
    var = P[:, :, 0, 0]
    return PcrbResult(offset_var_s2=var, skew_var=P[:, :, 1, 1], rms_s=np.sqrt(var.mean(axis=1)),
                      final_s=np.sqrt(var[:, -1]))


def link_pcrb(link: LinkModel, oscillator: OscillatorModel, steps: int, distance_m: float, velocity_m_s: float,
              *, prior: LinkPrior | None = None, calibration_sigma_s: float = 0.0, flicker: bool = True) -> PcrbResult:
    """The bound of one nominal link: range ``distance_m + velocity_m_s t``, the reply slot and SNR of
    ``link``, both clocks ``oscillator`` (flicker FM included unless ``flicker=False``), ``prior``
    (default :class:`~chronofuse.sync.prior.LinkPrior`), a calibration of ``calibration_sigma_s``."""
    check_scalar(steps, "steps", min_val=1, integer=True)
    prior = LinkPrior() if prior is None else prior
    t = np.arange(int(steps)) * link.interval_s
    rng_m = np.maximum(distance_m + velocity_m_s * t, 0.0)[None, :]
    clock = ClockMarkovModel.for_link(oscillator, oscillator, link.interval_s, steps * link.interval_s, flicker=flicker)
    return exchange_bound(link, clock, prior, t_i_s=rng_m / C, t_b_s=np.full_like(rng_m, link.reply_delay_s),
                          offset_s=0.0, velocity_m_s=np.full_like(rng_m, velocity_m_s), snr_db=link.snr_at(rng_m),
                          calibration_sigma_s=calibration_sigma_s)

"""A clock as a finite state model with flicker FM: white FM, random-walk FM and flicker FM as a sum of
Gauss–Markov frequency processes, discretised exactly. The sync filter and its bound share it.

Flicker FM (``S_y = h_-1 / f``) has no finite state model; over a band ``[f_lo, f_hi]`` it is a sum of
first-order Gauss–Markov (Ornstein–Uhlenbeck) frequency components with corner frequencies spaced
evenly in ``log f``, because ``1/f = (2/pi) int_0^inf (1/f_c) / (1 + (f/f_c)^2) d(ln f_c)`` (the
standard construction: e.g. Keshner, "1/f noise", Proc. IEEE 70(3), 1982; Kasdin, Proc. IEEE 83(5), 1995,
section IV). With ``M`` corners a ratio ``r`` apart, component ``j`` has the one-sided PSD
``h_-1 (2 ln r / pi) / f_j / (1 + (f/f_j)^2)``, hence rate ``lambda_j = 2 pi f_j`` and stationary variance
``h_-1 ln r``. One corner per decade keeps the Allan deviation within 5 % of the flicker floor
``sqrt(2 ln 2 h_-1)`` for ``2 / f_hi < tau < 1 / (30 f_lo)`` (so up to a third of the run with the band
:meth:`ClockMarkovModel.for_link` takes) (the tests check it against the closed-form Allan variance of an
OU process, ``s^2 (2x - 3 + 4 e^-x - e^-2x) / x^2``, ``x = lambda tau``).

Continuous model, state ``[x, y, g_1 .. g_M]`` (phase s, frequency offset with random walk, flicker parts)::

    dx = (y + sum g_j) dt + sqrt(q1) dW_x,    dy = sqrt(q2) dW_y,    dg_j = -lambda_j g_j dt + sigma_j dW_j,

``q1 = h0 / 2``, ``q2 = 2 pi^2 h_-2`` (as :func:`chronofuse.models.clock.clock_process_noise`),
``sigma_j^2 = 2 lambda_j h_-1 ln r``. ``Phi`` and ``Q`` over a step come from Van Loan's method (C. F.
Van Loan, "Computing integrals involving the matrix exponential", IEEE Trans. Autom. Control 23(3),
1978). The difference of two independent clocks is the same model with the coefficients added.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from chronofuse.models.oscillator import OscillatorModel
from chronofuse.validation import check_scalar

__all__ = ["ClockMarkovModel", "flicker_corners_hz", "ou_allan_variance"]


def flicker_corners_hz(f_lo_hz: float, f_hi_hz: float, per_decade: float = 1.0) -> tuple[np.ndarray, float]:
    """Corner frequencies (M,), Hz, spaced evenly in ``log f`` over ``[f_lo, f_hi]`` (each at the middle of
    its cell), and their ratio ``r``."""
    check_scalar(f_lo_hz, "f_lo_hz", min_val=0.0, include_min=False)
    check_scalar(f_hi_hz, "f_hi_hz", min_val=f_lo_hz, include_min=False)
    check_scalar(per_decade, "per_decade", min_val=0.5)
    m = max(1, int(math.ceil(math.log10(f_hi_hz / f_lo_hz) * per_decade)))
    ratio = (f_hi_hz / f_lo_hz) ** (1.0 / m)
    return f_lo_hz * ratio ** (np.arange(m) + 0.5), float(ratio)


def ou_allan_variance(tau_s, rate_per_s: float, variance: float) -> np.ndarray:
    """Allan variance of an OU frequency process of rate ``lambda`` and stationary ``variance``:
    ``s^2 (2x - 3 + 4 e^-x - e^-2x) / x^2`` with ``x = lambda tau`` (series below x = 1e-3)."""
    x = rate_per_s * np.asarray(tau_s, dtype=np.float64)
    small = x < 1e-3
    xs = np.where(small, 1.0, x)
    g = np.where(small, (2.0 / 3.0) * x**3 - 0.5 * x**4, 2.0 * xs - 3.0 + 4.0 * np.exp(-xs) - np.exp(-2.0 * xs))
    return variance * g / np.where(small, np.maximum(x, 1e-300), xs) ** 2


@dataclass(frozen=True)
class ClockMarkovModel:
    """White FM ``h0_s`` (s), flicker FM ``hm1`` (dimensionless), random-walk FM ``hm2_per_s`` (1/s), flicker
    band ``[flicker_lo_hz, flicker_hi_hz]`` with ``corners_per_decade`` (module docstring)."""

    h0_s: float
    hm1: float
    hm2_per_s: float
    flicker_lo_hz: float = 1e-3
    flicker_hi_hz: float = 100.0
    corners_per_decade: float = 1.0

    def __post_init__(self):
        for name in ("h0_s", "hm1", "hm2_per_s"):
            check_scalar(getattr(self, name), name, min_val=0.0)
        flicker_corners_hz(self.flicker_lo_hz, self.flicker_hi_hz, self.corners_per_decade)

    @classmethod
    def for_link(cls, a: OscillatorModel, b: OscillatorModel, interval_s: float, duration_s: float,
                 *, flicker: bool = True) -> "ClockMarkovModel":
        """The offset ``x_B - x_A`` of two independent oscillators, its flicker band from ``1 / (10 duration)``
        to ``1 / interval`` (``flicker=False``: flicker left out, the model the bound used to have)."""
        return cls(h0_s=a.h.h0 + b.h.h0, hm1=(a.h.hm1 + b.h.hm1) if flicker else 0.0,
                   hm2_per_s=a.h.hm2 + b.h.hm2, flicker_lo_hz=1.0 / (10.0 * duration_s),
                   flicker_hi_hz=1.0 / interval_s)

    @property
    def corners_hz(self) -> np.ndarray:
        """Flicker corner frequencies (M,), Hz; none when ``hm1`` is 0."""
        if self.hm1 == 0.0:
            return np.zeros(0)
        return flicker_corners_hz(self.flicker_lo_hz, self.flicker_hi_hz, self.corners_per_decade)[0]

    @property
    def n_states(self) -> int:
        """``2 + M``: phase, frequency, and one state per flicker corner."""
        return 2 + self.corners_hz.size

    def flicker_variances(self) -> np.ndarray:
        """Stationary variance of each flicker component (M,): ``h_-1 ln r``."""
        if self.hm1 == 0.0:
            return np.zeros(0)
        _, ratio = flicker_corners_hz(self.flicker_lo_hz, self.flicker_hi_hz, self.corners_per_decade)
        return np.full(self.corners_hz.size, self.hm1 * math.log(ratio))

    def continuous(self) -> tuple[np.ndarray, np.ndarray]:
        """``(A, Qc)``: the drift matrix and the white-noise intensities of the continuous model."""
        lam = 2.0 * math.pi * self.corners_hz
        n = self.n_states
        A = np.zeros((n, n))
        A[0, 1:] = 1.0
        A[2:, 2:] = -np.diag(lam)
        qc = np.concatenate([[self.h0_s / 2.0, 2.0 * math.pi**2 * self.hm2_per_s], 2.0 * lam * self.flicker_variances()])
        return A, np.diag(qc)

    def discrete(self, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
        """``(Phi, Q)`` over one step of ``dt_s`` (Van Loan's method; computed once per model and step, then
        copies of the stored matrices are returned)."""
        check_scalar(dt_s, "dt_s", min_val=0.0, include_min=False)
        Phi, Q = _discrete(self, float(dt_s))
        return Phi.copy(), Q.copy()

    def _van_loan(self, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
        A, Qc = self.continuous()
        n = A.shape[0]
        block = np.zeros((2 * n, 2 * n))
        block[:n, :n] = -A
        block[:n, n:] = Qc
        block[n:, n:] = A.T
        E = scipy.linalg.expm(block * dt_s)
        Phi = E[n:, n:].T
        Q = Phi @ E[:n, n:]
        return Phi, 0.5 * (Q + Q.T)

    def allan_variance(self, tau_s) -> np.ndarray:
        """The model's Allan variance at ``tau_s``: ``h0/(2 tau) + (2 pi^2/3) h_-2 tau`` plus its flicker parts."""
        tau = np.asarray(tau_s, dtype=np.float64)
        out = self.h0_s / (2.0 * tau) + (2.0 * math.pi**2 / 3.0) * self.hm2_per_s * tau
        for f_c, var in zip(self.corners_hz, self.flicker_variances()):
            out = out + ou_allan_variance(tau, 2.0 * math.pi * f_c, var)
        return out

    def simulate_phase_s(self, steps: int, dt_s: float, rng: np.random.Generator, trials: int = 1) -> np.ndarray:
        """Phase (trials, steps) of this very model, exact in distribution (the flicker parts start from their
        stationary law, phase and frequency at 0): a truth the bound describes without approximation."""
        Phi, Q = self.discrete(dt_s)
        n = Phi.shape[0]
        L = np.linalg.cholesky(Q + 1e-300 * np.eye(n)) if np.all(np.diag(Q) > 0) else _psd_sqrt(Q)
        state = np.zeros((trials, n))
        state[:, 2:] = rng.standard_normal((trials, n - 2)) * np.sqrt(self.flicker_variances())
        out = np.empty((trials, int(steps)))
        draws = rng.standard_normal((int(steps), trials, n))
        for k in range(int(steps)):
            out[:, k] = state[:, 0]
            state = state @ Phi.T + draws[k] @ L.T
        return out


@functools.lru_cache(maxsize=256)
def _discrete(model: ClockMarkovModel, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    return model._van_loan(dt_s)


def _psd_sqrt(Q: np.ndarray) -> np.ndarray:
    w, V = np.linalg.eigh(Q)
    return V * np.sqrt(np.clip(w, 0.0, None))

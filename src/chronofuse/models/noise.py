"""Noise processes of the truth models: power-law noise (Kasdin–Walter) and the Gauss-Markov process.

Power-law noise
---------------

A sequence ``u`` with power spectral density ``S(f) ~ f**alpha`` is white noise ``e`` (unit variance)
through the fractional-difference filter ``H(z) = (1 - z**-1) ** (alpha / 2)`` (Kasdin & Walter 1992,
"Discrete simulation of power law noise", Proc. IEEE FCS, eqs. (26)-(28)). Its impulse response is

    h[0] = 1,   h[k] = h[k-1] * (k - 1 - alpha/2) / k,

and the output is the causal (truncated) convolution ``u[n] = sum_{k<=n} h[k] e[n-k]``, computed by FFT.
With ``nu = f * tau0`` (cycles per sample), the two-sided PSD of ``u`` per unit ``nu`` is
``|2 sin(pi nu)| ** alpha``; the one-sided PSD in physical units is therefore

    S(f) = 2 tau0 |2 sin(pi f tau0)| ** alpha  ~=  2 tau0 (2 pi tau0) ** alpha * f ** alpha,

so scaling ``u`` by ``sqrt(h_alpha / (2 tau0 (2 pi tau0) ** alpha))`` gives the one-sided level ``h_alpha``
at low frequency (Kasdin & Walter eq. (39); allantools ``Noise.frequency_psd_from_qd``).

For flicker noise (alpha = -1) the K-W spectrum carries more power near the Nyquist frequency than
the continuous process it stands for; :func:`flicker_fm_gain` and :func:`flicker_pm_gain` are
zero-phase shaping gains that make the discrete spectrum equal the sampled continuous one (see
``chronofuse.models.oscillator`` for why and for the resulting exact Allan variances).

Memory: the convolution is done by uniformly partitioned FFT blocks (:class:`PartitionedConvolution`),
one trial at a time in float64: about 2 x 16 bytes per sample (impulse-response spectra shared by all
trials, plus the current trial's input spectra) instead of a 2x-padded full-length FFT and the FFT
library's scratch space (another 2x).

First-order Gauss-Markov
------------------------
:func:`gauss_markov`: the AR(1) recursion ``x_k = phi x_{k-1} + sigma sqrt(1 - phi^2) w_k``,
``phi = exp(-dt / tau)``, started from its stationary law, so that ``E[x_k x_{k+n}] = sigma^2
exp(-n dt / tau)`` exactly (R. G. Brown and P. Y. C. Hwang, *Introduction to Random Signals and Applied
Kalman Filtering*, 4th ed., ch. 2): the receiver's multipath, wander and geometry.
"""

from __future__ import annotations

import numpy as np
import scipy.fft
from scipy import special

from chronofuse.validation import check_scalar

__all__ = [
    "kasdin_walter_impulse_response",
    "fft_length",
    "PartitionedConvolution",
    "KasdinWalterFilter",
    "shaping_kernel",
    "power_law_noise",
    "flicker_fm_gain",
    "flicker_pm_gain",
    "tabulated_gain",
    "gauss_markov",
]

_CHUNK = 1 << 20  # frequency bins handled at once when applying a shaping gain


def _fill_impulse_response(out: np.ndarray, alpha: float, n_samples: int) -> None:
    """Write the K-W impulse response into ``out[:n_samples]`` (chunked cumulative product)."""
    out[0] = 1.0
    carry = 1.0
    for start in range(1, n_samples, _CHUNK):
        stop = min(start + _CHUNK, n_samples)
        k = np.arange(start, stop, dtype=np.float64)
        chunk = out[start:stop]
        np.divide(k - 1.0 - alpha / 2.0, k, out=chunk)
        np.cumprod(chunk, out=chunk)
        chunk *= carry
        carry = float(chunk[-1])


def kasdin_walter_impulse_response(alpha: float, n_samples: int) -> np.ndarray:
    """Impulse response ``h`` of shape (n_samples,) of ``(1 - z**-1) ** (alpha/2)``.

    Kasdin & Walter (1992) eq. (28): ``h[0] = 1``, ``h[k] = h[k-1] (k - 1 - alpha/2) / k``
    (equivalently ``Gamma(k + d) / (Gamma(d) k!)`` with ``d = -alpha/2``).
    """
    check_scalar(alpha, "alpha", min_val=-4.0, max_val=2.0)
    check_scalar(n_samples, "n_samples", min_val=1, integer=True)
    h = np.empty(int(n_samples), dtype=np.float64)
    _fill_impulse_response(h, float(alpha), int(n_samples))
    return h


def fft_length(n_samples: int) -> int:
    """Even, FFT-friendly length >= ``2 n_samples - 1``: room for a linear (not circular) convolution."""
    length = scipy.fft.next_fast_len(max(2 * int(n_samples) - 1, 2), real=True)
    while length % 2:
        length = scipy.fft.next_fast_len(length + 1, real=True)
    return length


class PartitionedConvolution:
    """Causal linear convolution with a fixed impulse response, by uniformly partitioned FFT blocks.

    ``u[n] = sum_{k=0}^{n} impulse[k] x[n-k]`` (``np.convolve(impulse, x)[:n]``, its readable twin in the
    tests). The impulse response is cut into blocks of ``block`` samples whose spectra (FFT length
    ``fft_length(block)``) are kept; the input is consumed block by block, and output block ``s`` is the
    inverse FFT of ``sum_i H_i X_{s-i}`` overlap-added with the previous block's tail. Memory is two
    sets of spectra (impulse and the last ``len(impulse)/block`` input blocks, ~16 bytes per sample
    each) plus a few blocks, instead of the 2x-padded full-length FFT and its scratch space.
    """

    def __init__(self, impulse: np.ndarray, block: int):
        impulse = np.asarray(impulse, dtype=np.float64)
        if impulse.ndim != 1 or impulse.size == 0:
            raise ValueError(f"impulse has shape {impulse.shape}, must be (k,) with k >= 1")
        check_scalar(block, "block", min_val=1, integer=True)
        self.block = int(block)
        self.fft_len = fft_length(self.block)
        self.spectra = [
            np.fft.rfft(impulse[start : start + self.block], n=self.fft_len)
            for start in range(0, impulse.size, self.block)
        ]

    def blocks(self, source, n_out: int):
        """Yield ``(start, u_block)`` covering ``u[0:n_out]`` in order; ``u_block`` is a fresh array.

        ``source`` is a 1-D array (zero beyond its end) or a ``numpy.random.Generator`` (unit normals,
        drawn ``block`` at a time in order, so the draws equal ``standard_normal(n)`` of one call).
        """
        b, f = self.block, self.fft_len
        history: list[np.ndarray] = []
        carry = np.zeros(b - 1)
        for start in range(0, n_out, b):
            if isinstance(source, np.random.Generator):
                chunk = source.standard_normal(min(b, n_out - start))
            else:
                chunk = np.asarray(source[start : start + b], dtype=np.float64)
                if chunk.size == 0:  # past the end of a finite input: zeros
                    chunk = np.zeros(1)
            history.insert(0, np.fft.rfft(chunk, n=f))
            del history[len(self.spectra) :]
            acc = history[0] * self.spectra[0]
            product = np.empty_like(acc)
            for spectrum_h, spectrum_x in zip(self.spectra[1:], history[1:]):
                np.multiply(spectrum_h, spectrum_x, out=product)
                acc += product
            segment = np.fft.irfft(acc, n=f)
            del acc, product
            out = segment[:b].copy()
            out[: b - 1] += carry
            carry = segment[b : 2 * b - 1].copy()
            yield start, out[: n_out - start]


def _block_size(n_samples: int) -> int:
    """Partition size: the whole record up to 2**16 samples, else about an eighth of it."""
    return n_samples if n_samples <= 1 << 16 else -(-n_samples // 8)


def shaping_kernel(gain, half_width: int = 1024, grid: int = 8192) -> np.ndarray:
    """Zero-phase FIR ``g[-half_width..half_width]``, shape (2 half_width + 1,), with response ``gain(nu)``.

    Fourier coefficients of the real, even, periodic ``gain`` sampled on ``grid`` points; for the
    flicker gains below the discarded tail (|j| > 1024) carries < 1e-9 of the kernel's energy.
    """
    check_scalar(half_width, "half_width", min_val=0, integer=True)
    check_scalar(grid, "grid", min_val=2 * half_width + 2, integer=True)
    nu = np.arange(grid // 2 + 1) / grid
    kernel = np.fft.irfft(gain(nu), n=grid)
    return np.concatenate((kernel[grid - half_width :], kernel[: half_width + 1]))


class KasdinWalterFilter:
    """K-W power-law filter of ``n_samples`` outputs, optionally shaped by a zero-phase gain.

    Without a gain, ``add_row(dest, rng)`` adds ``u[n] = sum_{k<=n} h[k] e[n-k]`` to ``dest``. With
    ``gain``, the impulse response is ``h`` convolved with :func:`shaping_kernel(gain)` (two-sided,
    ``P`` = half width), and the innovations start ``P`` samples before the first output, so the
    output is the K-W process (started ``P`` samples earlier) seen through the shaping filter.
    """

    def __init__(self, alpha: float, n_samples: int, gain=None):
        check_scalar(n_samples, "n_samples", min_val=1, integer=True)
        self.n_samples = int(n_samples)
        if gain is None:
            self.skip = 0
            impulse = h = kasdin_walter_impulse_response(alpha, self.n_samples)
        else:
            kernel = shaping_kernel(gain)
            self.skip = (kernel.size - 1) // 2
            n_impulse = self.n_samples + self.skip
            h = kasdin_walter_impulse_response(alpha, n_impulse)
            short = PartitionedConvolution(kernel, max(kernel.size, 1 << 16))
            impulse = np.empty(n_impulse)
            for start, block in short.blocks(h, n_impulse):
                impulse[start : start + block.size] = block
            del short
        del h
        self._convolution = PartitionedConvolution(impulse, _block_size(self.n_samples + self.skip))

    def add_row(self, dest: np.ndarray, rng: np.random.Generator, scale: float = 1.0) -> None:
        """``dest += scale * u`` for one trial drawn from ``rng``; ``dest`` has shape (n_samples,)."""
        if dest.shape != (self.n_samples,):
            raise ValueError(f"dest has shape {dest.shape}, must be ({self.n_samples},)")
        for start, block in self._convolution.blocks(rng, self.n_samples + self.skip):
            lo = max(start, self.skip)
            hi = start + block.size
            if hi > lo:
                block *= scale
                dest[lo - self.skip : hi - self.skip] += block[lo - start :]


def power_law_noise(alpha: float, n_samples: int, rng: np.random.Generator, trials: int = 1) -> np.ndarray:
    """Kasdin–Walter discrete power-law noise, shape (trials, n_samples).

    Parameters
    ----------
    alpha : float
        Spectral exponent, ``S(f) ~ f**alpha``, in [-4, 2] (0 white, -1 flicker, -2 random walk).
    n_samples : int
        Samples per trial.
    rng : numpy.random.Generator
        Source of the unit-variance white innovations (drawn trial by trial, ``n_samples`` each).
    trials : int
        Number of independent rows.

    Returns
    -------
    ndarray of shape (trials, n_samples)
        Row ``i`` is ``sum_{k<=n} h[k] e_i[n-k]`` (Kasdin & Walter 1992 eq. (26)); its two-sided PSD per
        unit normalised frequency ``nu`` is ``|2 sin(pi nu)| ** alpha``. Alpha 0 (white) and -2 (random
        walk, ``h[k] = 1``) are computed without FFT from the same draws.
    """
    check_scalar(alpha, "alpha", min_val=-4.0, max_val=2.0)
    check_scalar(n_samples, "n_samples", min_val=1, integer=True)
    check_scalar(trials, "trials", min_val=1, integer=True)
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng == {rng!r}, must be a numpy.random.Generator")
    n_samples, trials = int(n_samples), int(trials)
    out = np.empty((trials, n_samples), dtype=np.float64)
    if alpha == 0.0:
        for i in range(trials):
            out[i] = rng.standard_normal(n_samples)
        return out
    if alpha == -2.0:
        for i in range(trials):
            np.cumsum(rng.standard_normal(n_samples), out=out[i])
        return out
    kw = KasdinWalterFilter(alpha, n_samples)
    out[:] = 0.0
    for i in range(trials):
        kw.add_row(out[i], rng)
    return out


def flicker_pm_gain(nu: np.ndarray) -> np.ndarray:
    """Amplitude gain that turns the K-W flicker spectrum into a brick-wall ``1/f`` spectrum.

    K-W flicker (alpha = -1) has two-sided PSD ``1 / |2 sin(pi nu)|``; the band-limited continuous
    flicker PM that NIST SP 1065's flicker-PM formula assumes (cut-off ``f_h`` = Nyquist) has
    ``1 / (2 pi |nu|)`` below Nyquist. Their ratio is ``sin(pi nu) / (pi nu) = sinc(nu)``, so the
    amplitude gain is ``sqrt(sinc(nu))`` (1 at nu = 0, sqrt(2/pi) at nu = 1/2).
    """
    return np.sqrt(np.sinc(np.asarray(nu, dtype=np.float64)))


def flicker_fm_gain(nu: np.ndarray) -> np.ndarray:
    """Amplitude gain that turns K-W flicker into interval-averaged continuous flicker FM.

    Averaging continuous flicker frequency ``y(t)`` (two-sided PSD ``h/(2|f|)``, no cut-off) over each
    sample interval and sampling gives, by aliasing (Poisson summation), the discrete PSD
    ``(h/2) sum_k sinc(nu+k)**2 / |nu+k| = (h/2) sin(pi nu)**2 / pi**2 [zeta(3, nu) + zeta(3, 1-nu)]``
    for 0 < nu <= 1/2 (Hurwitz zeta). Divided by the K-W spectrum ``pi h / (2 sin(pi nu))`` this is

        R(nu) = (sin(pi nu) / (pi nu))**3 [1 + nu**3 (zeta(3, 1+nu) + zeta(3, 1-nu))],

    written so that it is well conditioned at ``nu -> 0`` (R(0) = 1, R(1/2) = 14 zeta(3) / pi**3).
    Returns ``sqrt(R(|nu|))``. A test checks it against the aliasing sum done term by term.
    """
    nu = np.abs(np.asarray(nu, dtype=np.float64))
    aliases = special.zeta(3.0, 1.0 + nu) + special.zeta(3.0, np.maximum(1.0 - nu, 0.5))  # nu in [0, 1/2]
    ratio = np.sinc(nu) ** 3 * (1.0 + nu**3 * aliases)
    return np.sqrt(ratio)


def tabulated_gain(gain, points: int = 4097):
    """Return ``gain`` as a linear interpolant on ``points`` nodes over nu in [0, 1/2].

    For smooth gains (both above) the interpolation error is below 1e-7 with the default 4097
    nodes, and evaluating it on ~1e7 FFT bins costs a fraction of the FFT itself.
    """
    check_scalar(points, "points", min_val=2, integer=True)
    nodes = np.linspace(0.0, 0.5, int(points))
    values = gain(nodes)

    def interpolant(nu: np.ndarray) -> np.ndarray:
        return np.interp(np.abs(nu), nodes, values)

    return interpolant


def gauss_markov(w: np.ndarray, sigma: float, tau_s: float, dt_s: float) -> np.ndarray:
    """Stationary first-order Gauss-Markov process from unit normals, along the last axis.

    ``w`` has shape ``(..., steps + 1)``: ``w[..., 0]`` draws the initial state from the stationary law
    ``N(0, sigma^2)``; the result ``x`` has shape ``(..., steps)`` with
    ``x_k = phi x_{k-1} + sigma sqrt(1 - phi^2) w_k``, ``phi = exp(-dt_s / tau_s)``, hence
    ``E[x_k x_{k+n}] = sigma^2 phi^n`` (Brown and Hwang, ch. 2), computed by an AR(1) IIR filter
    (:func:`scipy.signal.lfilter`; the tests compare it with the recursion written as a loop).
    """
    w = np.asarray(w, dtype=np.float64)
    phi = float(np.exp(-dt_s / tau_s))
    x_prev = sigma * w[..., :1]
    from scipy.signal import lfilter  # scipy.signal takes seconds to import; only this filter needs it

    out, _ = lfilter([sigma * np.sqrt(1.0 - phi * phi)], [1.0, -phi], w[..., 1:], axis=-1, zi=phi * x_prev)
    return out

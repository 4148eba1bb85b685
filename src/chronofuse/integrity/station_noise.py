"""The noise of a real receiver's channels, per receiver and code: elevation-dependent, heavy-tailed, fitted.

What is modelled. In identification mode each channel ``n`` of a code (``"G C1C"``, ``"E C5Q"``) gives a
residual ``r_n(k)``: its clock bias at the known position less the other channels' clock
(:mod:`chronofuse.integrity.station_clock`). Its second difference in metres,
``d_n(k) = c (r_n(k) - 2 r_n(k-1) + r_n(k-2))``, is tested (the patent's high-order difference). Measured on
the IGS stations shipped in ``tests/data/rinex/igs`` (command in ``docs/integrity/stations.md``):

* the variance of ``d`` falls with elevation, by 5-10x between 10 and 60 degrees (code noise and multipath);
* its spectrum is not the white-phase MA(2) alone: below about 0.4 rad/epoch it has a floor that the white
  phase model puts at nearly zero (NYA1 C1C: 7x at 0.3 rad, 400x at 0.1 rad), from slowly varying
  multipath, ionosphere and broadcast orbit/clock errors; a chi-square window weighs exactly those
  directions most, so a model without the floor alarms in most windows;
* given the model, the statistic has heavier tails than chi-square: the empirical 1e-4 quantile of a
  20-difference window is 1.8x the chi-square's, while the 0.1 quantile matches. The local noise scale
  varies from window to window (multipath bursts), and a scale mixture of this kind is what a multivariate t
  (a chi-square scaled by an inverse-gamma variance) describes.

The model (:class:`CodeNoise`), fitted per code on a training stretch (:func:`fit_code_noise`):

1. **Elevation bands.** The differences are split into bands of elevation (10-20, 20-35, 35-55, 55-90 deg by
   default; a band with too few differences joins its neighbour). In each band the three-parameter spectrum of
   the high-order difference (white phase, white FM, random-walk FM; ``r(0..2)`` in m^2) is fitted by
   Whittle's likelihood over its unbroken runs (:func:`chronofuse.integrity.noise_model.fit_noise_whittle`),
   so each band's low-frequency floor is estimated where it matters. Between band centres each ``r(k)`` is
   interpolated linearly in elevation (held outside), giving a covariance and a whitener per whole degree.
2. **Tail.** On the training windows, whitened with their own elevation's model, ``T / n`` is fitted as
   ``scale * F(n, nu)`` by maximum likelihood: given a window's variance scale ``kappa``, ``T ~ kappa
   chi2(n)``, and ``kappa / scale ~ nu / chi2(nu)`` (inverse gamma) makes ``T / (n scale)`` an F(n, nu)
   variable (the multivariate t; Kotz & Nadarajah, "Multivariate t Distributions", 2004, 1.2). Measured on
   NYA1 C1C (fitted on six hours, checked on the next twelve): nu ~ 15, and the exceedances of the F
   thresholds are at or below nominal from 0.1 to 1e-4.
3. **The margin the training length deserves.** The fitted ``(log nu, log scale)`` carry the sampling
   uncertainty of the training: their covariance is the inverse of the observed information of the
   windows' likelihood, multiplied by ``n`` because a difference enters ``n`` overlapping windows (a window
   likelihood over overlapping windows counts each datum ``n`` times). The model used is the corner
   ``nu exp(-z s_nu)``, ``scale exp(z s_scale)`` with ``z = Phi^-1(confidence)`` (0.9 by default): the
   heavier tail and the larger scale, a margin that shrinks as the training grows.

``p_value(T, k, el)`` is then ``F.sf(T / (k scale), k, nu)`` for a window of ``k`` differences (the ``k``
leading rows of the whitener). A satellite arc that rises later is tested with this same model from its first
full window on (:mod:`chronofuse.integrity.station_identify` adds the arc's own check).

Units: ``d`` in metres (the second difference of the residual times the speed of light, not divided by the
interval); ``r_m2`` in m^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy import optimize, stats

from chronofuse.integrity.noise_model import difference_autocorrelation, fit_noise_whittle
from chronofuse.integrity.statistic import toeplitz_whiteners
from chronofuse.validation import check_scalar

__all__ = ["CodeNoise", "fit_code_noise", "DEFAULT_BANDS_DEG", "MIN_BAND_DIFFERENCES", "ELEVATION_GRID_DEG"]

#: Elevation bands (deg) of the fit: a band's lower and upper edge.
DEFAULT_BANDS_DEG = ((0.0, 20.0), (20.0, 35.0), (35.0, 55.0), (55.0, 90.01))

#: Fewest differences in unbroken runs of 8 or more for a band to be fitted on its own.
MIN_BAND_DIFFERENCES = 400

#: The whole degrees a whitener is tabulated at.
ELEVATION_GRID_DEG = np.arange(0, 91)

_MIN_TAIL_WINDOWS = 50


@dataclass(frozen=True)
class CodeNoise:
    """The fitted noise of one code (module docstring).

    ``code`` (e.g. ``"G C1C"``); ``centres_deg`` (bands,) the mean elevation of each fitted band; ``r_m2``
    (bands, 3) its ``r(0..2)`` (m^2); ``window`` (n); ``tail_dof`` (nu) and ``scale`` as used (with the
    margin), ``tail_dof_fit``/``scale_fit`` as fitted; ``n_differences``, ``n_windows`` of the training;
    ``confidence`` of the margin.
    """

    code: str
    centres_deg: np.ndarray
    r_m2: np.ndarray
    window: int
    tail_dof: float
    scale: float
    tail_dof_fit: float
    scale_fit: float
    n_differences: int
    n_windows: int
    confidence: float
    whiteners: np.ndarray = field(repr=False, compare=False, default=None)

    def __post_init__(self):
        if self.whiteners is None:
            object.__setattr__(self, "whiteners", toeplitz_whiteners(self.r_at(ELEVATION_GRID_DEG), self.window))

    def r_at(self, elevation_deg) -> np.ndarray:
        """``r(0..2)`` (m^2) at elevations (deg), shape ``elevation.shape + (3,)``: linear between band centres."""
        e = np.asarray(elevation_deg, dtype=np.float64)
        return np.stack([np.interp(e, self.centres_deg, self.r_m2[:, j]) for j in range(3)], axis=-1)

    def whitener_index(self, elevation_deg) -> np.ndarray:
        """The row of :attr:`whiteners` for each elevation (deg): the nearest whole degree, 0..90."""
        e = np.asarray(elevation_deg, dtype=np.float64)
        return np.clip(np.rint(np.where(np.isnan(e), 0.0, e)), 0, 90).astype(np.intp)

    def p_value(self, statistic, dof) -> np.ndarray:
        """Tail probability of window statistics ``T`` of ``dof`` differences under the model (NaN where
        ``dof == 0``): ``F.sf(T / (dof scale), dof, nu)``."""
        t = np.asarray(statistic, dtype=np.float64)
        k = np.asarray(dof)
        with np.errstate(invalid="ignore", divide="ignore"):
            p = stats.f.sf(t / (np.maximum(k, 1) * self.scale), np.maximum(k, 1), self.tail_dof)
        return np.where(k > 0, p, np.nan)

    def to_json(self) -> dict:
        return {"code": self.code, "centres_deg": [float(v) for v in self.centres_deg],
                "r_m2": [[float(v) for v in row] for row in self.r_m2], "window": int(self.window),
                "tail_dof": float(self.tail_dof), "scale": float(self.scale), "tail_dof_fit": float(self.tail_dof_fit),
                "scale_fit": float(self.scale_fit), "n_differences": int(self.n_differences),
                "n_windows": int(self.n_windows), "confidence": float(self.confidence)}

    @classmethod
    def from_json(cls, doc: dict) -> CodeNoise:
        return cls(code=str(doc["code"]), centres_deg=np.asarray(doc["centres_deg"], dtype=np.float64),
                   r_m2=np.asarray(doc["r_m2"], dtype=np.float64), window=int(doc["window"]),
                   tail_dof=float(doc["tail_dof"]), scale=float(doc["scale"]), tail_dof_fit=float(doc["tail_dof_fit"]),
                   scale_fit=float(doc["scale_fit"]), n_differences=int(doc["n_differences"]),
                   n_windows=int(doc["n_windows"]), confidence=float(doc["confidence"]))


def _band_fits(d_m: np.ndarray, elevation_deg: np.ndarray, bands) -> tuple[np.ndarray, np.ndarray, int]:
    """Per band (merged while too small): the mean elevation and the Whittle ``r(0..2)`` (m^2)."""
    groups: list[list[tuple[float, float]]] = []
    counts = []
    for lo, hi in bands:
        inside = (elevation_deg >= lo) & (elevation_deg < hi) & np.isfinite(d_m)
        counts.append(int(inside.sum()))
        groups.append([(lo, hi)])
    # merge a band with too few differences into its neighbour (upwards, the last downwards)
    i = 0
    while i < len(groups) and len(groups) > 1:
        if counts[i] < MIN_BAND_DIFFERENCES:
            j = i + 1 if i + 1 < len(groups) else i - 1
            a, b = min(i, j), max(i, j)
            groups[a] = groups[a] + groups[b]
            counts[a] += counts[b]
            del groups[b], counts[b]
            i = 0
            continue
        i += 1
    centres, rs = [], []
    total = 0
    for group in groups:
        inside = np.zeros(d_m.shape, dtype=bool)
        for lo, hi in group:
            inside |= (elevation_deg >= lo) & (elevation_deg < hi)
        d = np.where(inside, d_m, np.nan)
        ok = inside & np.isfinite(d_m)
        if ok.sum() < 8:
            continue
        h0, hm2, sig = fit_noise_whittle(d, 1.0)
        rs.append(difference_autocorrelation(h0, hm2, sig, 1.0))
        centres.append(float(np.mean(elevation_deg[ok])))
        total += int(ok.sum())
    if not rs:
        raise ValueError("no elevation band holds an unbroken run of 8 differences")
    order = np.argsort(centres)
    return np.asarray(centres)[order], np.asarray(rs)[order], total


def window_statistics(d_m: np.ndarray, elevation_deg: np.ndarray, whiteners: np.ndarray, window: int) -> np.ndarray:
    """``T`` of every full window of each channel, shape (channels, epochs) (NaN without a full unbroken
    window): ``|D(el) v|^2`` with ``v`` the last ``window`` differences and ``D`` the whitener at the
    elevation of the window's last epoch. ``d_m`` and ``elevation_deg`` are (channels, epochs)."""
    ch, ep = d_m.shape
    out = np.full((ch, ep), np.nan)
    if ep < window:
        return out
    win = sliding_window_view(d_m, window, axis=1)  # (ch, ep - n + 1, n)
    full = np.isfinite(win).all(axis=-1)
    rows, cols = np.nonzero(full)
    if rows.size == 0:
        return out
    last = cols + window - 1
    e = np.clip(np.rint(np.nan_to_num(elevation_deg[rows, last])), 0, 90).astype(np.intp)
    for start in range(0, rows.size, 1 << 15):
        sl = slice(start, start + (1 << 15))
        w = np.einsum("kij,kj->ki", whiteners[e[sl]], win[rows[sl], cols[sl]])
        out[rows[sl], last[sl]] = np.einsum("ki,ki->k", w, w)
    return out


def _fit_tail(t_over_n: np.ndarray, n: int) -> tuple[float, float, np.ndarray]:
    """ML ``(nu, scale)`` of ``T/n ~ scale F(n, nu)`` and the covariance of ``(log nu, log scale)``."""
    x = t_over_n[np.isfinite(t_over_n) & (t_over_n > 0)]

    def nll(p):
        lnu, ls = p
        nu = math.exp(min(lnu, 9.0))
        return -float(np.sum(stats.f.logpdf(x / math.exp(ls), n, nu)) - x.size * ls)

    start = [math.log(30.0), math.log(max(float(np.median(x)), 1e-6))]
    res = optimize.minimize(nll, start, method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-6, "maxiter": 2000})
    lnu, ls = float(min(res.x[0], 9.0)), float(res.x[1])
    h = _hessian(nll, np.array([lnu, ls]))
    try:
        cov = np.linalg.inv(h)
    except np.linalg.LinAlgError:
        cov = np.full((2, 2), np.inf)
    if not np.all(np.isfinite(cov)) or cov[0, 0] <= 0 or cov[1, 1] <= 0:
        cov = np.diag([np.inf, np.inf])
    return math.exp(lnu), math.exp(ls), cov * n


def _hessian(f, x: np.ndarray, step: float = 1e-3) -> np.ndarray:
    h = np.zeros((x.size, x.size))
    for i in range(x.size):
        for j in range(x.size):
            ei, ej = np.eye(x.size)[i] * step, np.eye(x.size)[j] * step
            h[i, j] = (f(x + ei + ej) - f(x + ei - ej) - f(x - ei + ej) + f(x - ei - ej)) / (4 * step * step)
    return h


def fit_code_noise(code: str, d_m: np.ndarray, elevation_deg: np.ndarray, *, window: int = 20,
                   confidence: float = 0.9, bands=DEFAULT_BANDS_DEG) -> CodeNoise:
    """Fit one code's model (module docstring) on training second differences ``d_m`` (channels, epochs), m,
    NaN = none, with the elevation of each (deg, same shape). Raises ``ValueError`` when the training holds
    too little (no band with a run of 8 differences, or fewer than 50 full windows for the tail)."""
    check_scalar(window, "window", min_val=3, integer=True)
    check_scalar(confidence, "confidence", min_val=0.5, max_val=1.0, include_max=False)
    d = np.asarray(d_m, dtype=np.float64)
    el = np.asarray(elevation_deg, dtype=np.float64)
    centres, rs, n_diff = _band_fits(d, el, bands)
    provisional = CodeNoise(code, centres, rs, window, math.inf, 1.0, math.inf, 1.0, n_diff, 0, confidence)
    t = window_statistics(d, el, provisional.whiteners, window)
    n_windows = int(np.isfinite(t).sum())
    if n_windows < _MIN_TAIL_WINDOWS:
        raise ValueError(f"{code}: {n_windows} full windows of {window} differences in training (need "
                         f"{_MIN_TAIL_WINDOWS}); train longer")
    nu, scale, cov = _fit_tail(t[np.isfinite(t)] / window, window)
    z = float(stats.norm.ppf(confidence))
    s_nu, s_scale = math.sqrt(cov[0, 0]), math.sqrt(cov[1, 1])
    nu_used = nu * math.exp(-z * s_nu) if math.isfinite(s_nu) else 2.0
    scale_used = scale * math.exp(z * s_scale) if math.isfinite(s_scale) else scale * 2.0
    return CodeNoise(code, centres, rs, window, max(nu_used, 2.0), scale_used, nu, scale, n_diff, n_windows,
                     confidence, provisional.whiteners)

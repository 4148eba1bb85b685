"""The one result type every stability statistic returns."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Deviation:
    """A stability statistic evaluated at a set of averaging times.

    All arrays have shape ``(k,)``, one entry per averaging time.

    Attributes
    ----------
    statistic : str
        Name of the statistic (``"adev"``, ``"mtie"``, ...).
    tau_s : ndarray of shape (k,)
        Averaging (observation) times in seconds.
    dev : ndarray of shape (k,)
        The deviation (seconds for TDEV/TTOTDEV/TIE rms/MTIE, dimensionless otherwise), bias-corrected
        where the statistic has a correction and ``bias_corrected`` is true.
    n : ndarray of int of shape (k,)
        Number of terms averaged (Stable32's ``#`` column).
    alpha : ndarray of int of shape (k,)
        Identified power-law noise exponent of fractional frequency, ``S_y(f) ~ f**alpha``, in -2..2
        (Stable32's ``Alpha`` column); used for the EDF and bias correction.
    edf : ndarray of shape (k,)
        Equivalent degrees of freedom (NaN where the statistic has no chi-square interval, e.g. MTIE).
    lo, hi : ndarray of shape (k,)
        Confidence interval bounds on ``dev`` at confidence ``ci`` (NaN where ``edf`` is NaN).
    alpha_method : ndarray of str of shape (k,)
        How ``alpha`` was identified at each tau: ``"acf"`` (lag-1 autocorrelation, 30 or more frequency
        averages), ``"b1"`` (B1/R(n) ratio, fewer averages: less certain, and the EDF and interval with
        it) or ``"held"`` (too few averages: the alpha of the nearest identified tau).
    ci : float
        Confidence factor of the interval (0.683 is Stable32's default, "1 sigma").
    bias_corrected : bool
        Whether the total-deviation bias correction was applied.
    filled : int
        Number of missing (NaN) phase samples filled by interpolation before computing, for
        statistics that cannot skip gaps; 0 otherwise.
    skipped : int
        Number of missing (NaN) phase samples whose terms were skipped.
    gap_rule : str
        How missing samples were handled: ``"samples"`` (a term is skipped when one of its own phase
        samples is missing), ``"span"`` (when any sample between its first and last is: no term bridges a
        gap), ``"window"`` (MTIE: each window's extremes over the samples present in it) or ``"fill"``
        (gaps interpolated linearly, ends trimmed). With gaps skipped, ``edf`` comes from the terms used.
    """

    statistic: str
    tau_s: np.ndarray
    dev: np.ndarray
    n: np.ndarray
    alpha: np.ndarray
    edf: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    alpha_method: np.ndarray | None = None
    ci: float = 0.683
    bias_corrected: bool = False
    filled: int = 0
    skipped: int = 0
    gap_rule: str = "samples"

    def to_dict(self) -> dict:
        """JSON-ready dict: ``{"tau": [...], "dev": [...], "lo": [...], "hi": [...], ...}`` (NaN -> None)."""

        def clean(a):
            return [None if (isinstance(v, float) and not np.isfinite(v)) else v for v in np.asarray(a).tolist()]

        return {
            "tau": clean(self.tau_s),
            "dev": clean(self.dev),
            "lo": clean(self.lo),
            "hi": clean(self.hi),
            "n": clean(self.n),
            "alpha": clean(self.alpha),
            "alpha_method": None if self.alpha_method is None else [str(v) for v in self.alpha_method],
            "edf": clean(self.edf),
            "bias_corrected": self.bias_corrected,
            "filled": self.filled,
            "skipped": self.skipped,
            "gap_rule": self.gap_rule,
        }

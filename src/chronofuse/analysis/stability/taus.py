"""Averaging-time grids. ``taus`` is always an array; these helpers build the usual ones."""

from __future__ import annotations

import numpy as np

from chronofuse.validation import check_scalar

SPACINGS = ("octave", "decade", "all")


def averaging_factors(max_m: int, spacing: str = "octave") -> np.ndarray:
    """Averaging factors ``m`` (integers >= 1) up to ``max_m``.

    ``octave``: 1, 2, 4, 8, ...; ``decade``: 1, 2, 4, 10, 20, 40, 100, ... (Stable32's decade grid);
    ``all``: every integer.
    """
    max_m = int(max_m)
    if max_m < 1:
        return np.zeros(0, dtype=np.int64)
    if spacing == "octave":
        m = 2 ** np.arange(int(np.floor(np.log2(max_m))) + 1)
    elif spacing == "decade":
        decades = 10 ** np.arange(int(np.floor(np.log10(max_m))) + 1)
        m = (decades[:, None] * np.array([1, 2, 4])[None, :]).ravel()
    elif spacing == "all":
        m = np.arange(1, max_m + 1)
    else:
        raise ValueError(f"spacing == {spacing!r}, must be one of {list(SPACINGS)}")
    m = m[m <= max_m]
    return m.astype(np.int64)


def parse_taus(spec: str, rate_hz: float) -> np.ndarray | str:
    """Parse a user's tau specification: ``octave``, ``decade``, ``all`` or a comma list of seconds.

    Returns the spacing name unchanged, or an array of taus in seconds.
    """
    spec = spec.strip()
    if spec in SPACINGS:
        return spec
    try:
        taus = np.array([float(t) for t in spec.split(",") if t.strip()], dtype=float)
    except ValueError as exc:
        raise ValueError(f"taus == {spec!r}, must be 'octave', 'decade', 'all' or comma-separated seconds") from exc
    if taus.size == 0 or np.any(taus <= 0) or not np.all(np.isfinite(taus)):
        raise ValueError(f"taus == {spec!r}, must be positive finite seconds")
    return taus


def taus_to_factors(tau_s: np.ndarray, rate_hz: float, *, tau_factor: float = 1.0) -> np.ndarray:
    """Convert averaging times to integer averaging factors ``m = tau / (tau_factor * tau0)``.

    A tau that is not (within 1e-6 relative) an integer multiple of the sample interval is an error.
    """
    check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
    tau_s = np.atleast_1d(np.asarray(tau_s, dtype=float))
    m_float = tau_s * rate_hz / tau_factor
    m = np.rint(m_float).astype(np.int64)
    bad = (m < 1) | (np.abs(m_float - m) > 1e-6 * np.maximum(m_float, 1.0))
    if bad.any():
        raise ValueError(
            f"tau_s == {tau_s[bad].tolist()}, must be whole multiples of {tau_factor}/rate_hz = {tau_factor / rate_hz} s"
        )
    return m

"""Averaging-time grids. The engine takes ``tau_s`` as an array only; these helpers build the usual ones.

``tau_grid("octave", n_points, rate_hz, statistic)`` gives the averaging times (seconds) of Stable32's
octave, decade or all-factors grid within a statistic's range for a record of ``n_points`` samples;
``parse_taus`` turns the CLI's ``--taus`` text into such an array.
"""

from __future__ import annotations

import numpy as np

from chronofuse.analysis.stability.factors import SPACINGS, averaging_factors  # noqa: F401 (re-exported)
from chronofuse.analysis.stability.registry import STATISTICS
from chronofuse.validation import InputError, check_choice, check_scalar

def tau_grid(kind: str, n_points: int, rate_hz: float, statistic: str = "oadev") -> np.ndarray:
    """Averaging times (s) of a standard grid within ``statistic``'s range, shape (k,).

    Parameters
    ----------
    kind : {"octave", "decade", "all"}
        The grid of averaging factors (see :func:`averaging_factors`).
    n_points : int
        Phase samples in the record (N + 1 for N frequency samples).
    rate_hz : float
        Sample rate, > 0.
    statistic : str
        A key of ``STATISTICS``: its largest averaging factor for ``n_points`` bounds the grid, and Theo1
        keeps the even factors at ``tau = 0.75 m / rate_hz``.

    Raises
    ------
    InputError
        When the record is too short for a single averaging time of the statistic.
    """
    check_choice(kind, "kind", SPACINGS)
    check_choice(statistic, "statistic", STATISTICS)
    check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
    check_scalar(n_points, "n_points", min_val=0, integer=True)
    spec = STATISTICS[statistic]
    if spec.grid is not None:  # TheoH: two grids, one either side of its split
        taus = spec.grid(kind, int(n_points), rate_hz)
        if taus.size == 0:
            raise InputError(f"the record has {n_points} samples, too few for {statistic}")
        return taus
    m = averaging_factors(int(spec.max_m(int(n_points))), kind)
    if spec.m_step > 1:
        m = m[m % spec.m_step == 0]
    if m.size == 0:
        raise InputError(f"the record has {n_points} samples, too few for {statistic}")
    return spec.tau_factor * m / rate_hz


def parse_taus(spec: str, n_points: int, rate_hz: float, statistic: str) -> np.ndarray:
    """Averaging times (s, shape (k,)) for the CLI's ``--taus``: ``octave``, ``decade``, ``all`` (the grid of
    :func:`tau_grid` for ``statistic``) or a comma list of seconds."""
    spec = spec.strip()
    if spec in SPACINGS:
        return tau_grid(spec, n_points, rate_hz, statistic)
    try:
        taus = np.array([float(t) for t in spec.split(",") if t.strip()], dtype=float)
    except ValueError as exc:
        raise InputError(f"{{taus}} == {spec!r}, must be 'octave', 'decade', 'all' or comma-separated seconds",
                         fields=("taus",)) from exc
    if taus.size == 0 or np.any(taus <= 0) or not np.all(np.isfinite(taus)):
        raise InputError(f"{{taus}} == {spec!r}, must be positive finite seconds", fields=("taus",))
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
        raise InputError(
            f"tau_s == {tau_s[bad].tolist()}, must be whole multiples of {tau_factor}/rate_hz = {tau_factor / rate_hz} s"
        )
    return m

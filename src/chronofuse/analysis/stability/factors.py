"""Averaging factors ``m`` of Stable32's octave, decade and all-factors grids (the engine's ``tau = m / rate``).

Apart from :mod:`chronofuse.analysis.stability.taus` (which re-exports them), because the statistics' table
(:mod:`chronofuse.analysis.stability.registry`) and TheoH's grid need the factors without the table.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SPACINGS", "averaging_factors"]

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
